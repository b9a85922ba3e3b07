// The coupled step's vector passes (after coupled.wgsl, whose bindings
// and helpers they use): PCG's updates, the line search's slope, trials
// and changes, the certified step filter, the updates of x and v, and the
// block-tree reduction. Same arithmetic, in the same order, as the golden
// path (core/src/implicit/pcg.rs, certified_filter.rs, reduction.rs;
// cpu/src/coupled/).

// ------------------------------------------------------------ CG vectors

// PCG's residual by cp.mode: 0 the start d = 0, r = −g (0 where P⁻¹ = 0),
// p = z; 1 an advance d += α p, r −= α q (α = cg.alpha). Then z = P⁻¹ r;
// r·r into A, r·z into B. Nothing once PCG has stopped.
@compute @workgroup_size(WORKGROUP)
fn cp_cg_residual(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= bp.count || cg.stopped != 0u) {
        return;
    }
    let alpha = cg.alpha;
    var rr: real = 0.0;
    var rz: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        let k = i * DIM + a;
        let inverse = vectors[at(R_INVERSE, k)];
        var r: real = 0.0;
        if (cp.mode == 0u) {
            if (inverse != 0.0) {
                r = -vectors[at(R_GRADIENT, k)];
            }
            vectors[at(R_DIRECTION, k)] = 0.0;
        } else {
            vectors[at(R_DIRECTION, k)] += alpha * vectors[at(R_P, k)];
            r = vectors[at(R_R, k)] - alpha * vectors[at(R_Q, k)];
        }
        let z = inverse * r;
        vectors[at(R_R, k)] = r;
        vectors[at(R_Z, k)] = z;
        if (cp.mode == 0u) {
            vectors[at(R_P, k)] = z;
        }
        rr += r * r;
        rz += r * z;
    }
    tree[cp.channel_a + i] = rr;
    tree[cp.channel_b + i] = rz;
}

// p = z + β p (β = cg.beta). Nothing once PCG has stopped.
@compute @workgroup_size(WORKGROUP)
fn cp_cg_turn(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= bp.count || cg.stopped != 0u) {
        return;
    }
    let beta = cg.beta;
    for (var a = 0u; a < DIM; a++) {
        let k = i * DIM + a;
        vectors[at(R_P, k)] = vectors[at(R_Z, k)] + beta * vectors[at(R_P, k)];
    }
}

// x is finite as the host reads it back (neither NaN nor ±∞, and not
// REAL_MAX, which a read-back turns into +∞).
fn cg_finite(x: real) -> bool {
    return x == x && abs(x) < REAL_MAX;
}

fn cg_stop(status: u32) {
    cg.status = status;
    cg.stopped = 1u;
}

// The first half of a PCG iteration (pcg_on): count it, then c = p·q;
// non-finite → stop (2); c ≤ 0 → stop (3); else α = ρ / c.
@compute @workgroup_size(WORKGROUP)
fn cp_cg_alpha(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    if (linear_index(gid, groups) != 0u || cg.stopped != 0u) {
        return;
    }
    cg.iterations += 1u;
    let c = tree[cg.pq_at];
    cg.curvature = c;
    if (!cg_finite(c)) {
        cg_stop(2u);
        return;
    }
    if (c <= 0.0) {
        cg_stop(3u);
        return;
    }
    cg.alpha = cg.rho / c;
}

// The second half (after the advance): ‖r‖ = √(r·r) is the final
// residual; non-finite → stop (2); ‖r‖ ≤ tolerance → stop (1); else
// β = (r·z)/ρ, ρ = r·z, and at the budget → stop (4).
@compute @workgroup_size(WORKGROUP)
fn cp_cg_beta(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    if (linear_index(gid, groups) != 0u || cg.stopped != 0u) {
        return;
    }
    let residual = sqrt(tree[cg.rr_at]);
    cg.residual = residual;
    if (!cg_finite(residual)) {
        cg_stop(2u);
        return;
    }
    if (residual <= cg.tolerance) {
        cg_stop(1u);
        return;
    }
    let next = tree[cg.rz_at];
    cg.beta = next / cg.rho;
    cg.rho = next;
    if (cg.iterations >= cg.max_iterations) {
        cg_stop(4u);
    }
}

// ---------------------------------------------------------- line search

// g·d per particle into A; status[0] when some x + d ≠ x.
@compute @workgroup_size(WORKGROUP)
fn cp_slope(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= bp.count) {
        return;
    }
    var dot: real = 0.0;
    var moved = false;
    for (var a = 0u; a < DIM; a++) {
        let k = i * DIM + a;
        let d = vectors[at(R_DIRECTION, k)];
        dot += vectors[at(R_GRADIENT, k)] * d;
        let xk = vectors[at(R_X, k)];
        moved = moved || (xk + d != xk);
    }
    tree[cp.channel_a + i] = dot;
    if (moved) {
        atomicOr(&status[0], 1u);
    }
}

