// The XPBD step on the device: its bindings, the call blocks, and the two
// runners that execute a schedule of calls (gpu/src/xpbd/schedule.rs).
//
// A step is a list of CALLS — one per kernel call of the plan (predict,
// one colour of one family's projections, velocity, friction, damping, per
// substep), then one residual call per family — each a `Call` block in
// `calls`. A DISPATCH runs the calls `here.first_call .. here.end_call`:
//
//   particles       one invocation per particle runs every call of the range
//                   (up to 8, fixed per pipeline: OP0..OP7 below) on that
//                   particle, its records held in registers: loaded once,
//                   stored once (IO). The range holds only per-particle calls
//                   (predict, contact projection, velocity, friction,
//                   damping), which read and write that particle alone, so
//                   running them particle by particle is the golden order
//                   for each particle.
//   project         one invocation per element of one colour (project.wgsl;
//                   its op OP0)
//   residual/reduce one workgroup per chunk / per family (residual.wgsl)
//   step_small      ONE workgroup runs every call of the range in order, its
//                   invocations striding over the call's elements, with a
//                   storage barrier between calls: colours stay race-free
//                   and ordered, so the results are those of the dispatch-
//                   per-call schedule. Per-particle calls and distance /
//                   tether colours only (the measure kernels' large private
//                   arrays are kept out of this one long-running workgroup:
//                   lavapipe miscomputes them there, docs/performance.md).
//
// THE CALL RUNNING NOW is the private `call`, copied in before each call
// runs: from the dispatch's uniform block (`here.calls`, the calls of a
// `particles`, `project` or `guard` dispatch; flags from the pipeline,
// `take_call`) or, for the runners that loop over
// calls the host cannot list in one block (step_small, residual), from
// the storage array `calls`. Kernels read their parameters from `call`
// only. A uniform block is read once per SIMD batch of invocations on
// lavapipe (a per-lane storage read is a masked 8-lane loop each, which
// made the parameter reads as dear as the particle data;
// docs/performance.md).
//
// Failure: `fail` notes the invocation's first failure (call, index) in
// private variables; `record_failure`, once at the end of an invocation's
// work (per call in step_small), puts it in the status block: the first
// failing call in status[0] and, for that call only, the smallest failing
// index in status[1] (a call records its index when no earlier call had
// failed as it recorded itself). Calls are not skipped after a failure —
// the step is refused and rolled back whatever they compute — so no
// kernel reads the status per invocation, and each invocation touches it
// at one place: on lavapipe every atomic and every branch of a kernel
// costs its SIMD batch whether or not a lane takes it. In the exact and
// small schedules every call runs after the calls before it recorded
// themselves (dispatch order, storage barriers), so (call, index) are
// those of the first failure, as the CPU names it. When several calls
// share a dispatch (fused), a later call may fail before an earlier one
// records itself; the host then replays the step one call per dispatch
// (the exact schedule) to name the failure.

// One kernel call of a step (encoded by gpu/src/xpbd/call.rs).
struct Call {
    op: u32,          // OP_*
    count: u32,       // invocations: particles, or elements of the colour / family
    first: u32,       // first slot of this colour within the family
    family: u32,      // family index (report slot)
    elem_base: u32,   // offset of the family's particle indices in `elements`
    slot_base: u32,   // offset of the family's slots in `rest`, `lambda`
    arity: u32,       // particles per element
    call: u32,        // index of the kernel call within the step (error reports)
    flags: u32,       // FLAG_*
    kind: u32,        // residual: RESIDUAL_* (gpu/src/codes.rs)
    slot_map: u32,    // contact, friction: offset of the family's particle → slot map;
                      // material: offset of the family's rest data in `rest`
    chunk: u32,       // residual: first chunk of the family in `partials`
    io: u32,          // records this call reads and writes (IO_*), when run alone
    carried: u32,     // FLAG_PRIMAL projection: offset of the family's displacements in `carried`
    factors: u32,     // FLAG_PRIMAL material: offset of the family's Newton factors in `carried`
    absent: u32,      // batch: 1 where this world's own plan has no such call
                      // (a friction or damping response of the union of the
                      // worlds' stages): the world skips it (`skipped`)
    alpha_tilde: real, // α / h²
    h: real,           // substep length
    friction: real,    // Coulomb μ of a contact family; Lamé μ of a material family
    factor: real,      // damping factor exp(−rate h); Lamé λ of a material family
    // Vectors as records (lanes 0..DIM; a uniform block's arrays need
    // 16-byte elements): normal(a), gravity(a).
    normal: array<vec4<real>, VEC>,
    gravity: array<vec4<real>, VEC>,
}

