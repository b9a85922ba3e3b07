// Per-particle barrier evaluation and the certified step filter (the
// incremental-potential path), one invocation per particle looping over
// the obstacles: every plane, then the simplices whose boxes overlap the
// particle's candidate box (the hierarchy walk below), in the order of
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

// Row s1 < m of face's Gram system G μ = rhs (anchor members[0], the
// other members at 1..=m): G[s1][t1] = (v_js − v_a)·(v_jt − v_a),
// rhs[s1] = (v_js − v_a)·(p − v_a). Called with constant s1 (llvmpipe's
// loop budget: check_loops), nothing when s1 ≥ m.
fn gram_row(s: u32, s1: u32, m: u32, members: ptr<function, array<u32, 4>>,
            g: ptr<function, array<array<real, 3>, 3>>, rhs: ptr<function, array<real, 3>>,
            p: ptr<function, array<real, DIM>>) {
    if (s1 >= m) {
        return;
    }
    let anchor = (*members)[0];
    let js = (*members)[s1 + 1u];
    for (var t1 = 0u; t1 < 3u; t1++) {
        if (t1 < m) {
            let jt = (*members)[t1 + 1u];
            var acc: real = 0.0;
            for (var a = 0u; a < DIM; a++) {
                acc += (vertex(s, js, a) - vertex(s, anchor, a)) * (vertex(s, jt, a) - vertex(s, anchor, a));
            }
            (*g)[s1][t1] = acc;
        }
    }
    var acc: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        acc += (vertex(s, js, a) - vertex(s, anchor, a)) * ((*p)[a] - vertex(s, anchor, a));
    }
    (*rhs)[s1] = acc;
}

// Elimination step c < m of G μ = rhs without pivoting (G is SPD); a bad
// pivot clears ok, and once ok is false later steps do nothing.
fn eliminate(c: u32, m: u32, ok: ptr<function, bool>, g: ptr<function, array<array<real, 3>, 3>>,
             rhs: ptr<function, array<real, 3>>) {
    if (c >= m || !(*ok)) {
        return;
    }
    if (!((*g)[c][c] > 0.0) || (*g)[c][c] > REAL_MAX) {
        *ok = false;
        return;
    }
    for (var r2 = 1u; r2 < 3u; r2++) {
        if (r2 > c && r2 < m) {
            let factor = (*g)[r2][c] / (*g)[c][c];
            for (var s2 = 0u; s2 < 3u; s2++) {
                if (s2 >= c && s2 < m) {
                    (*g)[r2][s2] -= factor * (*g)[c][s2];
                }
            }
            (*rhs)[r2] -= factor * (*rhs)[c];
        }
    }
}

// Back substitution step k < m: μ[c] for c = m − 1 − k.
fn back_substitute(k: u32, m: u32, g: ptr<function, array<array<real, 3>, 3>>,
                   rhs: ptr<function, array<real, 3>>, mu: ptr<function, array<real, 3>>) {
    if (k >= m) {
        return;
    }
    let c = m - 1u - k;
    var value = (*rhs)[c];
    for (var s2 = 1u; s2 < 3u; s2++) {
        if (s2 > c && s2 < m) {
            value -= (*g)[c][s2] * (*mu)[s2];
        }
    }
    (*mu)[c] = value / (*g)[c][c];
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
    let best_squared = simplex_offset(o - bp.planes, p, n);
    let distance = sqrt(best_squared);
    if (distance > 0.0) {
        for (var a = 0u; a < DIM; a++) {
            (*n)[a] /= distance;
        }
    }
    return distance - r;
}

