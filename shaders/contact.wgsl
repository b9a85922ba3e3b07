// Common part of the contact kernels (scan.wgsl, grid.wgsl, collide.wgsl):
// bindings, per-particle accessors, failure reports. The host prepends the
// header (real, DIM, REAL_MAX).
//
// Group 0 is bound once per backend: the resident positions x and p and the
// step status word of the backend, then the contact buffers. Group 1 holds
// one parameter block per kernel call (dynamic offset), like the step
// kernels' group 1.
//
//   props     per particle [w, r, pad, 0]: inverse mass, radius, box pad
//             r + margin (f32: rounded up on the host)
//   boxes     per box [min_0 … min_{N−1}, max_0 … max_{N−1}]
//   counters  [0] largest contact list, [1] box that broke the grid rule
//             (NONE: none), [2] active contacts (report), [3] unused,
//             then one counter per hash bucket
//   words     per box: bucket | bucket order | list length | active, then
//             the scan's block sums
//   lists     slot-major: entry t of particle k at lists[t · count + k]
//   scratch   reduction partials, the grid frame, the report

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
@group(0) @binding(3) var<storage, read> props: array<real>;
@group(0) @binding(4) var<storage, read_write> boxes: array<real>;
@group(0) @binding(5) var<storage, read_write> snapshot: array<real>;
@group(0) @binding(6) var<storage, read_write> scratch: array<real>;
@group(0) @binding(7) var<storage, read_write> counters: array<atomic<u32>>;
@group(0) @binding(8) var<storage, read_write> words: array<u32>;
@group(0) @binding(9) var<storage, read_write> lists: array<u32>;
@group(1) @binding(0) var<storage, read> cparams: ContactParams;

const NONE: u32 = 0xffffffffu;
const CONTACT_WORKGROUP: u32 = 64u;
const COUNTERS: u32 = 4u;      // status counters before the buckets
const MAX_DEGREE: u32 = 0u;
const GRID_BROKEN: u32 = 1u;
const ACTIVE: u32 = 2u;
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
    return props[4u * i];
}

fn radius(i: u32) -> real {
    return props[4u * i + 1u];
}

fn box_pad(i: u32) -> real {
    return props[4u * i + 2u];
}

fn box_min(i: u32, a: u32) -> real {
    return boxes[2u * DIM * i + a];
}

fn box_max(i: u32, a: u32) -> real {
    return boxes[2u * DIM * i + DIM + a];
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

// Not NaN and not ±Inf.
fn finite(a: real) -> bool {
    return abs(a) <= REAL_MAX;
}