// Calls of one dispatch in its uniform block (OP0..OP7).
const SEGMENT: u32 = 8u;

// The calls of one dispatch (one uniform block per dispatch, dynamic
// offset): the range, and copies of calls first_call + 0..SEGMENT for the
// runners that read them from here (particles, project; zeros past the
// range and for the other runners).
struct Dispatch {
    first_call: u32,
    end_call: u32,
    count: u32,       // invocations (particles, elements) or workgroups
    pad: u32,
    calls: array<Call, SEGMENT>,
}

// OP_*, FLAG_*, IO_* come from the generated header (gpu/src/codes.rs).

const NONE: u32 = 0xffffffffu;

@group(0) @binding(4) var<storage, read> gravity_scale: array<real>;
@group(0) @binding(5) var<storage, read> elements: array<u32>;
@group(0) @binding(6) var<storage, read> rest: array<real>;
@group(0) @binding(7) var<storage, read_write> lambda: array<real>;
// status[0]: first failing call (NONE: none), status[1]: smallest failing
// slot or particle of that call, status[2]: nonzero when an invocation's
// loops were cut short (`check_loops`), status[3]: in a batch, the lowest
// failing world (NONE: none), status[4 + w]: in a batch, nonzero when
// world w failed (gpu/src/batch/retry.rs; one world has 4 words).
@group(0) @binding(8) var<storage, read_write> status: array<atomic<u32>>;
// Per family [max violation, active contacts].
@group(0) @binding(9) var<storage, read_write> report: array<real>;
@group(0) @binding(10) var<storage, read> calls: array<Call>;
// Per contact (hyperplane or mesh) family, per particle: its slot in the family (NONE: fixed).
@group(0) @binding(11) var<storage, read> contact_slot: array<u32>;
// Per residual chunk [max violation, active contacts].
@group(0) @binding(12) var<storage, read_write> partials: array<real>;
// Per residual chunk (residual call, first element).
@group(0) @binding(13) var<storage, read> chunks: array<vec2<u32>>;
// `elements` again, read two indices at a time (distance families start at
// an even offset).
@group(0) @binding(14) var<storage, read> pairs: array<vec2<u32>>;
// FLAG_PRIMAL (primal.wgsl): per family, per slot, the displacement d_e its
// force put on each of its particles (arity · DIM reals); one real
// otherwise.
@group(0) @binding(15) var<storage, read_write> carried: array<real>;
@group(1) @binding(0) var<uniform> here: Dispatch;

// The call running now.
var<private> call: Call;

// BATCHES OF WORLDS (gpu/src/batch.rs; `world`, WORLD_PARTICLES
// and `particle(i)` in prelude.wgsl): a dispatch runs its calls for
// WORLDS worlds of one topology, invocation t = world · count + index.
// Shared by all worlds: the call structure (ops, counts, colours,
// elements, contact slot maps, chunks). Per world, world-major: particle
// records and gravity scales (WORLD_PARTICLES each), `rest` (WORLD_REST:
// rest values and material rest data), `lambda` (WORLD_SLOTS), residual
// partials (WORLD_CHUNKS chunks) and `report` (WORLD_REPORT reals), and
// the reals of every call block — compliance, friction, damping factor,
// normal, gravity, Lamé parameters: `calls` holds WORLD_CALLS blocks per
// world. With WORLDS = 1 every world term folds to 0 and the kernels are
// the single-world ones.
override WORLDS: u32 = 1u;
override WORLD_REST: u32 = 0u;
override WORLD_SLOTS: u32 = 0u;
override WORLD_CALLS: u32 = 0u;
override WORLD_CHUNKS: u32 = 0u;
override WORLD_REPORT: u32 = 0u;

