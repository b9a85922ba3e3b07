// XPBD projection of one colour of one family: one invocation per element
// (distance, tether, simplex measures, materials), or per particle on its records in
// registers (hyperplane contact, run by step.wgsl's `particles`). Elements
// of one colour share no dynamic particle, so invocations write disjoint
// particles: no atomics, no dependence on scheduling.
//
//   α~ = α / h²
//   Δλ = (−C − α~ λ) / (Σ_j w_j |∇_j C|² + α~)
//   contacts (C ≥ 0): λ' = max(λ + Δλ, 0);  Δλ = λ' − λ
//   tethers (|x1 − x0| ≤ rest, FLAG_TETHER): λ' = min(λ + Δλ, 0)
//   x_j += w_j ∇_j C Δλ
//   static friction (active contact, μ > 0): Δt = tangential part of x − p;
//   if |Δt| ≤ μ w λ then x −= Δt
//
// Same arithmetic, in the same order, as cpu/src/project.rs. Fixed
// particles (w = 0, the last lane of their record) are never written.
// The first projection of a family in a substep (FLAG_FIRST) reads λ as 0
// — the CPU resets λ in predict — and writes λ on every path, so friction
// and the report see this substep's multipliers.

// Gathers element e of the running call into `pts`.
fn gather(e: u32, pts: ptr<function, array<real, POINTS>>) {
    let arity = call.arity;
    for (var j = 0u; j < arity; j++) {
        var r = load_x(elements[call.elem_base + e * arity + j]);
        for (var a = 0u; a < DIM; a++) {
            (*pts)[j * DIM + a] = lane(&r, a);
        }
    }
}

// λ of slot s before this projection.
fn lambda_before(s: u32) -> real {
    if ((call.flags & FLAG_FIRST) != 0u) {
        return 0.0;
    }
    return lambda_at(s);
}

// An element that makes no response keeps λ (0 on the first projection).
fn no_response(s: u32) {
    if ((call.flags & (FLAG_FIRST | FLAG_UNREAD)) == FLAG_FIRST) {
        store_lambda(s, 0.0);
    }
}

// λ after this projection.
fn set_lambda(s: u32, value: real) {
    if ((call.flags & FLAG_UNREAD) == 0u) {
        store_lambda(s, value);
    }
}

fn project_distance_element(t: u32) {
    let e = call.first + t;
    let s = call.slot_base + e;
    let ij = pairs[call.elem_base / 2u + e];
    let i = ij.x;
    let j = ij.y;
    var ri = load_x(i);
    var rj = load_x(j);
    let wi = inverse_mass_of(&ri);
    let wj = inverse_mass_of(&rj);
    var d: array<real, DIM>;
    var d2: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        d[a] = lane(&rj, a) - lane(&ri, a);
        d2 += d[a] * d[a];
    }
    let len = sqrt(d2);
    let wsum = wi + wj;
    if (!(len > 0.0) || wsum == 0.0) {
        if (!finite(len)) {
            fail(e);
        }
        no_response(s);
        return;
    }
    let l = lambda_before(s);
    let alpha_tilde = call.alpha_tilde;
    var dl = (-(len - rest_at(s)) - alpha_tilde * l) / (wsum + alpha_tilde);
    if (!finite(dl)) {
        fail(e);
        return;
    }
    if ((call.flags & FLAG_TETHER) != 0u) {
        dl = min(l + dl, 0.0) - l;
    }
    set_lambda(s, l + dl);
    let inv = 1.0 / len;
    if (wi != 0.0) {
        for (var a = 0u; a < DIM; a++) {
            set_lane(&ri, a, lane(&ri, a) + wi * -(d[a] * inv) * dl);
        }
        store_x(i, ri);
    }
    if (wj != 0.0) {
        for (var a = 0u; a < DIM; a++) {
            set_lane(&rj, a, lane(&rj, a) + wj * (d[a] * inv) * dl);
        }
        store_x(j, rj);
    }
}

