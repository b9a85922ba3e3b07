// The closest point of a simplex to a point (core/src/geometry/
// closest_point.rs, closest_point_on_simplex), shared by the barrier
// kernels and the XPBD step's mesh contact. The including module defines
// `vertex(s, j, a)` (coordinate a of vertex j of simplex s, SLOTS = 4
// vertex slots per simplex) and `simplex_arity(s)` (its vertices, ≤ 4).
//
//   q = the affine projection of p on the face with all barycentrics ≥ 0
//       and the smallest |p − q|², over every face (bitmask order, the
//       first on a tie); Gram system G μ = rhs solved without pivots
//   simplex_distance = |p − q| − r,  n = (p − q)/|p − q| (p − q when 0)

// |p − q| − r for q the closest point of simplex s to p, the unit
// direction (p − q)/|p − q| into n (BarrierObstacles::distance).
fn simplex_distance(s: u32, p: ptr<function, array<real, DIM>>, r: real, n: ptr<function, array<real, DIM>>) -> real {
    let best_squared = simplex_offset(s, p, n);
    let distance = sqrt(best_squared);
    if (distance > 0.0) {
        for (var a = 0u; a < DIM; a++) {
            (*n)[a] /= distance;
        }
    }
    return distance - r;
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

// |p − q|² for q the closest point of simplex s to p (every face's affine
// projection with all barycentrics ≥ 0, smallest |p − q|², first on a
// tie), the offset p − q into `w` (geometry::closest_point_on_simplex).
fn simplex_offset(s: u32, p: ptr<function, array<real, DIM>>, w: ptr<function, array<real, DIM>>) -> real {
    let count = simplex_arity(s);
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

