// Common part of the contact kernels (scan.wgsl, grid.wgsl, collide.wgsl):
// bindings, per-particle accessors, failure reports. The host prepends the
// header (real, DIM, REAL_MAX).
//
// Group 0 is bound once per backend: the resident positions x and p and the
// step status word of the backend, then the contact buffers. Group 1 holds
// one parameter block per kernel call (dynamic offset), like the step
// kernels' group 1.
//
//   props     per particle vec4 [w, r, pad, 0]: inverse mass, radius, box
//             pad r + margin (f32: rounded up on the host)
//   boxes     per box VECS vec4 of lower corner, then VECS of upper corner
//   snapshot  per particle VECS vec4 of the iterate y (collide), then from
//             count · VECS on, VECS of the substep start p (broadphase)
//   counters  [0] longest contact list, [1] box that broke the grid rule
//             (NONE: none), [2] active contacts (report), [3] first
//             invocation whose loops were cut short (NONE: none), then one
//             counter per hash bucket
//   words     per box: bucket | bucket order | list length | active, then
//             the scan's block sums, then the first slot of every bucket
//   lists     slot-major: entry t of particle k at lists[t · count + k]
//   scratch   reduction partials, the grid frame, the report
//
// Points in the contact buffers are vec4-packed (VECS = ⌈N/4⌉ vec4 per
// point, unused components 0): one wide load per 4 coordinates.

struct ContactParams {
    call: u32,       // index of this kernel call within the step (status)
    count: u32,      // particles (boxes)
    buckets: u32,    // hash buckets, a power of two
    slots: u32,      // list slots per particle
    blocks: u32,     // scan blocks of the bucket counters
    flags: u32,      // bit 0: skip pairs of two fixed particles
    axis: u32,       // grid axis to use first (≥ DIM: widest spread first)
    pad0: u32,
    friction: real,  // Coulomb μ between particles
}

@group(0) @binding(0) var<storage, read_write> x: array<real>;
@group(0) @binding(1) var<storage, read> p: array<real>;
@group(0) @binding(2) var<storage, read_write> status: array<atomic<u32>, 4>;
@group(0) @binding(3) var<storage, read> props: array<vec4<real>>;
@group(0) @binding(4) var<storage, read_write> boxes: array<vec4<real>>;
@group(0) @binding(5) var<storage, read_write> snapshot: array<vec4<real>>;
@group(0) @binding(6) var<storage, read_write> scratch: array<real>;
@group(0) @binding(7) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(8) var<storage, read_write> words: array<u32>;
@group(0) @binding(9) var<storage, read_write> lists: array<u32>;
@group(1) @binding(0) var<storage, read> cparams: ContactParams;

const NONE: u32 = 0xffffffffu;
const VECS: u32 = (DIM + 3u) / 4u;
const CONTACT_WORKGROUP: u32 = 64u;
const COUNTERS: u32 = 4u;      // status counters before the buckets
const MAX_DEGREE: u32 = 0u;
const GRID_BROKEN: u32 = 1u;
const ACTIVE: u32 = 2u;
const CUT_SHORT: u32 = 3u;
const REAL_IS_F32: bool = REAL_MAX == real(3.4028234663852886e38);

// Scratch layout: per-thread partial bounds (grid.wgsl), the grid frame,
// the report (collide.wgsl: deepest overlap, then one value per particle).
const BOUND_THREADS: u32 = 1024u; // 16 workgroups of CONTACT_WORKGROUP
const FRAME: u32 = 3u * DIM * BOUND_THREADS;
const REPORT: u32 = FRAME + 9u;

// Linear invocation index over a 2D grid of workgroups.
fn invocation(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * CONTACT_WORKGROUP;
}

// ---- per-particle accessors (one place for the layout of x and p)

fn position(i: u32, a: u32) -> real {
    return x[i * DIM + a];
}

fn set_position(i: u32, a: u32, value: real) {
    x[i * DIM + a] = value;
}

fn start(i: u32, a: u32) -> real {
    return p[i * DIM + a];
}

fn inverse_mass(i: u32) -> real {
    return props[i].x;
}

fn radius(i: u32) -> real {
    return props[i].y;
}

fn box_pad(i: u32) -> real {
    return props[i].z;
}

// Point `at` (VECS vec4) of a vec4-packed buffer, unpacked.
fn unpack(q: array<vec4<real>, VECS>) -> array<real, DIM> {
    var out: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        out[a] = q[a / 4u][a % 4u];
    }
    return out;
}

fn pack(v: array<real, DIM>) -> array<vec4<real>, VECS> {
    var out: array<vec4<real>, VECS>;
    for (var c = 0u; c < VECS; c++) {
        out[c] = vec4<real>(0.0);
    }
    for (var a = 0u; a < DIM; a++) {
        out[a / 4u][a % 4u] = v[a];
    }
    return out;
}

fn box_lo(i: u32) -> array<real, DIM> {
    var q: array<vec4<real>, VECS>;
    for (var c = 0u; c < VECS; c++) {
        q[c] = boxes[2u * VECS * i + c];
    }
    return unpack(q);
}

fn box_hi(i: u32) -> array<real, DIM> {
    var q: array<vec4<real>, VECS>;
    for (var c = 0u; c < VECS; c++) {
        q[c] = boxes[2u * VECS * i + VECS + c];
    }
    return unpack(q);
}

fn store_box(i: u32, lo: array<real, DIM>, hi: array<real, DIM>) {
    let l = pack(lo);
    let h = pack(hi);
    for (var c = 0u; c < VECS; c++) {
        boxes[2u * VECS * i + c] = l[c];
        boxes[2u * VECS * i + VECS + c] = h[c];
    }
}

// The iterate y_i of the running contact iteration.
fn iterate_point(i: u32) -> array<real, DIM> {
    var q: array<vec4<real>, VECS>;
    for (var c = 0u; c < VECS; c++) {
        q[c] = snapshot[VECS * i + c];
    }
    return unpack(q);
}

// The substep start p_i, as copied by the broadphase.
fn start_point(i: u32) -> array<real, DIM> {
    var q: array<vec4<real>, VECS>;
    for (var c = 0u; c < VECS; c++) {
        q[c] = snapshot[VECS * (cparams.count + i) + c];
    }
    return unpack(q);
}

// ---- the per-box words

fn bucket_of(i: u32) -> u32 {
    return words[i];
}

fn sorted_box(slot: u32) -> u32 {
    return words[cparams.count + slot];
}

fn list_length_at() -> u32 {
    return 2u * cparams.count;
}

fn active_at() -> u32 {
    return 3u * cparams.count;
}

fn scan_sums_at() -> u32 {
    return 4u * cparams.count;
}

// First slot of bucket b in the bucket order (b ≤ buckets).
fn bucket_start(b: u32) -> u32 {
    if (b >= cparams.buckets) {
        return cparams.count;
    }
    return words[4u * cparams.count + cparams.blocks + b];
}

fn list_entry(k: u32, t: u32) -> u32 {
    return lists[t * cparams.count + k];
}

// ---- failures, the rule of the step kernels (prelude.wgsl)

// True when an earlier call of this step failed: later calls do nothing.
fn failed_before() -> bool {
    return atomicLoad(&status[0]) < cparams.call;
}

// Records a failure of this call at `index` (the smallest index wins).
fn fail(index: u32) {
    atomicMin(&status[0], cparams.call);
    atomicMin(&status[1], index);
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
        atomicMin(&counters[CUT_SHORT], invocation_index);
    }
}

// Not NaN and not ±Inf.
fn finite(a: real) -> bool {
    return abs(a) <= REAL_MAX;
}