// Simplex measures (OP_PROJECT_SIMPLEX: squared k-measure,
// OP_PROJECT_ORIENTED: oriented N-measure) and the material energy
// constraint (OP_PROJECT_MATERIAL, material.wgsl; a refused element fails
// like a non-finite one): gather, evaluate C and ∇C, update.
fn project_measure_element(t: u32, op: u32) {
    let e = call.first + t;
    let s = call.slot_base + e;
    let arity = call.arity;
    var pts: array<real, POINTS>;
    var grad: array<real, POINTS>;
    gather(e, &pts);
    var value: real;
    var refused = false;
    if (op == OP_PROJECT_SIMPLEX) {
        value = simplex_squared_measure(&pts, arity - 1u, &grad);
    } else if (op == OP_PROJECT_ORIENTED) {
        value = oriented_measure(&pts, &grad);
    } else if (op == OP_PROJECT_MATERIAL) {
        value = material_constraint(e, &pts, &grad, &refused);
    } else {
        refused = true;
    }
    if (refused || !finite(value)) {
        fail(e);
        return;
    }
    var wsum: real = 0.0;
    for (var j = 0u; j < arity; j++) {
        var g2: real = 0.0;
        for (var a = 0u; a < DIM; a++) {
            g2 += grad[j * DIM + a] * grad[j * DIM + a];
        }
        var r = load_x(elements[call.elem_base + e * arity + j]);
        wsum += inverse_mass_of(&r) * g2;
    }
    if (wsum == 0.0) {
        no_response(s);
        return;
    }
    let l = lambda_before(s);
    let alpha_tilde = call.alpha_tilde;
    let dl = (-(value - rest_at(s)) - alpha_tilde * l) / (wsum + alpha_tilde);
    if (!finite(dl)) {
        fail(e);
        return;
    }
    set_lambda(s, l + dl);
    for (var j = 0u; j < arity; j++) {
        let i = elements[call.elem_base + e * arity + j];
        var r = load_x(i);
        let w = inverse_mass_of(&r);
        if (w == 0.0) {
            continue;
        }
        for (var a = 0u; a < DIM; a++) {
            set_lane(&r, a, lane(&r, a) + w * grad[j * DIM + a] * dl);
        }
        store_x(i, r);
    }
}

// The last hyperplane contact this invocation projected: family, particle,
// slot (NONE: none) and the λ it stored — what friction of that family
// on that particle would load next (friction.wgsl). NONE family: none
// (or it failed and stored nothing).
var<private> contact_family: u32 = NONE;
var<private> contact_particle_index: u32;
var<private> contact_e: u32;
var<private> contact_l: real;

// Enters particle i's contact in the running contact call's family: its
// slot (NONE: a fixed particle, no contact), noted as the last contact
// this invocation projected.
fn enter_contact(i: u32) -> u32 {
    let e = contact_slot[call.slot_map + i];
    contact_family = call.family;
    contact_particle_index = i;
    contact_e = e;
    return e;
}

// The update of contact slot e with C = `cval`, λ = `l` and unit normal n:
// Δλ = (−C − α~ λ)/(w + α~), λ' = max(λ + Δλ, 0), x += w n (λ' − λ); λ'
// stored and noted (contact_l). False, the invocation failed at e, when
// Δλ is not finite.
fn contact_response(e: u32, cval: real, l: real, rx: ptr<function, Record>,
                    n: ptr<function, array<real, DIM>>) -> bool {
    let w = inverse_mass_of(rx);
    let alpha_tilde = call.alpha_tilde;
    let raw = (-cval - alpha_tilde * l) / (w + alpha_tilde);
    if (!finite(raw)) {
        contact_family = NONE;
        fail(e);
        return false;
    }
    let dl = max(l + raw, 0.0) - l;
    let l_new = l + dl;
    store_lambda(call.slot_base + e, l_new);
    contact_l = l_new;
    for (var a = 0u; a < DIM; a++) {
        set_lane(rx, a, lane(rx, a) + w * (*n)[a] * dl);
    }
    return true;
}

