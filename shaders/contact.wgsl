// Common part of the contact kernels (scan.wgsl, grid.wgsl, collide.wgsl),
// after prelude.wgsl: bindings, layouts and their accessors, failure
// reports.
//
// Group 0 is bound once per backend: the particle records x v p force of
// the prelude (bindings 0..=3) and the step status word of the backend,
// then the contact buffers. Group 1 holds one parameter block per kernel
// call (dynamic offset).
//
// The contact buffers hold points as the prelude's particle records (VEC
// vec4: coordinates in lanes 0..N, one extra real in the last lane): one
// wide access reads a 3D point and its extra. Software adapters pay per
// access, not per byte, and real GPUs coalesce vec4 loads.
//
//   props     per particle vec4 [w, r, pad, μ]: inverse mass, radius, box
//             pad r + margin (f32: rounded up on the host), Coulomb μ
//             between particles of its world
//   boxes     per box: record (lower corner, index), record (upper corner, w)
//   cands     the same two records per box, in bucket order (bin_fill)
//   snapshot  per particle: record (iterate y, radius)
//   counters  per world [0] longest contact list, [1] first invocation
//             whose loops were cut short (NONE: none), [2] active contacts
//             (report), [3] unused, [4..7] per grid axis the most cells a
//             box spans minus one; then one counter per hash bucket
//   ranges    per bucket [first slot, end slot) in bucket order
//   words     per box: bucket | list length | active, then the scan's
//             block sums, then per world its list region (base, slots)
//   lists     entry t of particle k in lists[base + (t / 4) · count + k][t % 4]:
//             four entries per access, neighbouring particles adjacent
//   scratch   per world its report (deepest overlap), then per world its
//             block: reduction partials, the grid frame, per-particle report
//
// BATCHES OF WORLDS (gpu/src/batch.rs, gpu/src/backend/contact_step.rs): WORLDS worlds of
// `count` particles each, world-major. A per-particle invocation t is
// particle t − world · count of world ⌊t / count⌋ (`enter`); the prelude's
// particle(i) = world · WORLD_PARTICLES + i is its record in x v p and in
// every per-particle buffer above (props, boxes, snapshot, words). Each
// world has its own counters, grid frame, `buckets` hash buckets (bucket b
// of world w is bucket w · buckets + b: the scan runs over all worlds'
// buckets at once and each world's boxes fill slot ranges of their own in
// cands), report and list region with its own slots (grown on its own).
// So world k's lists and arithmetic are exactly its own single run's.
// With WORLDS = 1 every world term is 0: the single-world kernels.

struct ContactParams {
    call: u32,       // index of this kernel call within the step (status)
    count: u32,      // particles (boxes)
    buckets: u32,    // hash buckets, a power of two
    pad1: u32,       // (list slots: per world, in the list table)
    blocks: u32,     // scan blocks of every world's bucket counters
    flags: u32,      // bit 0: skip pairs of two fixed particles; bit 1: boxes from x, p
    axis: u32,       // grid axis to use first (≥ DIM: widest spread first)
    pad0: u32,
}

@group(0) @binding(4) var<storage, read_write> status: array<atomic<u32>, 4>;
@group(0) @binding(5) var<storage, read> props: array<vec4<real>>;
@group(0) @binding(6) var<storage, read_write> boxes: array<vec4<real>>;
@group(0) @binding(7) var<storage, read_write> cands: array<vec4<real>>;
@group(0) @binding(8) var<storage, read_write> snapshot: array<vec4<real>>;
@group(0) @binding(9) var<storage, read_write> scratch: array<real>;
@group(0) @binding(10) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(11) var<storage, read_write> ranges: array<vec2<u32>>;
@group(0) @binding(12) var<storage, read_write> words: array<u32>;
@group(0) @binding(13) var<storage, read_write> lists: array<vec4<u32>>;
@group(1) @binding(0) var<storage, read> cparams: ContactParams;

override WORLDS: u32 = 1u;

const NONE: u32 = 0xffffffffu;
const COUNTERS: u32 = 8u;      // status counters before the buckets
const MAX_DEGREE: u32 = 0u;
const CUT_SHORT: u32 = 1u;
const ACTIVE: u32 = 2u;
const SPAN: u32 = 4u;          // 3 counters: widest box in cells − 1, per grid axis
const REAL_IS_F32: bool = REAL_MAX == real(3.4028234663852886e38);

// Scratch layout of a world's block: per-thread partial bounds
// (grid.wgsl), the grid frame, the report (collide.wgsl: one value per
// particle from REPORT + 1 on).
const BOUND_THREADS: u32 = 1024u; // 16 workgroups of 64
const FRAME: u32 = 3u * DIM * BOUND_THREADS;
const REPORT: u32 = FRAME + 9u;

// ---- worlds

// The running world's list region (set by `enter` / `enter_world`).
var<private> list_base: u32 = 0u;
var<private> list_slots: u32 = 0u;

// Makes w the running world.
fn enter_world(w: u32) {
    world = w;
    let at = list_table_at() + 2u * w;
    list_base = words[at];
    list_slots = words[at + 1u];
}

// Enters the world of per-particle invocation t (< WORLDS · count);
// returns the particle's index within its world.
fn enter(t: u32) -> u32 {
    var w = 0u;
    if (WORLDS > 1u) {
        w = t / cparams.count;
    }
    enter_world(w);
    return t - w * cparams.count;
}

