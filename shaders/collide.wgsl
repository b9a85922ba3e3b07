// Particle–particle contact, one gather-Jacobi iteration — the arithmetic of
// cpu/src/collide.rs, in the same order:
//
//   contact_snapshot  y = x                      (the iterate every pair reads)
//   collide           particle k, over its list (ascending partners m):
//                     pair (i, j) = (min(k, m), max(k, m)), from y:
//                       d = y_j − y_i;  C = |d| − (r_i + r_j);  active iff C < 0, |d| > 0
//                       n = d / |d|;  s = −C;  c = n s − t_f   (t_f: clamped tangential
//                       motion since the substep start p, μ > 0 only)
//                     x_k = y_k + Σ_active ±(w_k / (w_i + w_j)) c / (active count)
//
// Each pair's correction is computed by both of its particles with the same
// operations on the same operands (i < j as on the CPU), so both see the
// CPU's value; each particle sums in ascending partner order — the order of
// its CPU contact list. No atomics on reals.
//
// Failures, as the CPU reports them: a non-finite |d| fails the pair's
// lower particle i (index i: the CPU stops at the first such pair, the one
// with the smallest i); a non-finite new position fails particle k with
// index count + k, so a pair failure anywhere wins (the CPU's pair loop runs
// before its gather).
//
//   contact_report        per particle: deepest overlap r_k + r_m − |x_m − x_k|
//                         over its partners m > k → scratch; active pairs
//   contact_report_final  max(0, deepest), Σ active → the world's report
//                         (scratch[world]) and counters (one workgroup per world)
//
// In a batch each invocation enters its particle's world (contact.wgsl):
// its records, lists, μ (props) and report are that world's.

fn report_at() -> u32 {
    return world;
}

fn deepest_at(k: u32) -> u32 {
    return scratch_at(REPORT + 1u + k);
}

@compute @workgroup_size(WORKGROUP)
fn contact_snapshot(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = linear_index(gid, groups);
    if (t >= all_particles() || failed_before()) {
        return;
    }
    let k = enter(t);
    var q = load_x(k);
    set_last_lane(&q, radius(k));
    for (var c = 0u; c < VEC; c++) {
        snapshot[VEC * particle(k) + c] = word(&q, c);
    }
}

@compute @workgroup_size(WORKGROUP)
fn collide(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = linear_index(gid, groups);
    let n = cparams.count;
    if (t >= all_particles() || failed_before()) {
        return;
    }
    let k = enter(t);
    let own = iterate_record(k);
    let yk = coords(own);
    let rk = extra(own);
    var own_start = load_p(k);
    let pk = coords(own_start);
    let wk = inverse_mass_of(&own_start);
    let mu = friction_of(k);
    var sum: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        sum[a] = 0.0;
    }
    var touching = 0u;
    var ahead = 0u;
    let len = words[box_word(1u, k)];
    var quad = vec4<u32>(0u);
    for (var t = 0u; t < len; t++) {
        if (t % 4u == 0u) {
            quad = list_quad(k, t / 4u);
        }
        let m = quad[t % 4u];
        let other = iterate_record(m);
        let ym = coords(other);
        let lower = k < m; // k is i of the pair (i, j) = (min, max)
        var d: array<real, DIM>;
        var len2: real = 0.0;
        for (var a = 0u; a < DIM; a++) {
            d[a] = select(yk[a] - ym[a], ym[a] - yk[a], lower);
            len2 += d[a] * d[a];
        }
        let dist = sqrt(len2);
        if (!finite(dist)) {
            fail(min(k, m));
            return;
        }
        let rm = extra(other);
        let c = dist - select(rm + rk, rk + rm, lower);
        if (!(c < 0.0 && dist > 0.0)) {
            continue;
        }
        if (lower) {
            ahead++;
        }
        let s = -c;
        let inv = 1.0 / dist;
        for (var a = 0u; a < DIM; a++) {
            d[a] *= inv;
        }
        var out: array<real, DIM>;
        for (var a = 0u; a < DIM; a++) {
            out[a] = d[a] * s;
        }
        var other_start = load_p(m);
        if (mu > 0.0) {
            // Δr = (y_j − p_j) − (y_i − p_i)
            let pm = coords(other_start);
            var dr: array<real, DIM>;
            var dn: real = 0.0;
            for (var a = 0u; a < DIM; a++) {
                dr[a] = select((yk[a] - pk[a]) - (ym[a] - pm[a]), (ym[a] - pm[a]) - (yk[a] - pk[a]), lower);
                dn += dr[a] * d[a];
            }
            var t2: real = 0.0;
            for (var a = 0u; a < DIM; a++) {
                let tan = dr[a] - dn * d[a];
                t2 += tan * tan;
            }
            let t_norm = sqrt(t2);
            let bound = mu * s;
            var scale: real = 1.0;
            if (!(t_norm <= bound)) {
                scale = bound / t_norm;
            }
            for (var a = 0u; a < DIM; a++) {
                let tan = dr[a] - dn * d[a];
                out[a] -= tan * scale;
            }
        }
        if (wk == 0.0) {
            continue;
        }
        let wm = inverse_mass_of(&other_start);
        let share = wk / select(wm + wk, wk + wm, lower);
        let sign = select(share, -share, lower);
        for (var a = 0u; a < DIM; a++) {
            sum[a] += sign * out[a];
        }
        touching++;
    }
    words[box_word(2u, k)] = ahead;
    check_loops(t);
    if (touching == 0u) {
        return;
    }
    let count = real(touching);
    var ok = true;
    var moved = load_x(k);
    for (var a = 0u; a < DIM; a++) {
        let xk = yk[a] + sum[a] / count;
        set_lane(&moved, a, xk);
        ok = ok && finite(xk);
    }
    store_x(k, moved);
    if (!ok) {
        fail(n + k);
    }
}

@compute @workgroup_size(WORKGROUP)
fn contact_report(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = linear_index(gid, groups);
    if (t >= all_particles() || failed_before()) {
        return;
    }
    let k = enter(t);
    var deepest: real = 0.0;
    var xk = load_x(k);
    let len = words[box_word(1u, k)];
    for (var t = 0u; t < len; t++) {
        let m = entry_at(k, t);
        if (m < k) {
            continue;
        }
        var xm = load_x(m);
        var len2: real = 0.0;
        for (var a = 0u; a < DIM; a++) {
            let d = lane(&xm, a) - lane(&xk, a);
            len2 += d * d;
        }
        deepest = max(deepest, radius(k) + radius(m) - sqrt(len2));
    }
    scratch[deepest_at(k)] = deepest;
    check_loops(t);
}

var<workgroup> report_deepest: array<real, WORKGROUP>;
var<workgroup> report_active: array<u32, WORKGROUP>;

@compute @workgroup_size(WORKGROUP)
fn contact_report_final(@builtin(local_invocation_index) lid: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    enter_world(wid.x + wid.y * groups.x);
    var deepest: real = 0.0;
    var pushing = 0u;
    for (var k = lid; k < cparams.count; k += WORKGROUP) {
        deepest = max(deepest, scratch[deepest_at(k)]);
        pushing += words[box_word(2u, k)];
    }
    report_deepest[lid] = deepest;
    report_active[lid] = pushing;
    check_loops(lid);
    workgroupBarrier();
    if (lid != 0u || failed_before()) {
        return;
    }
    for (var t = 1u; t < WORKGROUP; t++) {
        deepest = max(deepest, report_deepest[t]);
        pushing += report_active[t];
    }
    scratch[report_at()] = deepest;
    atomicStore(&counters[counter(ACTIVE)], pushing);
}