// R_TRIAL = x + t d (t = cp.step); status[0] when the trial differs from x.
@compute @workgroup_size(WORKGROUP)
fn cp_trial(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= bp.count) {
        return;
    }
    var differs = false;
    for (var a = 0u; a < DIM; a++) {
        let k = i * DIM + a;
        let xk = vectors[at(R_X, k)];
        let y = xk + cp.step * vectors[at(R_DIRECTION, k)];
        vectors[at(R_TRIAL, k)] = y;
        differs = differs || (y != xk);
    }
    if (differs) {
        atomicOr(&status[0], 1u);
    }
}

// F_i(y) − F_i(x) in difference form (y: the point buffer, x: R_X) into A.
@compute @workgroup_size(WORKGROUP)
fn cp_particle_changes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= bp.count) {
        return;
    }
    let m = mass[i];
    if (m == 0.0) {
        tree[cp.channel_a + i] = 0.0;
        check_loops(i);
        return;
    }
    var p = load_point(i);
    let own = obstacle_terms(i, &p, false);
    var inertia: real = 0.0;
    var work: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        let k = i * DIM + a;
        let xk = vectors[at(R_X, k)];
        let s = p[a] - xk;
        inertia += s * ((xk - vectors[at(R_PREDICTION, k)]) + 0.5 * s);
        work += vectors[at(R_LOAD, k)] * s;
    }
    var change = m * inertia - cp.h2 * work + cp.h2 * (own.energy - terms[i * TERMS + MAT]);
    if (own.infeasible) {
        change = REAL_MAX;
    }
    tree[cp.channel_a + i] = change;
    check_loops(i);
}

// ------------------------------------------------ certified step filter

fn trial_rounding(p: ptr<function, array<real, DIM>>, step: ptr<function, array<real, DIM>>) -> real {
    var largest_x: real = 0.0;
    var largest_step: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        largest_x = max(largest_x, abs((*p)[a]));
        largest_step = max(largest_step, abs((*step)[a]));
    }
    return real(DIM) * cp.epsilon * (largest_x + 2.0 * largest_step);
}

fn certified_time(low: real, approach: real) -> real {
    if (!(low > 0.0)) {
        return 0.0;
    }
    if (approach > 0.0) {
        return low / approach;
    }
    if (approach != approach) {
        return 0.0;
    }
    return REAL_MAX;
}

// certified_filter.rs plane_time for plane o.
fn plane_time(o: u32, i: u32, p: ptr<function, array<real, DIM>>, step: ptr<function, array<real, DIM>>) -> real {
    let offset = geometry[bp.planes * DIM + o];
    let gamma = (real(DIM) + 4.0) * cp.epsilon;
    var dot: real = 0.0;
    var size: real = 0.0;
    var closing: real = 0.0;
    var closing_size: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        let n = geometry[o * DIM + a];
        dot += n * (*p)[a];
        size += abs(n * (*p)[a]);
        closing -= n * (*step)[a];
        closing_size += abs(n * (*step)[a]);
    }
    let d0 = dot - offset - radius[i];
    let rounding = gamma * (size + abs(offset) + radius[i]) + trial_rounding(p, step);
    return certified_time(d0 - rounding, closing + gamma * closing_size);
}

// certified_filter.rs simplex_time for simplex s: the support bound of
// the offset w = x − q̂ the closest-point search returns.
fn simplex_time(s: u32, i: u32, p: ptr<function, array<real, DIM>>, step: ptr<function, array<real, DIM>>) -> real {
    var w: array<real, DIM>;
    _ = simplex_offset(s, p, &w);
    var w_squared: real = 0.0;
    var step_squared: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        w_squared += w[a] * w[a];
        step_squared += (*step)[a] * (*step)[a];
    }
    let w_length = sqrt(w_squared);
    if (!(w_length > 0.0)) {
        return 0.0;
    }
    var support = REAL_MAX;
    var size: real = 0.0;
    for (var v = 0u; v < 4u; v++) {
        if (v < arity[s]) {
            var s_v: real = 0.0;
            var a_v: real = 0.0;
            for (var a = 0u; a < DIM; a++) {
                let term = w[a] * ((*p)[a] - vertex(s, v, a));
                s_v += term;
                a_v += abs(term);
            }
            support = min(support, s_v);
            size = max(size, a_v);
        }
    }
    let gamma = (real(DIM) + 4.0) * cp.epsilon;
    let d0 = support / w_length - radius[i];
    let rounding = gamma * (size / w_length + radius[i]) + trial_rounding(p, step);
    return certified_time(d0 - rounding, sqrt(step_squared) * (1.0 + gamma));
}

