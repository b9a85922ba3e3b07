// Prescribed motion on the device: animated pins, and the carry,
// friction and residual of a moving hyperplane (FLAG_MOVING; its contact
// is project.wgsl's contact_particle with `moving`, and a moving mesh's
// is mesh_contact.wgsl's with this carry and friction). The host
// evaluates every motion in f64 once per step for all its substeps
// (core/src/motion.rs) and hands the values over in the call blocks and
// in `rest` (gpu/src/xpbd/motion.rs):
//
//   OP_MOTION  pin k of particle i (contact_slot[slot_map + i] = k):
//              x = rest[slot_base + 2 DIM k + a],  v = rest[… + DIM + a]
//   moving plane call   normal = n(t1), factor = s (shift), gravity = c,
//              FLAG_ROTATES: Ā row-major at rest[chunk …]
//   contact    C = n·x − rest − s;  static friction against q = D(p) + p,
//              D(p) = Σ_b Ā_ab p_b + c_a  (c_a without a rotation)
//   friction   rel = v − D(p) / h, clamped as friction.wgsl clamps v
//   residual   max(−(n·x − rest − s), 0)
//
// Same arithmetic, in the same order, as cpu/src/motion.rs (f64) and
// cpu/src/f32_reference/motion.rs (f32). A pin is fixed (w = 0), so the
// runner's store skips it: OP_MOTION stores its records itself.

// Animated pin on particle i, if it is one.
fn motion_particle(i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>, rp: ptr<function, Record>) {
    let k = contact_slot[call.slot_map + i];
    if (k == NONE) {
        return;
    }
    let base = call.slot_base + 2u * DIM * k;
    for (var a = 0u; a < DIM; a++) {
        set_lane(rx, a, rest_at(base + a));
        set_lane(rv, a, rest_at(base + DIM + a));
    }
    store_x(i, *rx);
    store_v(i, *rv);
}

// Coordinate a of D(p) of the running moving-plane call.
fn carry_at(a: u32, rp: ptr<function, Record>) -> real {
    if ((call.flags & FLAG_ROTATES) == 0u) {
        return gravity(a);
    }
    var s: real = 0.0;
    for (var b = 0u; b < DIM; b++) {
        s += rest_at(call.chunk + a * DIM + b) * lane(rp, b);
    }
    return kept(s) + gravity(a);
}

// The obstacle point under p at the substep's start, now at q = D(p) + p
// (the running moving-plane or moving-mesh call's carry).
fn carried_start(rp: ptr<function, Record>) -> Record {
    var q: Record;
    for (var a = 0u; a < DIM; a++) {
        set_lane(&q, a, kept(carry_at(a, rp)) + lane(rp, a));
    }
    return q;
}

// Dynamic friction against a moving hyperplane (friction_particle's slot
// and λ lookup; friction.wgsl).
fn moving_friction_particle(i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>, rp: ptr<function, Record>) {
    let slot = friction_slot(i);
    if (slot.e == NONE || slot.l <= 0.0) {
        return;
    }
    var n: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        n[a] = normal(a);
    }
    carried_friction(i, rx, rv, rp, slot.l, &n);
}

// v −= u_t · min(μ w λ / h, |u_t|) / |u_t|, u = v − D(p)/h: dynamic
// friction of particle i (multiplier `l` > 0) against the running call's
// moving obstacle, with unit normal n (a plane's, or a moving mesh's at x).
fn carried_friction(i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>,
                    rp: ptr<function, Record>, l: real, n: ptr<function, array<real, DIM>>) {
    var rel: Record;
    for (var a = 0u; a < DIM; a++) {
        set_lane(&rel, a, lane(rv, a) - kept(carry_at(a, rp)) / call.h);
    }
    relative_friction(i, rx, rv, &rel, l, n);
}

// The violation of a moving plane's slot s at the gathered point `pts`.
fn moving_contact_violation(s: u32, nx: real) -> real {
    return max(-(kept(kept(nx) - rest_at(s)) - call.factor), 0.0);
}
