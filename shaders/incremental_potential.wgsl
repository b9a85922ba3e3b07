// The whole incremental-potential substep on the GPU, composed after
// barrier.wgsl (which holds the obstacle distance, the barrier law and the
// bindings 0..=9). One invocation per particle; the residual is reduced by
// the fixed pairwise tree of cpu/src/incremental_potential.rs (one dispatch
// per stride). Same arithmetic, in the same order, as the f64 golden path.
//
//   ip_predict    x_prev = x;  x~ = x + h v                  (free particles)
//   ip_gradient   g = m (x − x~) − h² load + h² Σ b' n;  residual term
//                 (packed: |g|², acceleration: |g| w / h²; 0 for fixed);
//                 Σ b'' n nᵀ, Σ b, Σ |b'| kept for ip_newton (hessian,
//                 energy, scalar: one obstacle loop fewer there);
//                 status: infeasible start, non-finite gradient
//   ip_reduce_sum / ip_reduce_max   terms[i] ⊕= terms[i + s] for i ≡ 0 mod 2s
//   ip_newton     Δ = −(m I + h² Σ b'' n nᵀ)⁻¹ g (Cholesky), t = filter,
//                 Armijo halving on F(x + tΔ) − F(x) in difference form
//                 (c = 1e-4, ≤ 60), x += tΔ; status: moved
//   ip_decide     one invocation after each gradient reduction: Newton's stop
//                 test on the device (gpu/src/ip_decision.rs): logs terms[0] and
//                 status[0..4], stops on a refusal, a stall, value ≤ ip.threshold
//                 or the budget ip.max_iterations, else clears status[0..4] for
//                 the next ip_newton; once stopped, ip_gradient, the reductions,
//                 ip_decide and ip_newton do nothing (exact no-ops), and
//                 ip_velocity runs only after a stop that keeps the iterate
//   ip_velocity   v = (x − x_prev) / h                       (free particles)
//   every entry point ends with barrier.wgsl's check_loops (status[4])

struct IpParams {
    count: u32,     // particles
    stride: u32,    // reduction stride s
    criterion: u32, // 0: packed gradient, 1: max acceleration residual
    max_iterations: u32,
    h: real,
    armijo: real,
    threshold: real, // the largest reduced value whose residual meets the tolerance
    pad_b: real,
}

// barrier.wgsl's status (binding 10): status[0]: some particle moved
// (newton); status[1]: smallest particle with a non-finite gradient or
// direction; status[2]: smallest infeasible particle; status[3]: some
// particle's Armijo search failed although x + Δ ≠ x and its expected
// decrease was above the rounding of F's change; status[4]: LOOPS_CUT.
@group(0) @binding(11) var<storage, read_write> v: array<real>;
@group(0) @binding(12) var<storage, read_write> x_prev: array<real>;
@group(0) @binding(13) var<storage, read_write> prediction: array<real>;
@group(0) @binding(14) var<storage, read> inv_mass: array<real>;
@group(0) @binding(15) var<storage, read> gravity_scale: array<real>;
@group(0) @binding(16) var<storage, read> force: array<real>;
@group(0) @binding(17) var<storage, read_write> terms: array<real>;
@group(0) @binding(18) var<storage, read> gravity: array<real>;
// The stop decisions (ip_decide): [stopped, evaluations, stop code (0 none,
// 1 converged, 2 budget, 3 rounding floor, 4 refused), 0], then status[0..4] of
// each evaluation; `decided` holds each evaluation's reduced value.
@group(0) @binding(19) var<storage, read_write> decision: array<u32>;
@group(0) @binding(20) var<storage, read_write> decided: array<real>;
@group(1) @binding(0) var<storage, read> ip: IpParams;

const IP_NONE: u32 = 0xffffffffu;

fn stopped() -> bool {
    return decision[0] != 0u;
}

const MAX_HALVINGS: u32 = 60u;

fn is_finite(a: real) -> bool {
    return abs(a) <= REAL_MAX;
}

fn mass_of(i: u32) -> real {
    return 1.0 / inv_mass[i];
}

// m s g_a + f_a.
fn load(i: u32, a: u32) -> real {
    return mass_of(i) * gravity_scale[i] * gravity[a] + force[i * DIM + a];
}

