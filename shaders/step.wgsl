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
//   project_*       one invocation per element of one colour (project.wgsl)
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
// Failure: `fail` records the first failing call (status[0]) and the
// smallest failing index (status[1]); calls after a failed one do nothing
// (failed_before). When several calls share a dispatch the index may come
// from a later call; the host then replays the step one call per dispatch
// (the exact schedule) to name the failure as the CPU does.

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
    kind: u32,        // residual: 0 distance, 1 simplex measure, 2 oriented, 3 contact, 4 tether
    slot_map: u32,    // contact, friction: offset of the family's particle → slot map
    chunk: u32,       // residual: first chunk of the family in `partials`
    io: u32,          // records this call reads and writes (IO_*), when run alone
    pad0: u32,
    pad1: u32,
    pad2: u32,
    alpha_tilde: real, // α / h²
    h: real,           // substep length
    friction: real,    // Coulomb μ of a contact family
    factor: real,      // damping factor exp(−rate h)
    normal: array<real, DIM>,
    gravity: array<real, DIM>,
}

// The calls of one dispatch (one block per dispatch, dynamic offset).
struct Dispatch {
    first_call: u32,
    end_call: u32,
    count: u32,       // invocations (particles, elements) or workgroups
    pad: u32,
}

const OP_PREDICT: u32 = 0u;
const OP_PROJECT_DISTANCE: u32 = 1u;
const OP_PROJECT_SIMPLEX: u32 = 2u;
const OP_PROJECT_ORIENTED: u32 = 3u;
const OP_PROJECT_CONTACT: u32 = 4u;
const OP_VELOCITY: u32 = 5u;
const OP_FRICTION: u32 = 6u;
const OP_DAMPING: u32 = 7u;
const OP_RESIDUAL: u32 = 8u;

const FLAG_GRAVITY: u32 = 1u;  // predict: s g term
const FLAG_FORCE: u32 = 2u;    // predict: w f term
const FLAG_FIRST: u32 = 4u;    // projection: first of its family this substep (λ = 0 before)
const FLAG_TETHER: u32 = 8u;   // distance: one-sided (|x1 − x0| ≤ rest)
const FLAG_UNREAD: u32 = 16u;  // projection: nothing reads this λ later (not stored)

const IO_LOAD_X: u32 = 1u;
const IO_LOAD_V: u32 = 2u;
const IO_LOAD_P: u32 = 4u;
const IO_STORE_X: u32 = 8u;
const IO_STORE_V: u32 = 16u;
const IO_STORE_P: u32 = 32u;

const NONE: u32 = 0xffffffffu;

@group(0) @binding(4) var<storage, read> gravity_scale: array<real>;
@group(0) @binding(5) var<storage, read> elements: array<u32>;
@group(0) @binding(6) var<storage, read> rest: array<real>;
@group(0) @binding(7) var<storage, read_write> lambda: array<real>;
// status[0]: first failing call (NONE: none), status[1]: smallest failing
// slot or particle of that call, status[2]: nonzero when an invocation's
// loops were cut short (`check_loops`).
@group(0) @binding(8) var<storage, read_write> status: array<atomic<u32>, 4>;
// Per family [max violation, active contacts].
@group(0) @binding(9) var<storage, read_write> report: array<real>;
@group(0) @binding(10) var<storage, read> calls: array<Call>;
// Per hyperplane family, per particle: its slot in the family (NONE: fixed).
@group(0) @binding(11) var<storage, read> contact_slot: array<u32>;
// Per residual chunk [max violation, active contacts].
@group(0) @binding(12) var<storage, read_write> partials: array<real>;
// Per residual chunk (residual call, first element).
@group(0) @binding(13) var<storage, read> chunks: array<vec2<u32>>;
// `elements` again, read two indices at a time (distance families start at
// an even offset).
@group(0) @binding(14) var<storage, read> pairs: array<vec2<u32>>;
@group(1) @binding(0) var<uniform> here: Dispatch;

// True when an earlier call of this step failed: later calls do nothing.
fn failed_before(c: u32) -> bool {
    return atomicLoad(&status[0]) < calls[c].call;
}

// Records a failure of call c at `index`; the smallest index wins.
fn fail(c: u32, index: u32) {
    atomicMin(&status[0], calls[c].call);
    atomicMin(&status[1], index);
}

