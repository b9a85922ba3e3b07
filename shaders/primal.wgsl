// XPBD that carries the primal residual (FLAG_PRIMAL; the golden path is
// cpu/src/consistent.rs, the same arithmetic in the same order). Each
// element e keeps d_e, the displacement its force has put on each of its
// particles (`carried`, at call.carried + e · arity · DIM), so that
// x = x~ + Σ_e d_e always holds, and an update solves the element's own
// backward-Euler problem from a = x − d_e (x without e's force):
//
//   distance, tether  λ = (rest − |a₁ − a₀|) / (w₀ + w₁ + α~)   (tether: λ ≤ 0)
//                     d₀ = −w₀ u λ,  d₁ = w₁ u λ,  u = (a₁ − a₀) / |a₁ − a₀|
//   hyperplane        λ = max(−(n·a − rest) / (w + α~), 0),  d = w n λ,
//                     then static friction as project.wgsl
//   measures          one Gauss–Newton step from y0 = x:
//                     λ = −(C(x) + ∇C(x)·(a − x)) / (Σ w |∇C|² + α~),  d = w ∇C λ
//   then              x = a + d (dynamic particles), λ stored (a result, not
//                     an increment: FLAG_FIRST and FLAG_UNREAD do not apply)
//   predict           the warm start x = x~ + Σ_e d_e, in family, slot order
//
// A clamp is written as a select so that −0 and NaN go where the CPU's
// explicit comparison sends them.

// Row i of the warm start (integrate.rs): x_i += each of its displacements.
fn warm_start_particle(i: u32, rx: ptr<function, Record>) {
    if (inverse_mass_of(rx) == 0.0) {
        return;
    }
    let first = contact_slot[call.slot_map + i];
    let end = contact_slot[call.slot_map + i + 1u];
    for (var k = first; k < end; k++) {
        let base = contact_slot[k];
        for (var a = 0u; a < DIM; a++) {
            set_lane(rx, a, lane(rx, a) + carried[base + a]);
        }
    }
}

// λ clamped by a relation: 0 equal, 1 at least (≥ 0), 2 at most (≤ 0).
fn primal_clamp(l: real, relation: u32) -> real {
    if (relation == 1u) {
        return select(0.0, l, l > 0.0);
    }
    if (relation == 2u) {
        return select(0.0, l, l < 0.0);
    }
    return l;
}

fn primal_distance_element(t: u32) {
    let e = call.first + t;
    let s = call.slot_base + e;
    let ij = pairs[call.elem_base / 2u + e];
    let i = ij.x;
    let j = ij.y;
    var ri = load_x(i);
    var rj = load_x(j);
    let wi = inverse_mass_of(&ri);
    let wj = inverse_mass_of(&rj);
    let base = call.carried + e * 2u * DIM;
    var ai: array<real, DIM>;
    var aj: array<real, DIM>;
    var di: array<real, DIM>;
    var dj: array<real, DIM>;
    var len2: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        ai[a] = lane(&ri, a) - carried[base + a];
        aj[a] = lane(&rj, a) - carried[base + DIM + a];
        let dk = aj[a] - ai[a];
        len2 += dk * dk;
    }
    let len = sqrt(len2);
    let wsum = wi + wj;
    var l: real = 0.0;
    if (!(len > 0.0) || wsum == 0.0) {
        if (!finite(len)) {
            fail(e);
            return;
        }
    } else {
        var relation = 0u;
        if ((call.flags & FLAG_TETHER) != 0u) {
            relation = 2u;
        }
        l = primal_clamp((rest_at(s) - len) / (wsum + call.alpha_tilde), relation);
        if (!finite(l)) {
            fail(e);
            return;
        }
        for (var a = 0u; a < DIM; a++) {
            let u = (aj[a] - ai[a]) / len;
            di[a] = -wi * u * l;
            dj[a] = wj * u * l;
        }
    }
    for (var a = 0u; a < DIM; a++) {
        carried[base + a] = di[a];
        carried[base + DIM + a] = dj[a];
    }
    store_lambda(s, l);
    if (wi != 0.0) {
        for (var a = 0u; a < DIM; a++) {
            set_lane(&ri, a, ai[a] + di[a]);
        }
        store_x(i, ri);
    }
    if (wj != 0.0) {
        for (var a = 0u; a < DIM; a++) {
            set_lane(&rj, a, aj[a] + dj[a]);
        }
        store_x(j, rj);
    }
}