// Σ_o b, Σ_o b' n and Σ_o b'' n nᵀ at p (CPU: evaluate_particle_barrier).
// Returns false where some d ≤ 0 (the energy is then +∞).
fn barrier_sum(p: ptr<function, array<real, DIM>>, r: real, e_out: ptr<function, real>,
               g: ptr<function, array<real, DIM>>, hm: ptr<function, array<real, MAT>>,
               fs: ptr<function, real>) -> bool {
    *e_out = 0.0;
    *fs = 0.0;
    for (var a = 0u; a < DIM; a++) {
        (*g)[a] = 0.0;
    }
    for (var a = 0u; a < MAT; a++) {
        (*hm)[a] = 0.0;
    }
    var feasible = true;
    var n: array<real, DIM>;
    var walk = walk_start(p, r, bp.activation);
    for (var o = walk_next(&walk); o != WALK_END; o = walk_next(&walk)) {
        let d = obstacle_distance(o, p, r, &n);
        if (d >= bp.activation) {
            continue;
        }
        if (!(d > 0.0)) {
            feasible = false;
            continue;
        }
        let law = barrier_law(d);
        *e_out += law.x;
        *fs += abs(law.y);
        for (var a = 0u; a < DIM; a++) {
            (*g)[a] += law.y * n[a];
            for (var c = 0u; c < DIM; c++) {
                (*hm)[a * DIM + c] += law.z * n[a] * n[c];
            }
        }
    }
    return feasible;
}

// F_i(y) − F_i(x) in difference form (CPU: ParticleTerms::change);
// REAL_MAX where y is infeasible.
fn change(i: u32, p: ptr<function, array<real, DIM>>, y: ptr<function, array<real, DIM>>, barrier_at_x: real,
          hm: ptr<function, array<real, MAT>>) -> real {
    var e: real;
    var g: array<real, DIM>;
    var fs: real;
    let feasible = barrier_sum(y, radius[i], &e, &g, hm, &fs);
    if (!feasible) {
        return REAL_MAX;
    }
    let h2 = ip.h * ip.h;
    var inertia: real = 0.0;
    var work: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        let s = (*y)[a] - (*p)[a];
        inertia += s * (((*p)[a] - prediction[i * DIM + a]) + 0.5 * s);
        work += load(i, a) * s;
    }
    return mass_of(i) * inertia - h2 * work + h2 * (e - barrier_at_x);
}

@compute @workgroup_size(WORKGROUP)
fn ip_predict(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= ip.count) {
        return;
    }
    for (var a = 0u; a < DIM; a++) {
        let k = i * DIM + a;
        x_prev[k] = x[k];
        prediction[k] = x[k] + ip.h * v[k];
    }
    check_loops(i);
}

@compute @workgroup_size(WORKGROUP)
fn ip_gradient(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= ip.count || stopped()) {
        return;
    }
    if (inv_mass[i] == 0.0) {
        terms[i] = 0.0;
    } else {
        gradient_particle(i);
    }
    check_loops(i);
}

fn gradient_particle(i: u32) {
    var p: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        p[a] = x[i * DIM + a];
    }
    var e: real;
    var bg: array<real, DIM>;
    var hm: array<real, MAT>;
    var fs: real;
    if (!barrier_sum(&p, radius[i], &e, &bg, &hm, &fs)) {
        atomicMin(&status[2], i);
    }
    let h2 = ip.h * ip.h;
    let m = mass_of(i);
    var squared: real = 0.0;
    var ok = true;
    for (var a = 0u; a < DIM; a++) {
        let ga = m * (p[a] - prediction[i * DIM + a]) - h2 * load(i, a) + h2 * bg[a];
        gradient[i * DIM + a] = ga;
        ok = ok && is_finite(ga);
        squared += ga * ga;
    }
    for (var a = 0u; a < MAT; a++) {
        hessian[i * MAT + a] = hm[a];
    }
    // The barrier terms at x, for ip_newton at the same x.
    energy[i] = e;
    scalar[i] = fs;
    if (!ok) {
        atomicMin(&status[1], i);
    }
    if (ip.criterion == 0u) {
        terms[i] = squared;
    } else {
        terms[i] = sqrt(squared) * inv_mass[i] / h2;
    }
}