// |p − q|² for q the closest point of simplex s to p (every face's affine
// projection with all barycentrics ≥ 0, smallest |p − q|², first on a
// tie), the offset p − q into `w` (geometry::closest_point_on_simplex).
fn simplex_offset(s: u32, p: ptr<function, array<real, DIM>>, w: ptr<function, array<real, DIM>>) -> real {
    let count = arity[s];
    var best_squared: real = REAL_MAX;
    var found = false;
    var rr: array<real, DIM>;
    // Every loop below but the one over faces has a constant trip count
    // (guards inside): llvmpipe unrolls those, so they cost nothing of its
    // loop budget (check_loops); the face loop costs 2^count per simplex.
    for (var face = 1u; face < (1u << count); face++) {
        // Members of the face.
        var members: array<u32, 4>;
        var size = 0u;
        for (var j = 0u; j < 4u; j++) {
            if ((face & (1u << j)) != 0u) {
                members[size] = j;
                size++;
            }
        }
        let anchor = members[0];
        let m = size - 1u;
        var lambda: array<real, 4>;
        for (var j = 0u; j < 4u; j++) {
            lambda[j] = 0.0;
        }
        var ok = true;
        if (m == 0u) {
            lambda[anchor] = 1.0;
        } else {
            var g: array<array<real, 3>, 3>;
            var rhs: array<real, 3>;
            gram_row(s, 0u, m, &members, &g, &rhs, p);
            gram_row(s, 1u, m, &members, &g, &rhs, p);
            gram_row(s, 2u, m, &members, &g, &rhs, p);
            // Gaussian elimination without pivoting (SPD); the first bad
            // pivot stops it (ok = false).
            eliminate(0u, m, &ok, &g, &rhs);
            eliminate(1u, m, &ok, &g, &rhs);
            eliminate(2u, m, &ok, &g, &rhs);
            if (ok) {
                var mu: array<real, 3>;
                back_substitute(0u, m, &g, &rhs, &mu);
                back_substitute(1u, m, &g, &rhs, &mu);
                back_substitute(2u, m, &g, &rhs, &mu);
                var sum: real = 0.0;
                for (var k = 0u; k < 3u; k++) {
                    if (k < m) {
                        lambda[members[k + 1u]] = mu[k];
                        sum += mu[k];
                    }
                }
                lambda[anchor] = 1.0 - sum;
            }
        }
        if (!ok) {
            continue;
        }
        var inside = true;
        for (var j = 0u; j < 4u; j++) {
            if (lambda[j] < 0.0) {
                inside = false;
            }
        }
        if (!inside) {
            continue;
        }
        for (var a = 0u; a < DIM; a++) {
            rr[a] = (*p)[a];
        }
        for (var j = 0u; j < 4u; j++) {
            if (j < count && (face & (1u << j)) != 0u) {
                for (var a = 0u; a < DIM; a++) {
                    rr[a] -= lambda[j] * vertex(s, j, a);
                }
            }
        }
        var squared: real = 0.0;
        for (var a = 0u; a < DIM; a++) {
            squared += rr[a] * rr[a];
        }
        if (!found || squared < best_squared) {
            found = true;
            best_squared = squared;
            for (var a = 0u; a < DIM; a++) {
                (*w)[a] = rr[a];
            }
        }
    }
    return best_squared;
}

// The simplex hierarchy walk (core/src/geometry/simplex_hierarchy.rs,
// OrderedWalk; the candidate box: core/src/barrier.rs candidate_box):
// every plane, then every simplex whose box overlaps x ± (r + reach + pad),
// pad = M (‖x‖∞ + scale + r + reach) with M = 16 N (N + 4) ε where computed
// distances decide (walk_start), 4 √(N (N + 4) ε) for the certified
// filter's support bound (walk_box with support_margin), in index order: batches
// of the HIERARCHY_BATCH smallest indices ≥ floor from a stack traversal
// (preorder nodes: left child n + 1, words (right, first, last)), each
// handed out in order. The traversal costs one trip of llvmpipe's loop
// budget per node visited; the insertion's loop has a constant trip count.
const HIERARCHY_BATCH: u32 = 32u;
const HIERARCHY_STACK: u32 = 32u;
const WALK_END: u32 = 0xffffffffu;

