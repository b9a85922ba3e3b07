// The coupled implicit step's particle passes (composed right after
// coupled.wgsl, whose bindings, records and element passes they read):
// each particle gathers its elements' slots (no atomics) and adds its own
// terms — inertia, gravity, the obstacle barriers and the lagged plane
// friction — for the start, the gradient and the curvature. Same
// arithmetic, in the same order, as cpu/src/coupled/ (f64 golden path).

// The element values of particle i's slots (records' gradients with
// `from_records`, else the slots) added to `sum`.
fn gather_into(i: u32, from_records: bool, sum: ptr<function, array<real, DIM>>) {
    let width = cp.arity_max * DIM;
    let first = gather[i];
    let last = gather[i + 1u];
    for (var k = first; k < last; k++) {
        let s = gather[bp.count + 1u + k];
        let e = s / cp.arity_max;
        let j = s % cp.arity_max;
        for (var a = 0u; a < DIM; a++) {
            if (from_records) {
                (*sum)[a] += records[e * record_len() + 3u + j * DIM + a];
            } else {
                (*sum)[a] += slots[e * width + j * DIM + a];
            }
        }
    }
}

struct Own {
    energy: real,
    force: real,
    infeasible: bool,
    gradient: array<real, DIM>,
    block: array<real, MAT>,
}

// One lag's friction (normal n, F_max = `limit`) of particle i at `p`
// into `own` (particles.rs obstacle_terms, one lag).
fn add_lag(own: ptr<function, Own>, i: u32, p: ptr<function, array<real, DIM>>, n: array<real, DIM>, limit: real, derivatives: bool) {
    var w: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        w[a] = (*p)[a] - vectors[at(R_START, i * DIM + a)];
    }
    let t = tangent(n, limit, w);
    (*own).energy += t.energy;
    if (derivatives) {
        for (var a = 0u; a < DIM; a++) {
            (*own).gradient[a] += t.gradient[a];
        }
        // The lag's block first, then added (TangentCurvature::block,
        // then b += lag_block): one sum per entry, so no compiler can
        // fold the block's old value into the block's two terms.
        var lag: array<real, MAT>;
        for (var a = 0u; a < DIM; a++) {
            for (var b = 0u; b < DIM; b++) {
                var identity: real = 0.0;
                if (a == b) {
                    identity = 1.0;
                }
                lag[a * DIM + b] = t.across * (identity - n[a] * n[b])
                    + (t.along - t.across) * t.direction[a] * t.direction[b];
            }
        }
        for (var k = 0u; k < MAT; k++) {
            (*own).block[k] += lag[k];
        }
    }
}

// Obstacle barriers and lagged plane and simplex friction of particle i at `p`
// (particles.rs obstacle_terms): energy; with `derivatives`, gradient,
// PSD block and Σ|b'|.
fn obstacle_terms(i: u32, p: ptr<function, array<real, DIM>>, derivatives: bool) -> Own {
    var own: Own;
    own.energy = 0.0;
    own.force = 0.0;
    own.infeasible = false;
    for (var a = 0u; a < DIM; a++) {
        own.gradient[a] = 0.0;
    }
    for (var k = 0u; k < MAT; k++) {
        own.block[k] = 0.0;
    }
    var n: array<real, DIM>;
    var walk = walk_start(p, radius[i], bp.activation);
    for (var o = walk_next(&walk); o != WALK_END; o = walk_next(&walk)) {
        let d = obstacle_distance(o, p, radius[i], &n);
        if (d >= bp.activation) {
            continue;
        }
        if (!(d > 0.0)) {
            own.infeasible = true;
            continue;
        }
        let law = barrier_law(d);
        own.energy += law.x;
        own.force += abs(law.y);
        if (derivatives) {
            for (var a = 0u; a < DIM; a++) {
                own.gradient[a] += law.y * n[a];
                for (var c = 0u; c < DIM; c++) {
                    own.block[a * DIM + c] += law.z * n[a] * n[c];
                }
            }
        }
    }
    for (var o = 0u; o < bp.planes; o++) {
        let limit = lag_force[i * bp.planes + o];
        if (!(limit > 0.0)) {
            continue;
        }
        var n: array<real, DIM>;
        for (var a = 0u; a < DIM; a++) {
            n[a] = geometry[o * DIM + a];
        }
        add_lag(&own, i, p, n, limit, derivatives);
    }
    if (cp.mesh_friction == 1u) {
        // Simplex lags (setup.rs lags): the simplices near x^t with μ > 0
        // and 0 < d < d^ there, in walk order, n and F_max recomputed
        // from x^t by the same operations.
        var start: array<real, DIM>;
        for (var a = 0u; a < DIM; a++) {
            start[a] = vectors[at(R_START, i * DIM + a)];
        }
        var lag_walk = walk_start(&start, radius[i], bp.activation);
        for (var o = walk_next(&lag_walk); o != WALK_END; o = walk_next(&lag_walk)) {
            if (o < bp.planes || !(obstacle_mu[o] > 0.0)) {
                continue;
            }
            var n: array<real, DIM>;
            let d = obstacle_distance(o, &start, radius[i], &n);
            if (!(d > 0.0 && d < bp.activation)) {
                continue;
            }
            let normal_force = -barrier_law(d).y;
            if (normal_force > 0.0) {
                add_lag(&own, i, p, n, obstacle_mu[o] * normal_force, derivatives);
            }
        }
    }
    return own;
}

fn load_point(i: u32) -> array<real, DIM> {
    var p: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        p[a] = x[i * DIM + a];
    }
    return p;
}