// Sets `world` from a batch index t over `count` items per world; returns
// the item's index within its world (t itself with one world).
fn split_world(t: u32, count: u32) -> u32 {
    if (WORLDS > 1u) {
        world = t / count;
        return t - world * count;
    }
    return t;
}

// The reals the running call (op `op`) reads, as the running world has
// them (call block c of its copy of the calls); nothing with one world.
// `op` is a constant of the pipeline, so only its own fields are loaded
// (each is a per-lane load on lavapipe).
fn world_reals(op: u32, c: u32) {
    if (WORLDS > 1u) {
        let k = world * WORLD_CALLS + c;
        switch (op) {
            case OP_PREDICT: {
                call.gravity = calls[k].gravity;
            }
            case OP_PROJECT_CONTACT: {
                call.alpha_tilde = calls[k].alpha_tilde;
                call.friction = calls[k].friction;
                call.normal = calls[k].normal;
            }
            case OP_FRICTION: {
                call.absent = calls[k].absent;
                call.friction = calls[k].friction;
                call.normal = calls[k].normal;
            }
            case OP_DAMPING: {
                call.absent = calls[k].absent;
                call.factor = calls[k].factor;
            }
            case OP_GUARD_SPEED: {
                call.factor = calls[k].factor;
            }
            case OP_PROJECT_MATERIAL: {
                call.alpha_tilde = calls[k].alpha_tilde;
                call.friction = calls[k].friction;
                call.factor = calls[k].factor;
            }
            case OP_PROJECT_DISTANCE, OP_PROJECT_SIMPLEX, OP_PROJECT_ORIENTED,
                 OP_PROJECT_EXPRESSION, OP_RESIDUAL, OP_GUARD_MEASURE: {
                call.alpha_tilde = calls[k].alpha_tilde;
            }
            case OP_VELOCITY, OP_MOTION, OP_HOST, OP_NONE: {}
            // Every op is named above (tests/gpu/shaders.rs); an unknown one loads nothing.
            default: {}
        }
    }
}

// Whether the running world skips the running call: a response (friction,
// damping) its own plan compiles away, which the union of a batch's stages
// runs for the other worlds (gpu/src/batch/union.rs). Skipping leaves
// every record as the world's own step leaves it: exact by construction,
// signed zeros included. Never with one world (folds to false).
fn skipped() -> bool {
    return WORLDS > 1u && call.absent != 0u;
}

// Rest value (or material rest datum) s of the running world.
fn rest_at(s: u32) -> real {
    return rest[world * WORLD_REST + s];
}

// Multiplier of slot s of the running world.
fn lambda_at(s: u32) -> real {
    return lambda[world * WORLD_SLOTS + s];
}

fn store_lambda(s: u32, value: real) {
    lambda[world * WORLD_SLOTS + s] = value;
}

// Coordinate a of the running call's normal and gravity.
fn normal(a: u32) -> real {
    return call.normal[a / 4u][a % 4u];
}

fn gravity(a: u32) -> real {
    return call.gravity[a / 4u][a % 4u];
}

// This invocation's first failure (call, index); NONE: none yet.
var<private> failed_call: u32 = NONE;
var<private> failed_index: u32;

// Notes a failure of the running call at `index` (see Failure above): the
// invocation's first one is kept (its calls run in order).
fn fail(index: u32) {
    if (failed_call == NONE) {
        failed_call = call.call;
        failed_index = index;
    }
}

// Puts this invocation's noted failure, if any, in the status block.
fn record_failure() {
    if (failed_call != NONE) {
        if (atomicMin(&status[0], failed_call) >= failed_call) {
            atomicMin(&status[1], failed_index);
        }
        if (WORLDS > 1u) {
            atomicMin(&status[3], world);
            atomicMax(&status[4u + world], 1u);
        }
        failed_call = NONE;
    }
}

