// XPBD with the primal residual, material elements (FLAG_PRIMAL; the
// golden path is `material` in cpu/src/consistent.rs, the same arithmetic
// in the same order): one Newton step from y0 = x on the element's
// backward-Euler problem ½|y − a|²_M + W(y)/α~, a = x − d_e:
//
//   (M + K/α~) Δ = −(M (y0 − a) + ∇W(y0)/α~),  y = y0 + t Δ,  d_e = y − a
//   t: the first of 1, ½, …, 2⁻⁶ at which the law accepts the element and
//      φ(y) = ½|y − a|²_M + W(y)/α~ ≤ φ(y0); 0 when none does
//   λ = −√(2 max(W, 0)) / α~
//
// over the element's dynamic coordinates (M = 1/w on the diagonal). K is
// the vertex block of the law's frame Hessian H_F (material_hessian.wgsl),
// built column by column as core's material_hessian_block does; where
// M + K/α~ has no Cholesky factor, H_F is projected onto the PSD cone
// (symmetric_eigen.wgsl) and the block built again. The factor is made at
// the element's first update of the substep (FLAG_FIRST) and kept in
// `carried` at call.factors + e · (arity · DIM)² (q × q of it, row-major),
// and the later sweeps reuse it (a chord step: the same fixed point).

const SYS: u32 = POINTS * POINTS;

// Column `c` of element e's vertex block: core's apply_material_curvature
// of the frame Hessian `h` with p = e_c.
fn primal_block_column(e: u32, h: ptr<function, array<real, HESS>>, c: u32,
                       out: ptr<function, array<real, POINTS>>) {
    let k = call.arity - 1u;
    let size = DIM * k;
    let base = call.slot_map + e * (k * k + 1u);
    let v0 = rest_at(base + k * k);
    var p: array<real, POINTS>;
    p[c] = 1.0;
    var df: array<real, MAT>;
    material_frame_change(base, k, &p, &df);
    var yf: array<real, MAT>;
    for (var row = 0u; row < size; row++) {
        var v: real = 0.0;
        for (var q = 0u; q < size; q++) {
            v += (*h)[row * size + q] * df[q];
        }
        yf[row] = v;
    }
    material_point_forces(base, k, v0, &yf, out);
}

// primal_cholesky(a, n, l): shaders/cholesky.wgsl over array<real, SYS>
// (composed after this file, shader.rs).

// Element e's factor (q × q) into `carried` at `at`; false: refused.
fn primal_material_factor(e: u32, pts: ptr<function, array<real, POINTS>>,
                          dynamic: ptr<function, array<u32, POINTS>>, q: u32,
                          w: ptr<function, array<real, POINTS>>, at: u32) -> bool {
    // (`w`: the inverse mass of each coordinate.)
    var h: array<real, HESS>;
    if (!material_frame_hessian(e, pts, &h)) {
        return false;
    }
    var system: array<real, SYS>;
    var factor: array<real, SYS>;
    var column: array<real, POINTS>;
    for (var attempt = 0u; attempt < 2u; attempt++) {
        for (var c = 0u; c < q; c++) {
            primal_block_column(e, &h, (*dynamic)[c], &column);
            for (var r = 0u; r < q; r++) {
                system[r * q + c] = column[(*dynamic)[r]] / call.alpha_tilde;
            }
        }
        for (var r = 0u; r < q; r++) {
            system[r * q + r] += 1.0 / (*w)[(*dynamic)[r]];
        }
        if (primal_cholesky(&system, q, &factor)) {
            for (var t = 0u; t < q * q; t++) {
                carried[at + t] = factor[t];
            }
            return true;
        }
        if (attempt == 1u || !project_psd(&h, DIM * (call.arity - 1u))) {
            return false;
        }
    }
    return false;
}

// Halvings of the step before the element keeps its point.
const PRIMAL_HALVINGS: u32 = 6u;

// φ(y) = ½ Σ_dyn (y − a)²/w + W/α~ at `points` (W = `energy` there).
fn primal_objective(points: ptr<function, array<real, POINTS>>, anchor: ptr<function, array<real, POINTS>>,
                    dynamic: ptr<function, array<u32, POINTS>>, q: u32,
                    w: ptr<function, array<real, POINTS>>, energy: real) -> real {
    var m: real = 0.0;
    for (var r = 0u; r < q; r++) {
        let cr = (*dynamic)[r];
        let u = (*points)[cr] - (*anchor)[cr];
        m += u * u / (*w)[cr];
    }
    return 0.5 * m + energy / call.alpha_tilde;
}

