// Per-particle barrier evaluation and the certified step filter (the
// incremental-potential path), one invocation per particle looping over
// the obstacles: every plane, then the simplices whose boxes overlap the
// particle's candidate box (the hierarchy walk, simplex_walk.wgsl), in the order of
// BarrierObstacles (core/src/barrier.rs). Same arithmetic, in the same
// order, as the f64 golden path; ln_real is an arithmetic-only ln in both
// precisions (ln_f32.wgsl, ln_f64.wgsl), because lavapipe's f64 log is
// garbage and its f32 log a polynomial no CPU repeats.
//
//   plane:    d = n·x − c − r,                n = unit normal
//   simplex:  d = |x − q| − r,  n = (x − q)/|x − q|,  q = closest point
//             (every face's affine projection with all barycentrics ≥ 0,
//             smallest |x − q|², first on a tie; Gram solve without pivots)
//   b = −κ (d − d^)² ln(d/d^),  b', b'' as in core/src/barrier.rs
//   evaluate: energy Σ b, gradient Σ b' n, hessian Σ b'' n nᵀ, min(min d, d^)
//   filter_fraction: t = min(1, η min_o t*_o) (simplices within reach |Δ|(1 + γ)/η),  t*_plane = d0/(−n·Δ) if n·Δ < 0,
//             t*_simplex = d0/|Δ|;  0 if some d0 ≤ 0
//   every entry point ends with check_loops (llvmpipe's loop budget):
//             status[LOOPS_CUT] = smallest particle whose loops were cut
// The host prepends `alias real`, DIM and REAL_MAX (shader.rs).

struct BarrierParams {
    count: u32,     // particles
    planes: u32,    // plane obstacles
    simplices: u32, // simplex obstacles
    pad: u32,
    stiffness: real,  // κ
    activation: real, // d^
    safety: real,     // η
    scale: real,      // largest |obstacle coordinate| (rounding floor of d)
}

@group(0) @binding(0) var<storage, read_write> x: array<real>;
@group(0) @binding(1) var<storage, read> radius: array<real>;
// [plane normals, planes·DIM | plane offsets, planes | simplex vertices, simplices·4·DIM |
//  hierarchy node boxes (lo[DIM], hi[DIM]), (2 simplices − 1)·2·DIM]
@group(0) @binding(2) var<storage, read> geometry: array<real>;
// [arity, simplices | hierarchy node words (right, first, last), (2 simplices − 1)·3]
@group(0) @binding(3) var<storage, read> arity: array<u32>;
@group(0) @binding(4) var<storage, read> delta: array<real>;
@group(0) @binding(5) var<storage, read_write> energy: array<real>;
@group(0) @binding(6) var<storage, read_write> gradient: array<real>;
@group(0) @binding(7) var<storage, read_write> hessian: array<real>;
@group(0) @binding(8) var<storage, read_write> scalar: array<real>;
@group(0) @binding(9) var<storage, read> bp: BarrierParams;
// status[0..4]: incremental_potential.wgsl's words; status[LOOPS_CUT]: the
// smallest particle whose loops were cut short (NONE: none).
@group(0) @binding(10) var<storage, read_write> status: array<atomic<u32>, 5>;

const SLOTS: u32 = 4u;
const LOOPS_CUT: u32 = 4u;

// llvmpipe (lavapipe) keeps one loop budget per group of 8 neighbouring
// invocations (its SIMD width): 65 535 iterations of every data-dependent
// loop of the kernel together (a loop of n trips costs n + 1; loops with a
// constant trip count are unrolled and cost nothing), shared by the 8
// lanes, which run a loop as long as any of them is still in it. Once it
// is spent every loop runs its body once and stops, silently. A two-trip
// probe at the end of every entry point, with a trip count the compiler
// cannot see (bp.count < 2^31), then counts 1 instead of 2 (measured:
// gpu/src/barrier.rs); the host refuses the results.
fn check_loops(i: u32) {
    let trips = 2u + (bp.count >> 31u);
    var probe = 0u;
    for (var t = 0u; t < trips; t++) {
        probe++;
    }
    if (probe != 2u) {
        atomicMin(&status[LOOPS_CUT], i);
    }
}

fn linear_index(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.x + gid.y * groups.x * WORKGROUP;
}

// Vertex j, coordinate a of simplex s.
fn vertex(s: u32, j: u32, a: u32) -> real {
    let base = bp.planes * DIM + bp.planes;
    return geometry[base + (s * SLOTS + j) * DIM + a];
}

// Vertices of simplex s (closest_point.wgsl).
fn simplex_arity(s: u32) -> u32 {
    return arity[s];
}

// Distance to obstacle o from p (radius r); the unit direction into n.
fn obstacle_distance(o: u32, p: ptr<function, array<real, DIM>>, r: real, n: ptr<function, array<real, DIM>>) -> real {
    if (o < bp.planes) {
        var dot: real = 0.0;
        for (var a = 0u; a < DIM; a++) {
            (*n)[a] = geometry[o * DIM + a];
            dot += (*n)[a] * (*p)[a];
        }
        return dot - geometry[bp.planes * DIM + o] - r;
    }
    return simplex_distance(o - bp.planes, p, r, n);
}