// x^t, x~, the load, x_0 = x^t and x~ − x^t from the point buffer (the
// state at the substep's start); the friction lags and d ≤ 0 at x^t.
@compute @workgroup_size(WORKGROUP)
fn cp_start(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= bp.count) {
        return;
    }
    let m = mass[i];
    for (var a = 0u; a < DIM; a++) {
        let k = i * DIM + a;
        var predicted = x[k];
        if (m > 0.0) {
            predicted = x[k] + cp.h * v[k];
        }
        vectors[at(R_START, k)] = x[k];
        vectors[at(R_X, k)] = x[k];
        vectors[at(R_PREDICTION, k)] = predicted;
        vectors[at(R_DIRECTION, k)] = predicted - x[k];
        vectors[at(R_LOAD, k)] = m * gravity_scale[i] * gravity[a] + force[k];
    }
    var p = load_point(i);
    var n: array<real, DIM>;
    var walk = walk_start(&p, radius[i], bp.activation);
    for (var o = walk_next(&walk); o != WALK_END; o = walk_next(&walk)) {
        if (o < bp.planes) {
            lag_force[i * bp.planes + o] = 0.0;
        }
        if (!(m > 0.0)) {
            continue;
        }
        let d = obstacle_distance(o, &p, radius[i], &n);
        if (!(d > 0.0)) {
            atomicMin(&status[2], i);
            continue;
        }
        var normal_force: real = 0.0;
        if (d < bp.activation) {
            normal_force = -barrier_law(d).y;
        }
        if (o < bp.planes && normal_force > 0.0 && obstacle_mu[o] > 0.0) {
            lag_force[i * bp.planes + o] = obstacle_mu[o] * normal_force;
        }
    }
    check_loops(i);
}

// g = m (x − x~) − h² load + h² (own + Σ slots) at the point buffer into
// R_GRADIENT, B_i and the energy terms, the residual term into channel A.
@compute @workgroup_size(WORKGROUP)
fn cp_gradient(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= bp.count) {
        return;
    }
    let m = mass[i];
    for (var k = 0u; k < TERMS; k++) {
        terms[i * TERMS + k] = 0.0;
    }
    if (m == 0.0) {
        for (var a = 0u; a < DIM; a++) {
            vectors[at(R_GRADIENT, i * DIM + a)] = 0.0;
        }
        tree[cp.channel_a + i] = 0.0;
        check_loops(i);
        return;
    }
    var p = load_point(i);
    let own = obstacle_terms(i, &p, true);
    for (var k = 0u; k < MAT; k++) {
        terms[i * TERMS + k] = own.block[k];
    }
    var energy = own.energy;
    if (own.infeasible) {
        energy = REAL_MAX;
    }
    var largest: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        largest = max(largest, abs(p[a]));
    }
    let gamma = (real(DIM) + 4.0) * cp.epsilon;
    terms[i * TERMS + MAT] = energy;
    terms[i * TERMS + MAT + 1u] = own.force * gamma * (largest + bp.scale + radius[i]);
    var sum: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        sum[a] = own.gradient[a];
    }
    gather_into(i, true, &sum);
    var ok = finite(energy) && energy < REAL_MAX;
    var squared: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        let k = i * DIM + a;
        let g = m * (p[a] - vectors[at(R_PREDICTION, k)]) - cp.h2 * vectors[at(R_LOAD, k)] + cp.h2 * sum[a];
        vectors[at(R_GRADIENT, k)] = g;
        ok = ok && finite(g);
        squared += g * g;
    }
    if (!ok) {
        atomicMin(&status[1], i);
    }
    if (cp.criterion == 0u) {
        tree[cp.channel_a + i] = squared;
    } else {
        tree[cp.channel_a + i] = sqrt(squared) / (m * cp.h2);
    }
    check_loops(i);
}

// The particles' half of H = M + h² Σ K⁺, after cp_slots of the same
// cp.diagonal: 1 → P⁻¹ = 1/(m + h² (diag B_i + Σ slots)) into R_INVERSE;
// 0 → q = m p + h² (B_i p_i + Σ slots) (0 where P⁻¹ = 0) into R_Q, p·q per
// particle into channel A. Fixed particles: 0. Nothing once PCG has stopped.
@compute @workgroup_size(WORKGROUP)
fn cp_particle_curvature(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= bp.count || cg.stopped != 0u) {
        return;
    }
    let m = mass[i];
    var sum: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        if (cp.diagonal == 1u) {
            sum[a] = terms[i * TERMS + a * DIM + a];
        } else {
            var s: real = 0.0;
            for (var b = 0u; b < DIM; b++) {
                s += terms[i * TERMS + a * DIM + b] * vectors[at(R_P, i * DIM + b)];
            }
            sum[a] = s;
        }
    }
    if (m != 0.0) {
        gather_into(i, false, &sum);
    }
    var dot: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        let k = i * DIM + a;
        var value: real = 0.0;
        if (cp.diagonal == 1u) {
            if (m != 0.0) {
                value = 1.0 / (m + cp.h2 * sum[a]);
            }
            vectors[at(R_INVERSE, k)] = value;
        } else {
            if (m != 0.0 && vectors[at(R_INVERSE, k)] != 0.0) {
                value = m * vectors[at(R_P, k)] + cp.h2 * sum[a];
            }
            vectors[at(R_Q, k)] = value;
            dot += vectors[at(R_P, k)] * value;
        }
    }
    if (cp.diagonal == 0u) {
        tree[cp.channel_a + i] = dot;
    }
    check_loops(i);
}
