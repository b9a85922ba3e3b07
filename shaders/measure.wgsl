// Determinants, adjugates and the two simplex measures with gradients —
// the same algorithms, in the same order, as core/src/geometry.
//
//   det(A)        Gaussian elimination, partial pivoting (first largest
//                 |pivot| wins), product of pivots, sign per row swap
//   adj(A)[j][i]  = (−1)^(i+j) det(A without row i and column j)
//   S = det(EᵀE)/(k!)²,  ∂S/∂E = 2 E adj(EᵀE)/(k!)²
//   V = det(D)/N!,       ∇_j V = row j−1 of adj(D) / N!
//   ∇_0 = −Σ_j ∇_j

fn factorial(k: u32) -> real {
    var f: real = 1.0;
    for (var i = 1u; i <= k; i++) {
        f = f * real(i);
    }
    return f;
}

// Determinant of the n×n row-major matrix in `a` (overwritten).
fn determinant(a: ptr<function, array<real, MAT>>, n: u32) -> real {
    var det: real = 1.0;
    for (var col = 0u; col < n; col++) {
        var pivot_row = col;
        var pivot_abs = abs((*a)[col * n + col]);
        for (var row = col + 1u; row < n; row++) {
            let value = abs((*a)[row * n + col]);
            if (value > pivot_abs) {
                pivot_abs = value;
                pivot_row = row;
            }
        }
        if (pivot_abs == 0.0) {
            return 0.0;
        }
        if (pivot_row != col) {
            for (var c = 0u; c < n; c++) {
                let tmp = (*a)[col * n + c];
                (*a)[col * n + c] = (*a)[pivot_row * n + c];
                (*a)[pivot_row * n + c] = tmp;
            }
            det = -det;
        }
        let pivot = (*a)[col * n + col];
        det = det * pivot;
        for (var row = col + 1u; row < n; row++) {
            let factor = (*a)[row * n + col] / pivot;
            if (factor != 0.0) {
                for (var c = col + 1u; c < n; c++) {
                    (*a)[row * n + c] -= factor * (*a)[col * n + c];
                }
            }
        }
    }
    return det;
}

// Adjugate of the n×n row-major matrix `a` into `out`.
fn adjugate(a: ptr<function, array<real, MAT>>, n: u32, out: ptr<function, array<real, MAT>>) {
    if (n == 1u) {
        (*out)[0] = 1.0;
        return;
    }
    let m = n - 1u;
    var minor: array<real, MAT>;
    for (var i = 0u; i < n; i++) {
        for (var j = 0u; j < n; j++) {
            var idx = 0u;
            for (var r = 0u; r < n; r++) {
                if (r == i) {
                    continue;
                }
                for (var c = 0u; c < n; c++) {
                    if (c == j) {
                        continue;
                    }
                    minor[idx] = (*a)[r * n + c];
                    idx++;
                }
            }
            var sign: real = 1.0;
            if ((i + j) % 2u == 1u) {
                sign = -1.0;
            }
            (*out)[j * n + i] = sign * determinant(&minor, m);
        }
    }
}

// Squared k-measure of the k-simplex in `pts` (k + 1 points), gradient
// into `grad` (same layout).
fn simplex_squared_measure(pts: ptr<function, array<real, POINTS>>, k: u32, grad: ptr<function, array<real, POINTS>>) -> real {
    let scale = 1.0 / (factorial(k) * factorial(k));
    var edges: array<real, MAT>;   // edges[a * k + j], a < DIM, j < k
    var gram: array<real, MAT>;
    var adj: array<real, MAT>;
    for (var j = 0u; j < k; j++) {
        for (var a = 0u; a < DIM; a++) {
            edges[a * k + j] = (*pts)[(j + 1u) * DIM + a] - (*pts)[a];
        }
    }
    for (var i = 0u; i < k; i++) {
        for (var j = 0u; j < k; j++) {
            var s: real = 0.0;
            for (var a = 0u; a < DIM; a++) {
                s += edges[a * k + i] * edges[a * k + j];
            }
            gram[i * k + j] = s;
        }
    }
    adjugate(&gram, k, &adj);
    let measure = determinant(&gram, k) * scale;
    for (var a = 0u; a < DIM; a++) {
        (*grad)[a] = 0.0;
    }
    for (var j = 0u; j < k; j++) {
        for (var a = 0u; a < DIM; a++) {
            var s: real = 0.0;
            for (var i = 0u; i < k; i++) {
                s += edges[a * k + i] * adj[i * k + j];
            }
            let gj = 2.0 * s * scale;
            (*grad)[(j + 1u) * DIM + a] = gj;
            (*grad)[a] -= gj;
        }
    }
    return measure;
}

// Signed measure det([x1−x0 … xN−x0])/N! of the DIM + 1 points in `pts`.
fn oriented_measure(pts: ptr<function, array<real, POINTS>>, grad: ptr<function, array<real, POINTS>>) -> real {
    let n = DIM;
    let scale = 1.0 / factorial(n);
    var edges: array<real, MAT>;
    var adj: array<real, MAT>;
    for (var j = 0u; j < n; j++) {
        for (var a = 0u; a < n; a++) {
            edges[a * n + j] = (*pts)[(j + 1u) * n + a] - (*pts)[a];
        }
    }
    adjugate(&edges, n, &adj);
    let measure = determinant(&edges, n) * scale;
    for (var a = 0u; a < n; a++) {
        (*grad)[a] = 0.0;
    }
    for (var j = 0u; j < n; j++) {
        for (var a = 0u; a < n; a++) {
            let gj = adj[j * n + a] * scale;
            (*grad)[(j + 1u) * n + a] = gj;
            (*grad)[a] -= gj;
        }
    }
    return measure;
}

// |x1 − x0| with unit gradients (zero when the points coincide).
fn distance(pts: ptr<function, array<real, POINTS>>, grad: ptr<function, array<real, POINTS>>) -> real {
    var d2: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        let e = (*pts)[DIM + a] - (*pts)[a];
        d2 += e * e;
    }
    let d = sqrt(d2);
    if (d > 0.0) {
        let inv = 1.0 / d;
        for (var a = 0u; a < DIM; a++) {
            let n = ((*pts)[DIM + a] - (*pts)[a]) * inv;
            (*grad)[a] = -n;
            (*grad)[DIM + a] = n;
        }
    } else {
        for (var a = 0u; a < 2u * DIM; a++) {
            (*grad)[a] = 0.0;
        }
    }
    return d;
}