// The walk's accessors (simplex_walk.wgsl): the planes come first.
fn walk_planes() -> u32 {
    return bp.planes;
}

fn walk_simplices() -> u32 {
    return bp.simplices;
}

fn walk_scale() -> real {
    return bp.scale;
}

fn node_word(n: u32, k: u32) -> u32 {
    return arity[bp.simplices + n * 3u + k];
}

// Bound k < 2·DIM (lo then hi) of node n.
fn node_bound(n: u32, k: u32) -> real {
    return geometry[bp.planes * DIM + bp.planes + bp.simplices * SLOTS * DIM + n * 2u * DIM + k];
}

// The filters' reach |Δ| (1 + γ)/η, γ = (N + 4) ε.
fn filter_reach(length: real, epsilon: real) -> real {
    return length * (1.0 + (real(DIM) + 4.0) * epsilon) / bp.safety;
}

// The relative pad where the certified filter's support bound decides.
fn support_margin(epsilon: real) -> real {
    return 4.0 * sqrt(real(DIM) * (real(DIM) + 4.0) * epsilon);
}

// (b, b', b'') of the clamped-log law at d (0 < d < d^).
fn barrier_law(d: real) -> vec3<real> {
    let dh = bp.activation;
    let k = bp.stiffness;
    let ln = ln_real(d / dh);
    let e = d - dh;
    let b = -k * e * e * ln;
    let b1 = -k * (2.0 * e * ln + e * e / d);
    let b2 = -k * (2.0 * ln + 4.0 * e / d - e * e / (d * d));
    return vec3<real>(b, b1, b2);
}

@compute @workgroup_size(WORKGROUP)
fn evaluate(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= bp.count) {
        return;
    }
    evaluate_particle(i);
    check_loops(i);
}

fn evaluate_particle(i: u32) {
    var p: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        p[a] = x[i * DIM + a];
    }
    var g: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        g[a] = 0.0;
    }
    for (var a = 0u; a < DIM * DIM; a++) {
        hessian[i * DIM * DIM + a] = 0.0;
    }
    var e_sum: real = 0.0;
    var smallest: real = REAL_MAX;
    var infeasible = false;
    var n: array<real, DIM>;
    var walk = walk_start(&p, radius[i], bp.activation);
    for (var o = walk_next(&walk); o != WALK_END; o = walk_next(&walk)) {
        let d = obstacle_distance(o, &p, radius[i], &n);
        smallest = min(smallest, d);
        if (d >= bp.activation) {
            continue;
        }
        if (!(d > 0.0)) {
            infeasible = true;
            continue;
        }
        let law = barrier_law(d);
        e_sum += law.x;
        for (var a = 0u; a < DIM; a++) {
            g[a] += law.y * n[a];
            for (var c = 0u; c < DIM; c++) {
                hessian[(i * DIM + a) * DIM + c] += law.z * n[a] * n[c];
            }
        }
    }
    if (infeasible) {
        e_sum = REAL_MAX; // stands for +∞ (WGSL has no infinity literal)
    }
    energy[i] = e_sum;
    for (var a = 0u; a < DIM; a++) {
        gradient[i * DIM + a] = g[a];
    }
    scalar[i] = min(smallest, bp.activation);
}

@compute @workgroup_size(WORKGROUP)
fn filter_fraction(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= bp.count) {
        return;
    }
    scalar[i] = particle_filter_fraction(i);
    check_loops(i);
}

fn particle_filter_fraction(i: u32) -> real {
    var p: array<real, DIM>;
    var step: array<real, DIM>;
    var length2: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        p[a] = x[i * DIM + a];
        step[a] = delta[i * DIM + a];
        length2 += step[a] * step[a];
    }
    let length = sqrt(length2);
    var t: real = REAL_MAX;
    var n: array<real, DIM>;
    var walk = walk_start(&p, radius[i], filter_reach(length, REAL_EPS));
    for (var o = walk_next(&walk); o != WALK_END; o = walk_next(&walk)) {
        let d0 = obstacle_distance(o, &p, radius[i], &n);
        if (!(d0 > 0.0)) {
            return 0.0;
        }
        var approach = length;
        if (o < bp.planes) {
            var dot: real = 0.0;
            for (var a = 0u; a < DIM; a++) {
                dot += n[a] * step[a];
            }
            approach = -dot;
        }
        if (approach > 0.0) {
            t = min(t, d0 / approach);
        }
    }
    return min(bp.safety * t, 1.0);
}

// ln of every delta[i] into scalar[i] (the ln helper's own test).
@compute @workgroup_size(WORKGROUP)
fn ln_check(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= bp.count) {
        return;
    }
    scalar[i] = ln_real(delta[i]);
    check_loops(i);
}