// Exactly `a`, as a value the driver's optimiser cannot see through.
// WGSL cannot forbid reassociation or contraction (naga emits no
// NoContraction), and lavapipe uses that freedom: in R^2 it turned the
// contact's (n₀x₀ + n₁x₁) − r into n₀x₀ + (n₁x₁ − r), off the golden path
// by ulps. A sum passed through here is rounded as written before it is
// used. The condition is false for every call c (no call block has the
// number NONE), but only the run knows it.
fn kept(a: real, c: u32) -> real {
    return select(a, -a, calls[c].call == NONE);
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

// Per-particle call c on particle i (its records in registers).
fn run_op(op: u32, c: u32, i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>,
          rp: ptr<function, Record>) {
    switch (op) {
        case OP_PREDICT: {
            predict_particle(c, i, rx, rv, rp);
        }
        case OP_PROJECT_CONTACT: {
            contact_particle(c, i, rx, rv, rp);
        }
        case OP_VELOCITY: {
            velocity_particle(c, i, rx, rv, rp);
        }
        case OP_FRICTION: {
            friction_particle(c, i, rx, rv, rp);
        }
        case OP_DAMPING: {
            damping_particle(c, i, rx, rv, rp);
        }
        default: {}
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

// THE OPS OF A `particles` PIPELINE are fixed when it is created
// (pipeline-overridable constants: OP0..OP7 the ops of calls first_call +
// 0..7, NO_OP for none; IO the records loaded and stored), so a pipeline
// runs exactly its calls: no run-time branch on the op, which a SIMD
// implementation such as lavapipe would execute for every op under masks.
const NO_OP: u32 = 255u;
override OP0: u32 = NO_OP;
override OP1: u32 = NO_OP;
override OP2: u32 = NO_OP;
override OP3: u32 = NO_OP;
override OP4: u32 = NO_OP;
override OP5: u32 = NO_OP;
override OP6: u32 = NO_OP;
override OP7: u32 = NO_OP;
override IO: u32 = 0u;

// Call c with op `op` of a fixed run (skipped after a failed call; the
// records then stored are garbage, and the step is rolled back).
fn run_slot(op: u32, c: u32, i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>,
            rp: ptr<function, Record>) {
    if (op != NO_OP && !failed_before(c)) {
        run_op(op, c, i, rx, rv, rp);
    }
}

@compute @workgroup_size(WORKGROUP)
fn particles(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= here.count) {
        return;
    }
    var rx: Record;
    var rv: Record;
    var rp: Record;
    load_records(IO, i, &rx, &rv, &rp);
    let c = here.first_call;
    run_slot(OP0, c, i, &rx, &rv, &rp);
    run_slot(OP1, c + 1u, i, &rx, &rv, &rp);
    run_slot(OP2, c + 2u, i, &rx, &rv, &rp);
    run_slot(OP3, c + 3u, i, &rx, &rv, &rp);
    run_slot(OP4, c + 4u, i, &rx, &rv, &rp);
    run_slot(OP5, c + 5u, i, &rx, &rv, &rp);
    run_slot(OP6, c + 6u, i, &rx, &rv, &rp);
    run_slot(OP7, c + 7u, i, &rx, &rv, &rp);
    store_records(IO, i, &rx, &rv, &rp);
    check_loops();
}

@compute @workgroup_size(WORKGROUP)
fn step_small(@builtin(local_invocation_index) lid: u32) {
    for (var c = here.first_call; c < here.end_call; c++) {
        let count = calls[c].count;
        if (calls[c].op == OP_PROJECT_DISTANCE) {
            for (var t = lid; t < count; t += WORKGROUP) {
                project_distance_element(c, t);
            }
        } else {
            let op = calls[c].op;
            let io = calls[c].io;
            for (var i = lid; i < count; i += WORKGROUP) {
                var rx: Record;
                var rv: Record;
                var rp: Record;
                load_records(io, i, &rx, &rv, &rp);
                if (!failed_before(c)) {
                    run_op(op, c, i, &rx, &rv, &rp);
                }
                store_records(io, i, &rx, &rv, &rp);
            }
        }
        storageBarrier();
    }
    check_loops();
}