// A hyperplane contact of particle i (its records in registers);
// `moving`: the running call's plane moves (motion.wgsl), so C less its
// shift s, and static friction against the carried start q = D(p) + p.
fn contact_particle(i: u32, rx: ptr<function, Record>, rp: ptr<function, Record>, moving: bool) {
    let e = enter_contact(i);
    if (e == NONE) {
        return;
    }
    let s = call.slot_base + e;
    var n: array<real, DIM>;
    var nx: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        n[a] = normal(a);
        nx += normal(a) * lane(rx, a);
    }
    let cval = kept(nx) - rest_at(s);
    var c = cval;
    if (moving) {
        c = kept(cval) - call.factor;
    }
    let l = lambda_before(s);
    if (!contact_response(e, c, l, rx, &n)) {
        return;
    }
    let mu = call.friction;
    if (mu > 0.0 && contact_l > 0.0) {
        var start = *rp;
        if (moving) {
            start = carried_start(rp);
        }
        static_friction(rx, &start, &n, mu * inverse_mass_of(rx) * contact_l);
    }
}

// Static friction of an active contact with unit normal n: Δt = the
// tangential part of x − p; if |Δt| ≤ `bound` (μ w λ) then x −= Δt.
fn static_friction(rx: ptr<function, Record>, rp: ptr<function, Record>,
                   n: ptr<function, array<real, DIM>>, bound: real) {
    var dn: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        dn += (lane(rx, a) - lane(rp, a)) * (*n)[a];
    }
    var t2: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        let tan = (lane(rx, a) - lane(rp, a)) - dn * (*n)[a];
        t2 += tan * tan;
    }
    if (sqrt(t2) <= bound) {
        for (var a = 0u; a < DIM; a++) {
            let tan = (lane(rx, a) - lane(rp, a)) - dn * (*n)[a];
            set_lane(rx, a, lane(rx, a) - tan);
        }
    }
}

// Invocation (gid, groups) of a per-element projection dispatch of op
// `op` (the entry point's pipeline constant OP0): element e of its world's
// call, then the failure it noted, if any.
fn project_elements(gid: vec3<u32>, groups: vec3<u32>, op: u32) {
    let t = linear_index(gid, groups);
    if (t < here.count * WORLDS) {
        let e = split_world(t, here.count);
        take_call(0u, FLAGS);
        world_reals(op, here.first_call);
        switch (op) {
            case OP_PROJECT_DISTANCE: {
                if ((call.flags & FLAG_PRIMAL) != 0u) {
                    primal_distance_element(e);
                } else {
                    project_distance_element(e);
                }
            }
            case OP_PROJECT_SIMPLEX, OP_PROJECT_ORIENTED, OP_PROJECT_MATERIAL: {
                if ((call.flags & FLAG_PRIMAL) != 0u) {
                    primal_measure_element(e, op);
                } else {
                    project_measure_element(e, op);
                }
            }
            case OP_PROJECT_EXPRESSION: {
                project_expression_element(e);
            }
            // Not an element projection: every op is named (tests/gpu/shaders.rs),
            // and one that reaches here, or an unknown one, fails the step.
            case OP_PREDICT, OP_PROJECT_CONTACT, OP_VELOCITY, OP_FRICTION, OP_DAMPING, OP_RESIDUAL, OP_GUARD_MEASURE, OP_GUARD_SPEED, OP_HOST,
                 OP_MOTION, OP_NONE, default: {
                fail(e);
            }
        }
        record_failure();
    }
}

// One colour of an element family: op OP0 (an OP_PROJECT_*) and the
// call's FLAGS, both pipeline constants (gpu/src/xpbd/mod.rs, XpbdEntry).
@compute @workgroup_size(WORKGROUP)
fn project(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    project_elements(gid, groups, OP0);
}