// Exactly `a`, as a value the driver's optimiser cannot see through.
// WGSL cannot forbid reassociation or contraction (naga emits no
// NoContraction), and lavapipe uses that freedom: in R^2 it turned the
// contact's (n₀x₀ + n₁x₁) − r into n₀x₀ + (n₁x₁ − r), off the golden path
// by ulps. A sum passed through here is rounded as written before it is
// used. The condition is false for every call (no call block has the
// number NONE), but only the run knows it.
fn kept(a: real) -> real {
    return select(a, -a, call.call == NONE);
}

// llvmpipe (lavapipe) ends every loop of an invocation once 65 535 loop
// iterations have run in it, all loops together, silently; after that a
// loop runs its body once and stops. The small step loops over its calls,
// so a long run (many substeps) can be cut; a `particles` run unrolls its
// calls but each still loops over coordinates. A two-trip probe at the end
// of both kernels, with a trip count the compiler cannot see (count <
// 2^31), tells, and the host refuses the step
// (gpu/src/backend/status.rs).
fn check_loops() {
    let trips = 2u + (here.count >> 31u);
    var probe = 0u;
    for (var t = 0u; t < trips; t++) {
        probe++;
    }
    if (probe != 2u) {
        atomicMax(&status[2], 1u);
    }
}

// The running per-particle call on particle i (its records in registers),
// its op `op` and flags `flags` (= call.flags; passed, so a pipeline whose
// flags are constants compiles only the branches they select, specialize.rs).
fn run_op(op: u32, flags: u32, i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>,
          rp: ptr<function, Record>) {
    switch (op) {
        case OP_PREDICT: {
            predict_particle(i, rx, rv, rp);
            if ((flags & FLAG_PRIMAL) != 0u) {
                warm_start_particle(i, rx);
            }
        }
        case OP_PROJECT_CONTACT: {
            if ((flags & FLAG_PRIMAL) != 0u) {
                primal_contact_particle(i, rx, rp);
            } else if ((flags & FLAG_MESH) != 0u) {
                mesh_contact_particle(i, rx, rv, rp);
            } else {
                contact_particle(i, rx, rp, (flags & FLAG_MOVING) != 0u);
            }
        }
        case OP_VELOCITY: {
            velocity_particle(i, rx, rv, rp);
        }
        case OP_FRICTION: {
            if ((flags & FLAG_MESH) != 0u) {
                mesh_friction_particle(i, rx, rv, rp);
            } else if ((flags & FLAG_MOVING) != 0u) {
                moving_friction_particle(i, rx, rv, rp);
            } else {
                friction_particle(i, rx, rv, rp);
            }
        }
        case OP_MOTION: {
            motion_particle(i, rx, rv, rp);
        }
        case OP_DAMPING: {
            damping_particle(i, rx, rv, rp);
        }
        // Not per-particle, or no call: nothing runs here.
        case OP_PROJECT_DISTANCE, OP_PROJECT_SIMPLEX, OP_PROJECT_ORIENTED, OP_PROJECT_MATERIAL,
             OP_PROJECT_EXPRESSION, OP_RESIDUAL, OP_GUARD_MEASURE, OP_GUARD_SPEED, OP_HOST,
             OP_NONE: {}
        // Every op is named above (tests/gpu/shaders.rs): an unknown one fails the step.
        default: {
            fail(i);
        }
    }
}

// The records a run of per-particle calls loads (`io`: IO_LOAD_*).
fn load_records(io: u32, i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>,
                rp: ptr<function, Record>) {
    if ((io & IO_LOAD_X) != 0u) {
        *rx = load_x(i);
    }
    if ((io & IO_LOAD_V) != 0u) {
        *rv = load_v(i);
    }
    if ((io & IO_LOAD_P) != 0u) {
        *rp = load_p(i);
    }
}

// The records a run stores (`io`: IO_STORE_*). Only dynamic particles
// move: a fixed particle's x and v are never written (its v may not even
// have been loaded); `io` loads x whenever x or v is stored.
fn store_records(io: u32, i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>,
                 rp: ptr<function, Record>) {
    let dynamic = inverse_mass_of(rx) != 0.0;
    if ((io & IO_STORE_X) != 0u && dynamic) {
        store_x(i, *rx);
    }
    if ((io & IO_STORE_V) != 0u && dynamic) {
        store_v(i, *rv);
    }
    if ((io & IO_STORE_P) != 0u) {
        store_p(i, *rp);
    }
}

