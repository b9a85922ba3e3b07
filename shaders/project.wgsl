// XPBD projection of one color of one family, one invocation per element.
// Elements of one color share no dynamic particle, so invocations write
// disjoint particles: no atomics, no dependence on scheduling.
//
//   α~ = α / h²
//   Δλ = (−C − α~ λ) / (Σ_j w_j |∇_j C|² + α~)
//   contacts (C ≥ 0): λ' = max(λ + Δλ, 0);  Δλ = λ' − λ
//   tethers (|x1 − x0| ≤ rest, params.flags == 1): λ' = min(λ + Δλ, 0)
//   x_j += w_j ∇_j C Δλ
//   static friction (active contact, μ > 0): Δt = tangential part of x − p;
//   if |Δt| ≤ μ w λ then x −= Δt
//
// Same arithmetic, in the same order, as cpu/src/project.rs. Fixed
// particles (w = 0) are never written.

@compute @workgroup_size(64)
fn project_distance(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = linear_index(gid, groups);
    if (t >= params.count || failed_before()) {
        return;
    }
    let e = params.first + t;
    let s = params.slot_base + e;
    let i = elements[params.elem_base + 2u * e];
    let j = elements[params.elem_base + 2u * e + 1u];
    let wi = inv_mass[i];
    let wj = inv_mass[j];
    var d: array<real, DIM>;
    var d2: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        d[a] = x[j * DIM + a] - x[i * DIM + a];
        d2 += d[a] * d[a];
    }
    let len = sqrt(d2);
    let wsum = wi + wj;
    if (!(len > 0.0) || wsum == 0.0) {
        if (!finite(len)) {
            fail(e);
        }
        return;
    }
    let c = len - rest[s];
    var dl = (-c - params.alpha_tilde * lambda[s]) / (wsum + params.alpha_tilde);
    if (!finite(dl)) {
        fail(e);
        return;
    }
    if (params.flags == 1u) {
        dl = min(lambda[s] + dl, 0.0) - lambda[s];
    }
    lambda[s] += dl;
    let inv = 1.0 / len;
    for (var a = 0u; a < DIM; a++) {
        let unit = d[a] * inv;
        if (wi != 0.0) {
            x[i * DIM + a] += wi * -unit * dl;
        }
        if (wj != 0.0) {
            x[j * DIM + a] += wj * unit * dl;
        }
    }
}

// Simplex measures (kind 1: squared k-measure, kind 2: oriented N-measure):
// gather, evaluate C and ∇C, update.
fn project_generic(t: u32, kind: u32) {
    let e = params.first + t;
    let s = params.slot_base + e;
    var pts: array<real, POINTS>;
    var grad: array<real, POINTS>;
    gather(e, &pts);
    var value: real;
    if (kind == 1u) {
        value = simplex_squared_measure(&pts, params.arity - 1u, &grad);
    } else {
        value = oriented_measure(&pts, &grad);
    }
    if (!finite(value)) {
        fail(e);
        return;
    }
    var wsum: real = 0.0;
    for (var j = 0u; j < params.arity; j++) {
        var g2: real = 0.0;
        for (var a = 0u; a < DIM; a++) {
            g2 += grad[j * DIM + a] * grad[j * DIM + a];
        }
        wsum += inv_mass[elements[params.elem_base + e * params.arity + j]] * g2;
    }
    if (wsum == 0.0) {
        return;
    }
    let c = value - rest[s];
    let dl = (-c - params.alpha_tilde * lambda[s]) / (wsum + params.alpha_tilde);
    if (!finite(dl)) {
        fail(e);
        return;
    }
    lambda[s] += dl;
    for (var j = 0u; j < params.arity; j++) {
        let i = elements[params.elem_base + e * params.arity + j];
        let w = inv_mass[i];
        if (w == 0.0) {
            continue;
        }
        for (var a = 0u; a < DIM; a++) {
            x[i * DIM + a] += w * grad[j * DIM + a] * dl;
        }
    }
}

@compute @workgroup_size(64)
fn project_simplex_measure(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = linear_index(gid, groups);
    if (t >= params.count || failed_before()) {
        return;
    }
    project_generic(t, 1u);
}

@compute @workgroup_size(64)
fn project_oriented_measure(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = linear_index(gid, groups);
    if (t >= params.count || failed_before()) {
        return;
    }
    project_generic(t, 2u);
}

@compute @workgroup_size(64)
fn project_contact(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = linear_index(gid, groups);
    if (t >= params.count || failed_before()) {
        return;
    }
    let e = params.first + t;
    let s = params.slot_base + e;
    let i = elements[params.elem_base + e];
    let w = inv_mass[i];
    var nx: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        nx += params.normal[a] * x[i * DIM + a];
    }
    let c = kept(nx) - rest[s];
    let l = lambda[s];
    let raw = (-c - params.alpha_tilde * l) / (w + params.alpha_tilde);
    if (!finite(raw)) {
        fail(e);
        return;
    }
    let dl = max(l + raw, 0.0) - l;
    let l_new = l + dl;
    lambda[s] = l_new;
    for (var a = 0u; a < DIM; a++) {
        x[i * DIM + a] += w * params.normal[a] * dl;
    }
    if (params.friction > 0.0 && l_new > 0.0) {
        var dn: real = 0.0;
        for (var a = 0u; a < DIM; a++) {
            dn += (x[i * DIM + a] - p[i * DIM + a]) * params.normal[a];
        }
        var t2: real = 0.0;
        for (var a = 0u; a < DIM; a++) {
            let tan = (x[i * DIM + a] - p[i * DIM + a]) - dn * params.normal[a];
            t2 += tan * tan;
        }
        let bound = params.friction * w * l_new;
        if (sqrt(t2) <= bound) {
            for (var a = 0u; a < DIM; a++) {
                let tan = (x[i * DIM + a] - p[i * DIM + a]) - dn * params.normal[a];
                x[i * DIM + a] -= tan;
            }
        }
    }
}