@compute @workgroup_size(WORKGROUP)
fn ip_reduce_sum(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = linear_index(gid, groups);
    let i = 2u * ip.stride * k;
    if (i + ip.stride < ip.count && !stopped()) {
        terms[i] = terms[i] + terms[i + ip.stride];
        check_loops(i);
    }
}

@compute @workgroup_size(WORKGROUP)
fn ip_reduce_max(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = linear_index(gid, groups);
    let i = 2u * ip.stride * k;
    if (i + ip.stride < ip.count && !stopped()) {
        terms[i] = max(terms[i], terms[i + ip.stride]);
        check_loops(i);
    }
}

@compute @workgroup_size(WORKGROUP)
fn ip_newton(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= ip.count || stopped()) {
        return;
    }
    if (inv_mass[i] != 0.0) {
        newton_particle(i);
    }
    check_loops(i);
}

// One damped Newton step of free particle i (x[i] moves or not).
fn newton_particle(i: u32) {
    var p: array<real, DIM>;
    var g: array<real, DIM>;
    var all_zero = true;
    for (var a = 0u; a < DIM; a++) {
        p[a] = x[i * DIM + a];
        g[a] = gradient[i * DIM + a];
        all_zero = all_zero && g[a] == 0.0;
    }
    // Σ b, Σ b'' n nᵀ and Σ |b'| at x, as ip_gradient left them.
    var hm: array<real, MAT>;
    for (var a = 0u; a < MAT; a++) {
        hm[a] = hessian[i * MAT + a];
    }
    let barrier_at_x = energy[i];
    let force_sum = scalar[i];
    if (all_zero) {
        return;
    }
    // Newton matrix m I + h² B and its Cholesky solve (CPU: cholesky_solve).
    let h2 = ip.h * ip.h;
    let m = mass_of(i);
    var am: array<real, MAT>;
    var dir: array<real, DIM>;
    for (var r = 0u; r < DIM; r++) {
        for (var c = 0u; c < DIM; c++) {
            var diagonal: real = 0.0;
            if (r == c) {
                diagonal = m;
            }
            am[r * DIM + c] = diagonal + h2 * hm[r * DIM + c];
        }
        dir[r] = -g[r];
    }
    for (var c = 0u; c < DIM; c++) {
        var pivot = am[c * DIM + c];
        for (var k = 0u; k < c; k++) {
            pivot -= am[c * DIM + k] * am[c * DIM + k];
        }
        if (!(pivot > 0.0 && is_finite(pivot))) {
            atomicMin(&status[1], i);
            return;
        }
        let root = sqrt(pivot);
        am[c * DIM + c] = root;
        for (var r = c + 1u; r < DIM; r++) {
            var value = am[r * DIM + c];
            for (var k = 0u; k < c; k++) {
                value -= am[r * DIM + k] * am[c * DIM + k];
            }
            am[r * DIM + c] = value / root;
        }
    }
    for (var r = 0u; r < DIM; r++) {
        var value = dir[r];
        for (var k = 0u; k < r; k++) {
            value -= am[r * DIM + k] * dir[k];
        }
        dir[r] = value / am[r * DIM + r];
    }
    for (var q = 0u; q < DIM; q++) {
        let r = DIM - 1u - q;
        var value = dir[r];
        for (var k = r + 1u; k < DIM; k++) {
            value -= am[k * DIM + r] * dir[k];
        }
        dir[r] = value / am[r * DIM + r];
    }
    var at_floor = true;
    for (var a = 0u; a < DIM; a++) {
        at_floor = at_floor && p[a] + dir[a] == p[a];
    }
    if (at_floor) {
        return;
    }
    var slope: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        slope += g[a] * dir[a];
    }
    if (!is_finite(slope)) {
        atomicMin(&status[1], i);
        return;
    }
    // Rounding floor (CPU: change_resolution).
    var inertia_r: real = 0.0;
    var work_r: real = 0.0;
    var largest: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        let s = abs(dir[a]);
        inertia_r += s * (abs(p[a] - prediction[i * DIM + a]) + s);
        work_r += abs(load(i, a) * dir[a]);
        largest = max(largest, abs(p[a]));
    }
    let terms_r = real(DIM) + 4.0;
    let distance_error = terms_r * REAL_EPS * (largest + bp.scale + radius[i]);
    let resolution = terms_r * 0.5 * REAL_EPS * (m * inertia_r + h2 * work_r + 2.0 * h2 * abs(barrier_at_x))
        + 2.0 * h2 * force_sum * distance_error;
    // Certified filter fraction (CPU: filter_fraction), before any trial.
    var length2: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        length2 += dir[a] * dir[a];
    }
    let length = sqrt(length2);
    var t_star: real = REAL_MAX;
    var n: array<real, DIM>;
    var blocked = false;
    var walk = walk_start(&p, radius[i], filter_reach(length, REAL_EPS));
    for (var o = walk_next(&walk); o != WALK_END; o = walk_next(&walk)) {
        let d0 = obstacle_distance(o, &p, radius[i], &n);
        if (!(d0 > 0.0)) {
            blocked = true;
            break;
        }
        var approach = length;
        if (o < bp.planes) {
            var dot: real = 0.0;
            for (var a = 0u; a < DIM; a++) {
                dot += n[a] * dir[a];
            }
            approach = -dot;
        }
        if (approach > 0.0) {
            t_star = min(t_star, d0 / approach);
        }
    }
    var t: real = 0.0;
    if (!blocked) {
        t = min(bp.safety * t_star, 1.0);
    }
    var trial: array<real, DIM>;
    for (var k = 0u; k <= MAX_HALVINGS; k++) {
        var moved = false;
        for (var a = 0u; a < DIM; a++) {
            trial[a] = p[a] + t * dir[a];
            moved = moved || trial[a] != p[a];
        }
        var scratch: array<real, MAT>;
        let f = change(i, &p, &trial, barrier_at_x, &scratch);
        if (f <= ip.armijo * t * slope && moved) {
            for (var a = 0u; a < DIM; a++) {
                x[i * DIM + a] = trial[a];
            }
            atomicOr(&status[0], 1u);
            return;
        }
        t = t * 0.5;
    }
    // No trial decreased F_i: at the rounding floor, or a genuine stall.
    if (!(-0.5 * slope <= resolution)) {
        atomicOr(&status[3], 1u);
    }
}