// THE OPS AND FLAGS OF A PIPELINE read from a uniform block are fixed
// when it is created (pipeline-overridable constants): for `particles`,
// OP0..OP7 the ops of calls first_call + 0..7 (OP_NONE for none), FL0..FL7
// their FLAG_*, IO the records loaded and stored; for `project` and
// `guard`, FLAGS the flags of their one call and OP0 its op.
// The runner copies them into the private `call`, so the kernels keep
// reading `call.flags`, now a constant: the code a flag switches off (λ
// loads and stores, the force and gravity-scale loads, the other law)
// is removed, where a SIMD implementation such as lavapipe would run it
// for every batch under a mask.
override OP0: u32 = OP_NONE;
override OP1: u32 = OP_NONE;
override OP2: u32 = OP_NONE;
override OP3: u32 = OP_NONE;
override OP4: u32 = OP_NONE;
override OP5: u32 = OP_NONE;
override OP6: u32 = OP_NONE;
override OP7: u32 = OP_NONE;
override FL0: u32 = 0u;
override FL1: u32 = 0u;
override FL2: u32 = 0u;
override FL3: u32 = 0u;
override FL4: u32 = 0u;
override FL5: u32 = 0u;
override FL6: u32 = 0u;
override FL7: u32 = 0u;
override FLAGS: u32 = 0u;
override IO: u32 = 0u;

// Makes the dispatch's call k the running call, its flags `flags`.
fn take_call(k: u32, flags: u32) {
    call = here.calls[k];
    call.flags = flags;
}

// Call k of a fixed run, with op `op` and flags `flags`.
fn run_slot(op: u32, flags: u32, k: u32, i: u32, rx: ptr<function, Record>,
            rv: ptr<function, Record>, rp: ptr<function, Record>) {
    if (op != OP_NONE) {
        take_call(k, flags);
        world_reals(op, here.first_call + k);
        run_op(op, flags, i, rx, rv, rp);
    }
}

@compute @workgroup_size(WORKGROUP)
fn particles(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = linear_index(gid, groups);
    if (t >= here.count * WORLDS) {
        return;
    }
    let i = split_world(t, here.count);
    var rx: Record;
    var rv: Record;
    var rp: Record;
    load_records(IO, i, &rx, &rv, &rp);
    run_slot(OP0, FL0, 0u, i, &rx, &rv, &rp);
    run_slot(OP1, FL1, 1u, i, &rx, &rv, &rp);
    run_slot(OP2, FL2, 2u, i, &rx, &rv, &rp);
    run_slot(OP3, FL3, 3u, i, &rx, &rv, &rp);
    run_slot(OP4, FL4, 4u, i, &rx, &rv, &rp);
    run_slot(OP5, FL5, 5u, i, &rx, &rv, &rp);
    run_slot(OP6, FL6, 6u, i, &rx, &rv, &rp);
    run_slot(OP7, FL7, 7u, i, &rx, &rv, &rp);
    store_records(IO, i, &rx, &rv, &rp);
    record_failure();
    check_loops();
}

@compute @workgroup_size(WORKGROUP)
fn step_small(@builtin(local_invocation_index) lid: u32) {
    for (var c = here.first_call; c < here.end_call; c++) {
        call = calls[c];
        let count = call.count;
        if (call.op == OP_PROJECT_DISTANCE) {
            for (var t = lid; t < count; t += WORKGROUP) {
                if ((call.flags & FLAG_PRIMAL) != 0u) {
                    primal_distance_element(t);
                } else {
                    project_distance_element(t);
                }
            }
        } else {
            let op = call.op;
            let io = call.io;
            for (var i = lid; i < count; i += WORKGROUP) {
                var rx: Record;
                var rv: Record;
                var rp: Record;
                load_records(io, i, &rx, &rv, &rp);
                run_op(op, call.flags, i, &rx, &rv, &rp);
                store_records(io, i, &rx, &rv, &rp);
            }
        }
        record_failure();
        storageBarrier();
    }
    check_loops();
}