struct Walk {
    lo: array<real, DIM>,
    hi: array<real, DIM>,
    batch: array<u32, HIERARCHY_BATCH>,
    count: u32,
    next: u32,
    floor: u32,
    more: bool,
    plane: u32,
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

// The walk where computed distances decide (evaluation, step filter).
fn walk_start(p: ptr<function, array<real, DIM>>, r: real, reach: real) -> Walk {
    return walk_box(p, r, reach, 16.0 * real(DIM) * (real(DIM) + 4.0) * REAL_EPS);
}

fn walk_box(p: ptr<function, array<real, DIM>>, r: real, reach: real, margin: real) -> Walk {
    var w: Walk;
    var largest: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        largest = max(largest, abs((*p)[a]));
    }
    let extent = r + reach;
    let half = extent + margin * (largest + bp.scale + extent);
    var finite = half <= REAL_MAX;
    for (var a = 0u; a < DIM; a++) {
        w.lo[a] = (*p)[a] - half;
        w.hi[a] = (*p)[a] + half;
        finite = finite && abs(w.lo[a]) <= REAL_MAX && abs(w.hi[a]) <= REAL_MAX;
    }
    if (!finite) {
        for (var a = 0u; a < DIM; a++) {
            w.lo[a] = -REAL_MAX;
            w.hi[a] = REAL_MAX;
        }
    }
    w.count = 0u;
    w.next = 0u;
    w.floor = 0u;
    w.more = bp.simplices > 0u;
    w.plane = 0u;
    return w;
}

// Sorted insertion of s into the batch (absent from it, and below its
// largest when full), shifting larger entries up.
fn walk_insert(w: ptr<function, Walk>, s: u32) {
    let top = min((*w).count, HIERARCHY_BATCH - 1u);
    var at = top;
    for (var j = 1u; j < HIERARCHY_BATCH; j++) {
        let k = HIERARCHY_BATCH - j;
        if (k == at && (*w).batch[k - 1u] > s) {
            (*w).batch[k] = (*w).batch[k - 1u];
            at = k - 1u;
        }
    }
    (*w).batch[at] = s;
    (*w).count = min((*w).count + 1u, HIERARCHY_BATCH);
}

// The HIERARCHY_BATCH smallest overlapping simplices ≥ floor, sorted.
fn walk_refill(w: ptr<function, Walk>) {
    (*w).count = 0u;
    (*w).next = 0u;
    var stack: array<u32, HIERARCHY_STACK>;
    stack[0] = 0u;
    var depth = 1u;
    while (depth > 0u) {
        depth--;
        let n = stack[depth];
        let first = node_word(n, 1u);
        let last = node_word(n, 2u);
        if (last < (*w).floor || ((*w).count == HIERARCHY_BATCH && first > (*w).batch[HIERARCHY_BATCH - 1u])) {
            continue;
        }
        var hit = true;
        for (var a = 0u; a < DIM; a++) {
            if (!(node_bound(n, a) <= (*w).hi[a] && (*w).lo[a] <= node_bound(n, DIM + a))) {
                hit = false;
            }
        }
        if (!hit) {
            continue;
        }
        if (first == last) {
            walk_insert(w, first);
        } else if (depth + 2u <= HIERARCHY_STACK) { // always: depth + 1 ≤ 32 (< 2^31 simplices)
            stack[depth] = node_word(n, 0u);
            stack[depth + 1u] = n + 1u;
            depth += 2u;
        }
    }
    (*w).more = (*w).count == HIERARCHY_BATCH;
    if ((*w).more) {
        (*w).floor = (*w).batch[HIERARCHY_BATCH - 1u] + 1u;
    }
}

// The next obstacle slot of the walk (planes first), WALK_END after the last.
fn walk_next(w: ptr<function, Walk>) -> u32 {
    if ((*w).plane < bp.planes) {
        (*w).plane++;
        return (*w).plane - 1u;
    }
    if ((*w).next == (*w).count) {
        if (!(*w).more) {
            return WALK_END;
        }
        walk_refill(w);
        if ((*w).count == 0u) {
            return WALK_END;
        }
    }
    (*w).next++;
    return bp.planes + (*w).batch[(*w).next - 1u];
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