// Particles of every world together.
fn all_particles() -> u32 {
    return WORLDS * cparams.count;
}

// Buckets of every world together.
fn all_buckets() -> u32 {
    return WORLDS * cparams.buckets;
}

// Counter q of the running world's header.
fn counter(q: u32) -> u32 {
    return world * COUNTERS + q;
}

// The counter of bucket e (of all worlds' buckets).
fn bucket_counter(e: u32) -> u32 {
    return WORLDS * COUNTERS + e;
}

// Real q of the running world's scratch block.
fn scratch_at(q: u32) -> u32 {
    return WORLDS + world * (REPORT + 1u + cparams.count) + q;
}

// ---- records

// Records go through the prelude's accessors (record4.wgsl or
// records.wgsl): a Record is one vec4 or an array of VEC of them.
fn coords(q: Record) -> array<real, DIM> {
    var r = q;
    var out: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        out[a] = lane(&r, a);
    }
    return out;
}

fn extra(q: Record) -> real {
    var r = q;
    return inverse_mass_of(&r); // the last lane, whatever it holds
}

fn record(v: array<real, DIM>, e: real) -> Record {
    var out: Record;
    for (var c = 0u; c < VEC; c++) {
        set_word(&out, c, vec4<real>(0.0));
    }
    for (var a = 0u; a < DIM; a++) {
        set_lane(&out, a, v[a]);
    }
    set_last_lane(&out, e);
    return out;
}

// Lower (upper = false) or upper corner record of box i.
fn box_record(i: u32, upper: bool) -> Record {
    let at = (2u * particle(i) + u32(upper)) * VEC;
    var q: Record;
    for (var c = 0u; c < VEC; c++) {
        set_word(&q, c, boxes[at + c]);
    }
    return q;
}

fn store_box(i: u32, lo: Record, hi: Record) {
    var l = lo;
    var h = hi;
    let b = particle(i);
    for (var c = 0u; c < VEC; c++) {
        boxes[2u * VEC * b + c] = word(&l, c);
        boxes[(2u * b + 1u) * VEC + c] = word(&h, c);
    }
}

fn cand_record(slot: u32, upper: bool) -> Record {
    let at = (2u * slot + u32(upper)) * VEC;
    var q: Record;
    for (var c = 0u; c < VEC; c++) {
        set_word(&q, c, cands[at + c]);
    }
    return q;
}

// (y_i, r_i): the iterate of the running contact iteration and the radius.
fn iterate_record(i: u32) -> Record {
    var q: Record;
    for (var c = 0u; c < VEC; c++) {
        set_word(&q, c, snapshot[VEC * particle(i) + c]);
    }
    return q;
}

fn inverse_mass(i: u32) -> real {
    return props[particle(i)].x;
}

fn radius(i: u32) -> real {
    return props[particle(i)].y;
}

fn box_pad(i: u32) -> real {
    return props[particle(i)].z;
}

fn friction_of(i: u32) -> real {
    return props[particle(i)].w;
}

// ---- the per-box words and the lists

// Word q (0: bucket, 1: list length, 2: active pairs) of box i.
fn box_word(q: u32, i: u32) -> u32 {
    return q * all_particles() + particle(i);
}

fn bucket_of(i: u32) -> u32 {
    return words[box_word(0u, i)];
}

fn scan_sums_at() -> u32 {
    return 3u * all_particles();
}

fn list_table_at() -> u32 {
    return scan_sums_at() + cparams.blocks;
}

// Entries 4q … 4q + 3 of particle k's list.
fn list_quad(k: u32, q: u32) -> vec4<u32> {
    return lists[list_base + q * cparams.count + k];
}

fn set_list_quad(k: u32, q: u32, value: vec4<u32>) {
    lists[list_base + q * cparams.count + k] = value;
}

fn entry_at(k: u32, t: u32) -> u32 {
    return lists[list_base + (t / 4u) * cparams.count + k][t % 4u];
}

fn set_entry(k: u32, t: u32, value: u32) {
    lists[list_base + (t / 4u) * cparams.count + k][t % 4u] = value;
}

// ---- failures, the rule of the step kernels (prelude.wgsl)

// True when an earlier call of this step failed: later calls do nothing.
fn failed_before() -> bool {
    return atomicLoad(&status[0]) < cparams.call;
}

// Records a failure of this call at `index` (the smallest index wins).
// In a batch the lowest failing world too (status[3], as step.wgsl).
fn fail(index: u32) {
    atomicMin(&status[0], cparams.call);
    atomicMin(&status[1], index);
    if (WORLDS > 1u) {
        atomicMin(&status[3], world);
    }
}

// llvmpipe (lavapipe) ends every loop of an invocation once 65 535 loop
// iterations have run in it, all loops together, silently. After that a
// loop runs its body once and stops, so a two-iteration probe at the end
// of a kernel tells whether any loop before it was cut short; the kernels
// whose loops depend on the data report it (a typed error on the host,
// never a silently short list).
fn check_loops(invocation_index: u32) {
    // A trip count the compiler cannot see (flags never has bit 31), so
    // the probe stays a loop instead of being unrolled.
    let trips = 2u + (cparams.flags >> 31u);
    var probe = 0u;
    for (var t = 0u; t < trips; t++) {
        probe++;
    }
    if (probe != 2u) {
        atomicMin(&counters[counter(CUT_SHORT)], invocation_index);
    }
}