@compute @workgroup_size(WORKGROUP)
fn ip_velocity(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    let code = decision[2];
    if (i >= ip.count || inv_mass[i] == 0.0 || code == 0u || code == 4u) {
        return;
    }
    for (var a = 0u; a < DIM; a++) {
        let k = i * DIM + a;
        v[k] = (x[k] - x_prev[k]) / ip.h;
    }
    check_loops(i);
}

// Newton's stop test after evaluation k (one invocation decides; the host's loop of
// gpu/src/incremental_potential.rs, decision for decision, replayed there
// from the log): refused (infeasible, non-finite, or nothing moved at k > 0
// although a search failed above the rounding), stalled at the rounding
// floor (k > 0, nothing moved, status[3] = 0), converged (value ≤ threshold), budget (k = max), else on.
// One workgroup of the file's size; its first invocation decides.
@compute @workgroup_size(WORKGROUP)
fn ip_decide(@builtin(local_invocation_index) lane: u32) {
    if (lane != 0u || stopped()) {
        return;
    }
    let k = decision[1];
    var words: array<u32, 4>;
    for (var j = 0u; j < 4u; j++) {
        words[j] = atomicLoad(&status[j]);
        decision[4u + 4u * k + j] = words[j];
    }
    let value = terms[0];
    decided[k] = value;
    decision[1] = k + 1u;
    var code = 0u;
    if (words[2] != IP_NONE || words[1] != IP_NONE) {
        code = 4u;
    } else if (k > 0u && words[0] == 0u && words[3] == 0u) {
        code = 3u;
    } else if (k > 0u && words[0] == 0u) {
        code = 4u;
    } else if (value <= ip.threshold) {
        code = 1u;
    } else if (k == ip.max_iterations) {
        code = 2u;
    }
    if (code != 0u) {
        decision[0] = 1u;
        decision[2] = code;
        return;
    }
    atomicStore(&status[0], 0u);
    atomicStore(&status[1], IP_NONE);
    atomicStore(&status[2], IP_NONE);
    atomicStore(&status[3], 0u);
}