// One Gauss–Newton step of element e (its points `pts` = x, C(x) = value,
// ∇C(x) in `grad`) of a family with relation `relation`.
fn primal_gauss_newton(e: u32, value: real, pts: ptr<function, array<real, POINTS>>,
                       grad: ptr<function, array<real, POINTS>>, relation: u32) {
    let s = call.slot_base + e;
    let arity = call.arity;
    let base = call.carried + e * arity * DIM;
    var anchor: array<real, POINTS>;
    var w: array<real, POINTS>;
    primal_anchor(e, base, pts, &anchor, &w);
    if (!finite(value)) {
        fail(e);
        return;
    }
    var wsum: real = 0.0;
    var lin: real = value - rest_at(s);
    for (var j = 0u; j < arity; j++) {
        if (w[j] == 0.0) {
            continue;
        }
        for (var a = 0u; a < DIM; a++) {
            let k = j * DIM + a;
            wsum += w[j] * (*grad)[k] * (*grad)[k];
            lin += (*grad)[k] * (anchor[k] - (*pts)[k]);
        }
    }
    var l: real = 0.0;
    var ok = true;
    var d: array<real, POINTS>;
    // ∇C zero or undefined: no response (cpu/src/consistent.rs).
    if (wsum != 0.0 && finite(wsum)) {
        l = primal_clamp(-lin / (wsum + call.alpha_tilde), relation);
        for (var k = 0u; k < arity * DIM; k++) {
            d[k] = w[k / DIM] * (*grad)[k] * l;
            ok = ok && finite(d[k]);
        }
    }
    if (!ok || !finite(l)) {
        fail(e);
        return;
    }
    primal_commit(e, s, base, l, &d, &anchor, &w);
}

// Weights w_j and anchors a = x − d_e (d_e kept in `carried` at `base`) of
// element e's points at `pts`.
fn primal_anchor(e: u32, base: u32, pts: ptr<function, array<real, POINTS>>,
                 anchor: ptr<function, array<real, POINTS>>, w: ptr<function, array<real, POINTS>>) {
    let arity = call.arity;
    for (var j = 0u; j < arity; j++) {
        var r = load_x(elements[call.elem_base + e * arity + j]);
        (*w)[j] = inverse_mass_of(&r);
        for (var a = 0u; a < DIM; a++) {
            let k = j * DIM + a;
            (*anchor)[k] = (*pts)[k] - carried[base + k];
        }
    }
}

// Element e's accepted update: d_e = `d` kept in `carried` at `base`, λ = l
// in slot s, and every dynamic point moved to its anchor + d.
fn primal_commit(e: u32, s: u32, base: u32, l: real, d: ptr<function, array<real, POINTS>>,
                 anchor: ptr<function, array<real, POINTS>>, w: ptr<function, array<real, POINTS>>) {
    let arity = call.arity;
    for (var k = 0u; k < arity * DIM; k++) {
        carried[base + k] = (*d)[k];
    }
    store_lambda(s, l);
    for (var j = 0u; j < arity; j++) {
        if ((*w)[j] == 0.0) {
            continue;
        }
        let i = elements[call.elem_base + e * arity + j];
        var r = load_x(i);
        for (var a = 0u; a < DIM; a++) {
            set_lane(&r, a, (*anchor)[j * DIM + a] + (*d)[j * DIM + a]);
        }
        store_x(i, r);
    }
}

// Simplex and oriented measures (equalities); materials: primal_material.wgsl.
fn primal_measure_element(t: u32, op: u32) {
    let e = call.first + t;
    var pts: array<real, POINTS>;
    var grad: array<real, POINTS>;
    gather(e, &pts);
    var value: real;
    if (op == OP_PROJECT_SIMPLEX) {
        value = simplex_squared_measure(&pts, call.arity - 1u, &grad);
    } else if (op == OP_PROJECT_ORIENTED) {
        value = oriented_measure(&pts, &grad);
    } else {
        primal_material_element(t);
        return;
    }
    primal_gauss_newton(e, value, &pts, &grad, 0u);
}

// A hyperplane contact of particle i (its records in registers).
fn primal_contact_particle(i: u32, rx: ptr<function, Record>, rp: ptr<function, Record>) {
    let e = enter_contact(i);
    if (e == NONE) {
        return;
    }
    let s = call.slot_base + e;
    let base = call.carried + e * DIM;
    let w = inverse_mass_of(rx);
    var anchor: array<real, DIM>;
    var d: array<real, DIM>;
    var c = -rest_at(s);
    for (var a = 0u; a < DIM; a++) {
        anchor[a] = lane(rx, a) - carried[base + a];
        c = kept(c + normal(a) * anchor[a]);
    }
    let l = primal_clamp(-c / (w + call.alpha_tilde), 1u);
    var ok = finite(l);
    for (var a = 0u; a < DIM; a++) {
        d[a] = w * normal(a) * l;
        carried[base + a] = d[a];
        ok = ok && finite(d[a]);
    }
    if (!ok) {
        contact_family = NONE;
        fail(e);
        return;
    }
    store_lambda(s, l);
    contact_l = l;
    for (var a = 0u; a < DIM; a++) {
        set_lane(rx, a, anchor[a] + d[a]);
    }
    let mu = call.friction;
    if (mu > 0.0 && l > 0.0) {
        let bound = mu * w * l;
        var dn: real = 0.0;
        for (var a = 0u; a < DIM; a++) {
            dn += (lane(rx, a) - lane(rp, a)) * normal(a);
        }
        var t2: real = 0.0;
        for (var a = 0u; a < DIM; a++) {
            let tan = (lane(rx, a) - lane(rp, a)) - dn * normal(a);
            t2 += tan * tan;
        }
        if (sqrt(t2) <= bound) {
            for (var a = 0u; a < DIM; a++) {
                let tan = (lane(rx, a) - lane(rp, a)) - dn * normal(a);
                set_lane(rx, a, lane(rx, a) - tan);
            }
        }
    }
}