// Certified time of every obstacle of particle i (free particles; planes,
// then simplices) from R_X along R_DIRECTION into channel T.
@compute @workgroup_size(WORKGROUP)
fn cp_filter_particles(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= bp.count) {
        return;
    }
    var t = REAL_MAX;
    if (mass[i] > 0.0) {
        var p: array<real, DIM>;
        var step: array<real, DIM>;
        for (var a = 0u; a < DIM; a++) {
            p[a] = vectors[at(R_X, i * DIM + a)];
            step[a] = vectors[at(R_DIRECTION, i * DIM + a)];
        }
        for (var o = 0u; o < bp.planes; o++) {
            t = min(t, plane_time(o, i, &p, &step));
        }
        var length2: real = 0.0;
        for (var a = 0u; a < DIM; a++) {
            length2 += step[a] * step[a];
        }
        let reach = filter_reach(sqrt(length2), cp.epsilon);
        var walk = walk_box(&p, radius[i], reach, support_margin(cp.epsilon));
        walk.plane = bp.planes;
        for (var o = walk_next(&walk); o != WALK_END; o = walk_next(&walk)) {
            t = min(t, simplex_time(o - bp.planes, i, &p, &step));
        }
    }
    tree[cp.channel_t + i] = t;
    check_loops(i);
}

// certified_filter.rs pair_time of every ball element into channel T
// after the particles.
@compute @workgroup_size(WORKGROUP)
fn cp_filter_pairs(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let b = linear_index(gid, groups);
    if (b >= cp.pairs) {
        return;
    }
    let e = cp.first_ball + b;
    let i = member(e, 0u);
    let j = member(e, 1u);
    var pts: array<real, POINTS>;
    var grad: array<real, POINTS>;
    var pi: array<real, DIM>;
    var pj: array<real, DIM>;
    var di: array<real, DIM>;
    var dj: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        pi[a] = vectors[at(R_X, i * DIM + a)];
        pj[a] = vectors[at(R_X, j * DIM + a)];
        di[a] = vectors[at(R_DIRECTION, i * DIM + a)];
        dj[a] = vectors[at(R_DIRECTION, j * DIM + a)];
        pts[a] = pi[a];
        pts[DIM + a] = pj[a];
    }
    let length = distance(&pts, &grad);
    var t: real = 0.0;
    if (length > 0.0) {
        let d0 = length - radius[i] - radius[j];
        let gamma = (real(DIM) + 4.0) * cp.epsilon;
        var closing: real = 0.0;
        var step2: real = 0.0;
        for (var a = 0u; a < DIM; a++) {
            let delta = dj[a] - di[a];
            closing -= grad[DIM + a] * delta;
            step2 += delta * delta;
        }
        let approach = closing + gamma * sqrt(step2);
        let rounding = gamma * (length + radius[i] + radius[j])
            + trial_rounding(&pi, &di) + trial_rounding(&pj, &dj);
        t = certified_time(d0 - rounding, approach);
    }
    tree[cp.channel_t + bp.count + b] = t;
}

// ------------------------------------------------------ updates of x, v

// A new iterate R_X by cp.mode: 0 the warm start x^t + τ (x~ − x^t)
// (τ = cp.step; the direction holds x~ − x^t), 1 x^t itself (a warm start
// the elements refuse), 2 an accepted trial R_TRIAL.
@compute @workgroup_size(WORKGROUP)
fn cp_set_x(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= bp.count) {
        return;
    }
    for (var a = 0u; a < DIM; a++) {
        let k = i * DIM + a;
        var value = vectors[at(R_TRIAL, k)];
        if (cp.mode == 0u) {
            value = vectors[at(R_START, k)] + cp.step * vectors[at(R_DIRECTION, k)];
        } else if (cp.mode == 1u) {
            value = vectors[at(R_START, k)];
        }
        vectors[at(R_X, k)] = value;
    }
}

// x = R_X, v = (x − x^t)/h for free particles: the minimiser is the state.
@compute @workgroup_size(WORKGROUP)
fn cp_finish(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= bp.count) {
        return;
    }
    for (var a = 0u; a < DIM; a++) {
        let k = i * DIM + a;
        let value = vectors[at(R_X, k)];
        x[k] = value;
        if (mass[i] > 0.0) {
            v[k] = (value - vectors[at(R_START, k)]) / cp.h;
        }
    }
}

// ------------------------------------------------------------ reductions

fn combine(a: real, b: real, op: u32) -> real {
    if (op == 0u) {
        return a + b;
    }
    if (op == 1u) {
        return max(a, b);
    }
    return min(a, b);
}

// One level of the block tree: workgroup b reduces tree[src + 64 b ..]
// (padded) into tree[dst + b].
@compute @workgroup_size(WORKGROUP)
fn cp_reduce(@builtin(local_invocation_index) t: u32, @builtin(workgroup_id) wid: vec3<u32>,
             @builtin(num_workgroups) groups: vec3<u32>) {
    let b = wid.x + wid.y * groups.x;
    let i = b * WORKGROUP + t;
    var value: real = 0.0;
    if (level.op == 2u) {
        value = REAL_MAX;
    }
    if (i < level.len) {
        value = tree[level.src + i];
    }
    block[t] = value;
    workgroupBarrier();
    for (var stride = WORKGROUP / 2u; stride > 0u; stride = stride / 2u) {
        if (t < stride) {
            block[t] = combine(block[t], block[t + stride], level.op);
        }
        workgroupBarrier();
    }
    if (t == 0u) {
        tree[level.dst + b] = block[0];
    }
}
