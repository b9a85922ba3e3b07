// Particle–particle contact, one gather-Jacobi iteration in two kernels —
// the arithmetic of cpu/src/collide.rs, in the same order:
//
//   collide_pairs   per pair e = (i, j), from the iterate x:
//                   d = x_j − x_i;  C = |d| − (r_i + r_j);  active iff C < 0, |d| > 0
//                   n = d / |d|;  s = −C;  c_e = n s − t_f  (t_f: clamped tangential
//                   relative motion since the substep start p, μ > 0 only)
//   collide_gather  per particle k, over its sorted contact list:
//                   x_k += Σ ±(w_k / (w_i + w_j)) c_e / (number of active contacts)
//
// `lists` holds the pairs (2 per pair), then the list offsets (n + 1),
// then the entries (2 e + side). `corr` holds DIM + 1 reals per pair: c_e
// and an active flag (1 or 0). No atomics: each invocation writes only its
// own pair or particle. Positions x and p are the particle records of
// prelude.wgsl (bindings 0..=3), read and written through its accessors.

struct CollideParams {
    pairs: u32,       // candidate pairs
    particles: u32,   // particles
    offsets: u32,     // start of the offsets in `lists`
    entries: u32,     // start of the entries in `lists`
    friction: real,   // Coulomb μ between particles
}

@group(0) @binding(4) var<storage, read> cparams: CollideParams;
// inverse mass and radius, 2 per particle
@group(0) @binding(5) var<storage, read> props: array<real>;
@group(0) @binding(6) var<storage, read> lists: array<u32>;
@group(0) @binding(7) var<storage, read_write> corr: array<real>;

const STRIDE: u32 = DIM + 1u;

@compute @workgroup_size(WORKGROUP)
fn collide_pairs(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let e = linear_index(gid, groups);
    if (e >= cparams.pairs) {
        return;
    }
    let i = lists[2u * e];
    let j = lists[2u * e + 1u];
    var xi = load_x(i);
    var xj = load_x(j);
    var pi = load_p(i);
    var pj = load_p(j);
    var d: array<real, DIM>;
    var len2: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        d[a] = lane(&xj, a) - lane(&xi, a);
        len2 += d[a] * d[a];
    }
    let len = sqrt(len2);
    let c = len - (props[2u * i + 1u] + props[2u * j + 1u]);
    let base = e * STRIDE;
    if (!(c < 0.0 && len > 0.0)) {
        corr[base + DIM] = 0.0;
        return;
    }
    corr[base + DIM] = 1.0;
    let s = -c;
    let inv = 1.0 / len;
    for (var a = 0u; a < DIM; a++) {
        d[a] *= inv;
    }
    var out: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        out[a] = d[a] * s;
    }
    let mu = cparams.friction;
    if (mu > 0.0) {
        var dn: real = 0.0;
        for (var a = 0u; a < DIM; a++) {
            let dr = (lane(&xj, a) - lane(&pj, a)) - (lane(&xi, a) - lane(&pi, a));
            dn += dr * d[a];
        }
        var t2: real = 0.0;
        for (var a = 0u; a < DIM; a++) {
            let dr = (lane(&xj, a) - lane(&pj, a)) - (lane(&xi, a) - lane(&pi, a));
            let t = dr - dn * d[a];
            t2 += t * t;
        }
        let t_norm = sqrt(t2);
        let bound = mu * s;
        var scale: real = 1.0;
        if (!(t_norm <= bound)) {
            scale = bound / t_norm;
        }
        for (var a = 0u; a < DIM; a++) {
            let dr = (lane(&xj, a) - lane(&pj, a)) - (lane(&xi, a) - lane(&pi, a));
            let t = dr - dn * d[a];
            out[a] -= t * scale;
        }
    }
    for (var a = 0u; a < DIM; a++) {
        corr[base + a] = out[a];
    }
}

@compute @workgroup_size(WORKGROUP)
fn collide_gather(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = linear_index(gid, groups);
    if (k >= cparams.particles) {
        return;
    }
    let wk = props[2u * k];
    if (wk == 0.0) {
        return;
    }
    var sum: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        sum[a] = 0.0;
    }
    var touching = 0u;
    let first = lists[cparams.offsets + k];
    let last = lists[cparams.offsets + k + 1u];
    for (var at = first; at < last; at++) {
        let entry = lists[cparams.entries + at];
        let e = entry / 2u;
        if (corr[e * STRIDE + DIM] == 0.0) {
            continue;
        }
        let i = lists[2u * e];
        let j = lists[2u * e + 1u];
        let share = wk / (props[2u * i] + props[2u * j]);
        var sign = share;
        if (entry % 2u == 0u) {
            sign = -share;
        }
        for (var a = 0u; a < DIM; a++) {
            sum[a] += sign * corr[e * STRIDE + a];
        }
        touching++;
    }
    if (touching == 0u) {
        return;
    }
    let count = real(touching);
    var xk = load_x(k);
    for (var a = 0u; a < DIM; a++) {
        set_lane(&xk, a, lane(&xk, a) + sum[a] / count);
    }
    store_x(k, xk);
}
