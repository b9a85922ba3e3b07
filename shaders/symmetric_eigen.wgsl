// Cyclic Jacobi eigen-decomposition of a small symmetric matrix and the
// projection of a symmetric block onto the PSD cone — the arithmetic of
// core/src/geometry/symmetric_eigen.rs and core/src/implicit/psd.rs, in
// the same order (f64: the CPU's bits on lavapipe).
//
//   one sweep: p = 0..n−1, q = p+1..n−1 (row-cyclic), skipped when a_pq = 0:
//     θ = (a_qq − a_pp) / (2 a_pq)
//     t = sgn(θ) / (|θ| + √(θ² + 1))   (sgn(0) = +1);  t = 0.5/θ once |θ| > 2^500
//     c = 1/√(t² + 1),  s = t c
//     a_pp −= t a_pq,  a_qq += t a_pq,  a_pq = a_qp = 0
//     r ≠ p, q:  a_rp = a_pr = c a_rp − s a_rq,  a_rq = a_qr = s a_rp + c a_rq
//     every r:   v_rp = c v_rp − s v_rq,         v_rq = s v_rp + c v_rq
//   stop before a sweep once off(A) ≤ ε ‖A₀‖_F (norms of A/m, m = max |a_ij|),
//   at most MAX_SWEEPS sweeps; eigenvalues ascending by a stable insertion sort
//   A⁺ = V max(Λ, 0) Vᵀ, reassembled for i ≤ j ascending, Σ_l over λ_l > 0
//   ascending as s += (λ_l V_il) V_jl; A returned unchanged without a λ_l < 0
//
// Matrices are row-major n × n in arrays of HESS = MAT² reals (n ≤ N·k ≤ MAT).

const HESS: u32 = MAT * MAT;
const MAX_SWEEPS: u32 = 64u;
// 2^−500: |θ| > 2^500 is tested as |θ| · 2^−500 > 1 (exact: a power of two;
// 2^500 itself is no f32 literal, and the coupled step is f64 only).
const INVERSE_LARGE_THETA = 3.054936363499605e-151;

// √(Σ_{p<q} (scale · a_pq)²).
fn eigen_off_diagonal(a: ptr<function, array<real, HESS>>, n: u32, scale: real) -> real {
    var s: real = 0.0;
    for (var p = 0u; p < n; p++) {
        for (var q = p + 1u; q < n; q++) {
            let x = scale * (*a)[p * n + q];
            s += x * x;
        }
    }
    return sqrt(s);
}

// One Jacobi rotation annihilating a_pq (p < q).
fn eigen_rotate(a: ptr<function, array<real, HESS>>, n: u32, v: ptr<function, array<real, HESS>>, p: u32, q: u32) {
    let apq = (*a)[p * n + q];
    if (apq == 0.0) {
        return;
    }
    let theta = ((*a)[q * n + q] - (*a)[p * n + p]) / (2.0 * apq);
    var t: real;
    if (abs(theta) * real(INVERSE_LARGE_THETA) > 1.0) {
        t = 0.5 / theta;
    } else {
        let sign = select(real(1.0), real(-1.0), theta < 0.0);
        t = sign / (abs(theta) + sqrt(theta * theta + 1.0));
    }
    let c = 1.0 / sqrt(t * t + 1.0);
    let s = t * c;
    (*a)[p * n + p] -= t * apq;
    (*a)[q * n + q] += t * apq;
    (*a)[p * n + q] = 0.0;
    (*a)[q * n + p] = 0.0;
    for (var r = 0u; r < n; r++) {
        if (r == p || r == q) {
            continue;
        }
        let arp = (*a)[r * n + p];
        let arq = (*a)[r * n + q];
        let new_rp = c * arp - s * arq;
        let new_rq = s * arp + c * arq;
        (*a)[r * n + p] = new_rp;
        (*a)[p * n + r] = new_rp;
        (*a)[r * n + q] = new_rq;
        (*a)[q * n + r] = new_rq;
    }
    for (var r = 0u; r < n; r++) {
        let vrp = (*v)[r * n + p];
        let vrq = (*v)[r * n + q];
        (*v)[r * n + p] = c * vrp - s * vrq;
        (*v)[r * n + q] = s * vrp + c * vrq;
    }
}

// Eigenvalues (ascending) into `values`, eigenvectors (columns of the
// row-major `vectors`) of the symmetric `a`, which is rotated in place.
fn symmetric_eigen(a: ptr<function, array<real, HESS>>, n: u32, values: ptr<function, array<real, MAT>>,
                   vectors: ptr<function, array<real, HESS>>) {
    for (var r = 0u; r < n; r++) {
        for (var c = 0u; c < n; c++) {
            (*vectors)[r * n + c] = select(real(0.0), real(1.0), r == c);
        }
    }
    var m: real = 0.0;
    for (var t = 0u; t < n * n; t++) {
        m = max(m, abs((*a)[t]));
    }
    let inverse = 1.0 / m;
    var scale: real = 1.0;
    if (finite(inverse) && finite(m)) {
        scale = inverse;
    }
    var norm2: real = 0.0;
    for (var t = 0u; t < n * n; t++) {
        let x = (*a)[t] * scale;
        norm2 += x * x;
    }
    let threshold = REAL_EPSILON * sqrt(norm2);
    var sweeps = 0u;
    var off = eigen_off_diagonal(a, n, scale);
    while (off > threshold && sweeps < MAX_SWEEPS) {
        for (var p = 0u; p < n; p++) {
            for (var q = p + 1u; q < n; q++) {
                eigen_rotate(a, n, vectors, p, q);
            }
        }
        sweeps++;
        off = eigen_off_diagonal(a, n, scale);
    }
    for (var i = 0u; i < n; i++) {
        (*values)[i] = (*a)[i * n + i];
    }
    // Stable insertion sort, eigenvector columns alike.
    for (var i = 1u; i < n; i++) {
        var j = i;
        while (j > 0u && (*values)[j] < (*values)[j - 1u]) {
            let swap = (*values)[j];
            (*values)[j] = (*values)[j - 1u];
            (*values)[j - 1u] = swap;
            for (var r = 0u; r < n; r++) {
                let w = (*vectors)[r * n + j];
                (*vectors)[r * n + j] = (*vectors)[r * n + j - 1u];
                (*vectors)[r * n + j - 1u] = w;
            }
            j--;
        }
    }
}

// Projects the symmetric n × n `block` onto the PSD cone in place; false
// (block unchanged) when an entry is not finite.
fn project_psd(block: ptr<function, array<real, HESS>>, n: u32) -> bool {
    for (var t = 0u; t < n * n; t++) {
        if (!finite((*block)[t])) {
            return false;
        }
    }
    var work: array<real, HESS>;
    for (var t = 0u; t < n * n; t++) {
        work[t] = (*block)[t];
    }
    var values: array<real, MAT>;
    var vectors: array<real, HESS>;
    symmetric_eigen(&work, n, &values, &vectors);
    var clipped = 0u;
    for (var l = 0u; l < n; l++) {
        if (values[l] < 0.0) {
            clipped++;
        }
    }
    if (clipped == 0u) {
        return true;
    }
    for (var i = 0u; i < n; i++) {
        for (var j = i; j < n; j++) {
            var s: real = 0.0;
            for (var l = 0u; l < n; l++) {
                if (values[l] > 0.0) {
                    s += (values[l] * vectors[i * n + l]) * vectors[j * n + l];
                }
            }
            (*block)[i * n + j] = s;
            (*block)[j * n + i] = s;
        }
    }
    return true;
}
