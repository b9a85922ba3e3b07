// Common prelude of every hyperpbd kernel. The host prepends:
//   alias real = f32;            (or f64)
//   const DIM: u32 = N;          spatial dimension
//   const POINTS: u32 = (N+1)·N; coordinates of the largest element
//   const MAT: u32 = N·N;        largest square matrix
//   const MINOR: u32 = max((N−1)², 1)
//   const REAL_MAX: real = …;    largest finite real
//
// One bind group (group 0) holds the resident state; group 1 holds the
// parameters of one kernel call, selected per dispatch by a dynamic offset.

struct Params {
    count: u32,        // invocations that do work in this call
    first: u32,        // first slot of this color within the family
    elem_base: u32,    // offset of the family's particle indices in `elements`
    slot_base: u32,    // offset of the family's slots in `rest`, `lambda`, `resid`
    arity: u32,        // particles per element
    call: u32,         // index of this call within the step (error reports)
    flags: u32,        // predict: bit 0 gravity, bit 1 force; project_distance: 1 = tether; residual: family kind
    family: u32,       // family index (report slot)
    alpha_tilde: real, // α / h²
    h: real,           // substep length
    friction: real,    // Coulomb μ of a contact family
    factor: real,      // damping factor exp(−rate h)
    normal: array<real, DIM>,
    gravity: array<real, DIM>,
}

@group(0) @binding(0) var<storage, read_write> x: array<real>;
@group(0) @binding(1) var<storage, read_write> v: array<real>;
@group(0) @binding(2) var<storage, read_write> p: array<real>;
@group(0) @binding(3) var<storage, read> inv_mass: array<real>;
@group(0) @binding(4) var<storage, read> gravity_scale: array<real>;
@group(0) @binding(5) var<storage, read> force: array<real>;
@group(0) @binding(6) var<storage, read> elements: array<u32>;
@group(0) @binding(7) var<storage, read> rest: array<real>;
@group(0) @binding(8) var<storage, read_write> lambda: array<real>;
// status[0]: first failing call (0xffffffff: none), status[1]: smallest
// failing slot or particle of that call.
@group(0) @binding(9) var<storage, read_write> status: array<atomic<u32>, 4>;
// Per-slot residuals, then per-family [max violation, active contacts].
@group(0) @binding(10) var<storage, read_write> resid: array<real>;
@group(0) @binding(11) var<storage, read_write> report: array<real>;
@group(1) @binding(0) var<storage, read> params: Params;

const NONE: u32 = 0xffffffffu;
const WORKGROUP: u32 = 64u;

// Linear invocation index over a 2D grid of workgroups (more than 65535
// workgroups are spread over y).
fn linear_index(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * WORKGROUP;
}

// True when an earlier call of this step failed: later calls do nothing.
// Calls are ordered, so invocations of one call all see the same answer.
fn failed_before() -> bool {
    return atomicLoad(&status[0]) < params.call;
}

// Records a failure of this call at `index`; the smallest index wins, so
// the report does not depend on scheduling.
fn fail(index: u32) {
    atomicMin(&status[0], params.call);
    atomicMin(&status[1], index);
}

// Exactly `a`, as a value the driver's optimiser cannot see through.
// WGSL cannot forbid reassociation or contraction (naga emits no
// NoContraction), and lavapipe uses that freedom: in R^2 it turned the
// contact's (n₀x₀ + n₁x₁) − r into n₀x₀ + (n₁x₁ − r), off the golden path
// by ulps. A sum passed through here is rounded as written before it is
// used. The condition is false on every call (no call has index NONE),
// but only the run knows it.
fn kept(a: real) -> real {
    return select(a, -a, params.call == NONE);
}

// Not NaN and not ±Inf (WGSL has no isnan/isinf).
fn finite(a: real) -> bool {
    return abs(a) <= REAL_MAX;
}