// The step length t of y = y0 + t Δ (Δ in `step`): the first of 1, ½, …
// at which the law accepts the element and φ(y) ≤ φ(y0); 0 when none does.
fn primal_step_length(e: u32, energy: real, pts: ptr<function, array<real, POINTS>>,
                      anchor: ptr<function, array<real, POINTS>>,
                      dynamic: ptr<function, array<u32, POINTS>>, q: u32,
                      w: ptr<function, array<real, POINTS>>,
                      step: ptr<function, array<real, POINTS>>) -> real {
    let start = primal_objective(pts, anchor, dynamic, q, w, energy);
    var trial = *pts;
    var grad: array<real, POINTS>;
    var t: real = 1.0;
    for (var halving = 0u; halving <= PRIMAL_HALVINGS; halving++) {
        for (var r = 0u; r < q; r++) {
            let cr = (*dynamic)[r];
            trial[cr] = (*pts)[cr] + t * (*step)[r];
        }
        var refused = false;
        let trial_energy = material_energy(e, &trial, &grad, &refused);
        if (!refused && primal_objective(&trial, anchor, dynamic, q, w, trial_energy) <= start) {
            return t;
        }
        t *= 0.5;
    }
    return 0.0;
}

fn primal_material_element(t: u32) {
    let e = call.first + t;
    let s = call.slot_base + e;
    let arity = call.arity;
    let count = arity * DIM;
    let base = call.carried + e * count;
    let at = call.factors + e * count * count;
    var pts: array<real, POINTS>;
    gather(e, &pts);
    var anchor: array<real, POINTS>;
    var w: array<real, POINTS>;
    primal_anchor(e, base, &pts, &anchor, &w);
    var grad: array<real, POINTS>;
    var refused = false;
    let energy = material_energy(e, &pts, &grad, &refused);
    if (refused) {
        fail(e);
        return;
    }
    // The dynamic coordinates, in order; w per coordinate from here on.
    var dynamic: array<u32, POINTS>;
    var wc: array<real, POINTS>;
    var q = 0u;
    for (var c = 0u; c < count; c++) {
        wc[c] = w[c / DIM];
        if (wc[c] != 0.0) {
            dynamic[q] = c;
            q++;
        }
    }
    if ((call.flags & FLAG_FIRST) != 0u && !primal_material_factor(e, &pts, &dynamic, q, &wc, at)) {
        fail(e);
        return;
    }
    var rhs: array<real, POINTS>;
    for (var r = 0u; r < q; r++) {
        let cr = dynamic[r];
        rhs[r] = -((pts[cr] - anchor[cr]) / wc[cr] + grad[cr] / call.alpha_tilde);
    }
    for (var i = 0u; i < q; i++) {
        var v = rhs[i];
        for (var m = 0u; m < i; m++) {
            v -= carried[at + i * q + m] * rhs[m];
        }
        rhs[i] = v / carried[at + i * q + i];
    }
    for (var step = 0u; step < q; step++) {
        let i = q - 1u - step;
        var v = rhs[i];
        for (var m = i + 1u; m < q; m++) {
            v -= carried[at + m * q + i] * rhs[m];
        }
        rhs[i] = v / carried[at + i * q + i];
    }
    let length = primal_step_length(e, energy, &pts, &anchor, &dynamic, q, &wc, &rhs);
    var d: array<real, POINTS>;
    for (var r = 0u; r < q; r++) {
        let cr = dynamic[r];
        d[cr] = pts[cr] + length * rhs[r] - anchor[cr];
    }
    // (W may round to a hair below 0 at rest.)
    let l = -sqrt(2.0 * select(0.0, energy, energy > 0.0)) / call.alpha_tilde;
    var ok = finite(l);
    for (var c = 0u; c < count; c++) {
        ok = ok && finite(d[c]);
    }
    if (!ok) {
        fail(e);
        return;
    }
    primal_commit(e, s, base, l, &d, &anchor, &w);
}
