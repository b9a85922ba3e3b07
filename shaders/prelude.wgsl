// Common prelude of the particle kernels (the XPBD step, particle contact).
// The host prepends (gpu/src/shader.rs):
//   alias real = f32;            (or f64)
//   const DIM: u32 = N;          spatial dimension
//   const POINTS: u32 = (N+1)·N; coordinates of the largest element
//   const MAT: u32 = N·N;        largest square matrix
//   const MINOR: u32 = max((N−1)², 1)
//   const REAL_MAX: real = …;    largest finite real
//   const WORKGROUP: u32 = …;    the workgroup size of every entry point
//   const VEC: u32 = ⌊N/4⌋ + 1;  vec4 words per particle record
//
// PARTICLE RECORDS — the one place the per-particle layout is decided
// (host side: gpu/src/layout.rs; measured choice: docs/performance.md).
// x, v, p and force hold one record of VEC vec4 words per particle:
//
//   lanes 0..DIM   the vector's coordinates
//   last lane      (4·VEC − 1) the inverse mass w in position records (x, p);
//                  0 in v and force
//   other lanes    0
//
// e.g. DIM = 3: [x y z w];  DIM = 4: [x0 x1 x2 x3][0 0 0 w].
// A particle's vector is then one access of 16·VEC bytes: one instruction
// per lane on lavapipe, one 128-bit load per thread on a GPU with
// neighbouring threads reading neighbouring words (coalesced), and a
// projection reads an endpoint's position and inverse mass together.
//
// Every module composed with this prelude binds the particle buffers at
// group 0, bindings 0..=3, and reads and writes them ONLY through the record
// accessors below: change the layout in gpu/src/layout.rs (host packing and
// these accessors, side by side) and every kernel follows. Writers of x
// keep the last lane: they modify the loaded record and store it back.

@group(0) @binding(0) var<storage, read_write> x: array<vec4<real>>;
@group(0) @binding(1) var<storage, read_write> v: array<vec4<real>>;
@group(0) @binding(2) var<storage, read_write> p: array<vec4<real>>;
@group(0) @binding(3) var<storage, read> force: array<vec4<real>>;

// The accessors follow this prelude: record4.wgsl when VEC = 1 (a record
// in registers is a vec4), records.wgsl when VEC > 1 (an array of vec4):
//   alias Record = …;                       one particle's record in registers
//   fn load_x(i) -> Record, store_x(i, r)   and the same for v, p (load_force)
//   fn lane(r: ptr<function, Record>, a) -> real      coordinate a
//   fn set_lane(r: ptr<function, Record>, a, value)
//   fn inverse_mass_of(r: ptr<function, Record>) -> real   the last lane
//   fn set_last_lane(r: ptr<function, Record>, value)
//   fn word(r: ptr<function, Record>, c) -> vec4<real>, set_word(r, c, w)
//                                           vec4 word c < VEC, as stored
// (Records are passed by pointer: naga 30's SPIR-V writer fails on some
// calls that pass arrays by value.)

// BATCHES OF WORLDS (gpu/src/batch.rs): a module may run WORLDS
// worlds of one topology in each dispatch, world-major — world k's
// particle i is record k·WORLD_PARTICLES + i. `world` is the world of the
// running invocation (set by the runner that splits its index); with one
// world (every module but a batch's step) both are 0 and fold away.
override WORLD_PARTICLES: u32 = 0u;
var<private> world: u32 = 0u;

// Record index of particle i of the running world.
fn particle(i: u32) -> u32 {
    return world * WORLD_PARTICLES + i;
}

// Linear invocation index over a 2D grid of workgroups (more than 65535
// workgroups are spread over y).
fn linear_index(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * WORKGROUP;
}

// Not NaN and not ±Inf (WGSL has no isnan/isinf).
fn finite(a: real) -> bool {
    return abs(a) <= REAL_MAX;
}
