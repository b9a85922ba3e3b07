//! Eigen-decomposition of a small symmetric matrix by cyclic Jacobi, in a
//! fixed sweep order (deterministic: the same input gives the same bits).
//!
//! ```text
//! A = V Λ Vᵀ,   V orthogonal (columns are eigenvectors), Λ = diag(λ_0 ≤ … ≤ λ_{n−1})
//!
//! one sweep: for p = 0..n−1, for q = p+1..n−1 (row-cyclic order), if a_pq ≠ 0:
//!   θ = (a_qq − a_pp) / (2 a_pq)
//!   t = sgn(θ) / (|θ| + √(θ² + 1))        (sgn(0) = +1; the smaller angle, |t| ≤ 1;
//!                                          t = 1/(2θ) once |θ| > 2^500, where θ²
//!                                          would overflow and √(θ²+1) = |θ| anyway)
//!   c = 1/√(t² + 1),  s = t c
//!   A ← Jᵀ A J,  V ← V J     with J = identity except J_pp = J_qq = c, J_pq = s, J_qp = −s:
//!     a_pp ← a_pp − t a_pq,  a_qq ← a_qq + t a_pq,  a_pq = a_qp ← 0
//!     r ≠ p, q:  a_rp = a_pr ← c a_rp − s a_rq,   a_rq = a_qr ← s a_rp + c a_rq
//!     every r:   v_rp ← c v_rp − s v_rq,          v_rq ← s v_rp + c v_rq
//!
//! stop before a sweep once off(A) = √(Σ_{p<q} a_pq²) ≤ ε ‖A₀‖_F (or off(A) = 0;
//! both norms taken of A/m, m = max |a_ij| of A₀, so no square overflows),
//! at most MAX_SWEEPS sweeps (Jacobi converges quadratically: a handful suffice)
//! order: eigenvalues ascending by a stable insertion sort, eigenvector columns alike
//! ```
//! The updates write both a_rp and a_pr, so the iterate stays exactly
//! symmetric. Reused wherever a symmetric spectrum is needed: principal
//! stretches of materials, PSD projection of Hessian blocks. Generic over
//! the precision: f64 is the golden path, f32 the f32 reference's (both
//! `shaders/symmetric_eigen.wgsl`'s order; in f32 2^500 is +∞, so the
//! large-θ branch never runs, as in the shader).

use crate::kinds::ProjectionReal;

/// Sweeps after which the iteration stops even if the off-diagonal part
/// has not reached its threshold.
pub const MAX_SWEEPS: u32 = 64;

/// Above this |θ| the rotation uses t = 1/(2θ) (θ² would overflow).
const LARGE_THETA: f64 = 3.273390607896142e150; // 2^500

/// Evidence of one decomposition.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SymmetricEigen {
    /// Sweeps run.
    pub sweeps: u32,
    /// off(A) at the end: √ of the sum of squares of the strictly upper part.
    pub off_diagonal: f64,
    /// off(A) ≤ ε ‖A₀‖_F was reached within [`MAX_SWEEPS`].
    pub converged: bool,
}

/// Eigenvalues (ascending) into `values` and eigenvectors (as the columns
/// of the row-major n×n `vectors`) of the symmetric row-major n×n `a`,
/// which is used as scratch and holds the rotated matrix on return.
/// Only the symmetric part of `a` is meaningful: pass a symmetric matrix.
pub fn symmetric_eigen<R: ProjectionReal>(
    a: &mut [R],
    n: usize,
    values: &mut [R],
    vectors: &mut [R],
) -> SymmetricEigen {
    let (zero, one) = (R::constant(0.0), R::constant(1.0));
    for r in 0..n {
        for c in 0..n {
            vectors[r * n + c] = if r == c { one } else { zero };
        }
    }
    // Norms are taken of A / m, m = max |a_ij| of the input, so that
    // neither squares overflow nor underflow (a NaN entry is passed over).
    let mut m = zero;
    for &v in &a[..n * n] {
        if v.abs() > m {
            m = v.abs();
        }
    }
    let scale = if (one / m).finite() && m.finite() {
        one / m
    } else {
        one
    };
    let mut norm2 = zero;
    for &v in &a[..n * n] {
        norm2 += (v * scale) * (v * scale);
    }
    let threshold = R::epsilon() * norm2.sqrt();
    let mut sweeps = 0;
    let mut off = off_diagonal(a, n, scale);
    while off > threshold && sweeps < MAX_SWEEPS {
        for p in 0..n {
            for q in p + 1..n {
                rotate(a, n, vectors, p, q);
            }
        }
        sweeps += 1;
        off = off_diagonal(a, n, scale);
    }
    for i in 0..n {
        values[i] = a[i * n + i];
    }
    sort_ascending(values, vectors, n);
    SymmetricEigen {
        sweeps,
        off_diagonal: (off / scale).to_f64(),
        converged: off <= threshold,
    }
}

/// √(Σ_{p<q} (scale · a_pq)²).
fn off_diagonal<R: ProjectionReal>(a: &[R], n: usize, scale: R) -> R {
    let mut s = R::constant(0.0);
    for p in 0..n {
        for q in p + 1..n {
            let x = scale * a[p * n + q];
            s += x * x;
        }
    }
    s.sqrt()
}

/// One Jacobi rotation annihilating a_pq (p < q).
fn rotate<R: ProjectionReal>(a: &mut [R], n: usize, v: &mut [R], p: usize, q: usize) {
    let (zero, one) = (R::constant(0.0), R::constant(1.0));
    let apq = a[p * n + q];
    if apq == zero {
        return;
    }
    let theta = (a[q * n + q] - a[p * n + p]) / (R::constant(2.0) * apq);
    let t = if theta.abs() > R::constant(LARGE_THETA) {
        R::constant(0.5) / theta
    } else {
        let sign = if theta < zero { -one } else { one };
        sign / (theta.abs() + (theta * theta + one).sqrt())
    };
    let c = one / (t * t + one).sqrt();
    let s = t * c;
    a[p * n + p] -= t * apq;
    a[q * n + q] += t * apq;
    a[p * n + q] = zero;
    a[q * n + p] = zero;
    for r in 0..n {
        if r == p || r == q {
            continue;
        }
        let arp = a[r * n + p];
        let arq = a[r * n + q];
        let new_rp = c * arp - s * arq;
        let new_rq = s * arp + c * arq;
        a[r * n + p] = new_rp;
        a[p * n + r] = new_rp;
        a[r * n + q] = new_rq;
        a[q * n + r] = new_rq;
    }
    for r in 0..n {
        let vrp = v[r * n + p];
        let vrq = v[r * n + q];
        v[r * n + p] = c * vrp - s * vrq;
        v[r * n + q] = s * vrp + c * vrq;
    }
}

/// Stable insertion sort of `values` ascending, moving eigenvector columns
/// with them (NaN compares false and stays in place).
fn sort_ascending<R: ProjectionReal>(values: &mut [R], vectors: &mut [R], n: usize) {
    for i in 1..n {
        let mut j = i;
        while j > 0 && values[j] < values[j - 1] {
            values.swap(j, j - 1);
            for r in 0..n {
                vectors.swap(r * n + j, r * n + j - 1);
            }
            j -= 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ‖A V − V Λ‖_max and ‖VᵀV − I‖_max.
    fn residuals(a: &[f64], n: usize, values: &[f64], v: &[f64]) -> (f64, f64) {
        let mut eig: f64 = 0.0;
        let mut orth: f64 = 0.0;
        for i in 0..n {
            for j in 0..n {
                let av: f64 = (0..n).map(|m| a[i * n + m] * v[m * n + j]).sum();
                eig = eig.max((av - v[i * n + j] * values[j]).abs());
                let vv: f64 = (0..n).map(|m| v[m * n + i] * v[m * n + j]).sum();
                orth = orth.max((vv - if i == j { 1.0 } else { 0.0 }).abs());
            }
        }
        (eig, orth)
    }

    #[test]
    fn known_spectra() {
        // [[2, 1], [1, 2]]: eigenvalues 1 and 3.
        let mut a = [2.0, 1.0, 1.0, 2.0];
        let (mut w, mut v) = ([0.0; 2], [0.0; 4]);
        let report = symmetric_eigen(&mut a, 2, &mut w, &mut v);
        assert!(report.converged);
        approx::assert_relative_eq!(w[0], 1.0, epsilon = 4.0 * f64::EPSILON);
        approx::assert_relative_eq!(w[1], 3.0, epsilon = 4.0 * f64::EPSILON);
        // A diagonal matrix needs no sweep and comes back sorted.
        let mut d = [3.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 2.0];
        let (mut w, mut v) = ([0.0; 3], [0.0; 9]);
        let report = symmetric_eigen(&mut d, 3, &mut w, &mut v);
        assert_eq!(report.sweeps, 0);
        assert_eq!(w, [-1.0, 2.0, 3.0]);
        assert_eq!(v, [0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    }

    #[test]
    fn decomposes_dense_matrices_up_to_order_eight() {
        for n in 1..=8 {
            let mut a = vec![0.0; n * n];
            for i in 0..n {
                for j in 0..=i {
                    let x = ((i * 7 + j * 3 + n) % 11) as f64 / 5.0 - 1.0;
                    a[i * n + j] = x;
                    a[j * n + i] = x;
                }
            }
            let original = a.clone();
            let scale = original.iter().map(|x| x.abs()).fold(0.0, f64::max);
            let (mut w, mut v) = (vec![0.0; n], vec![0.0; n * n]);
            let report = symmetric_eigen(&mut a, n, &mut w, &mut v);
            assert!(report.converged, "n = {n}: {report:?}");
            assert!(report.sweeps <= 12, "n = {n}: {report:?}");
            assert!(w.windows(2).all(|p| p[0] <= p[1]), "n = {n}: {w:?}");
            let (eig, orth) = residuals(&original, n, &w, &v);
            // Each rotation is orthogonal to O(ε); a sweep has n(n−1)/2.
            let bound = 8.0 * (n * n) as f64 * f64::EPSILON;
            assert!(eig <= bound * scale * n as f64, "n = {n}: {eig:e}");
            assert!(orth <= bound, "n = {n}: {orth:e}");
        }
    }

    #[test]
    fn repeated_eigenvalues_and_extreme_ratios() {
        // Identity plus a rank-one term: eigenvalues 1 (twice) and 1 + 3.
        let mut a = [2.0, 1.0, 1.0, 1.0, 2.0, 1.0, 1.0, 1.0, 2.0];
        let (mut w, mut v) = ([0.0; 3], [0.0; 9]);
        assert!(symmetric_eigen(&mut a, 3, &mut w, &mut v).converged);
        approx::assert_relative_eq!(w[0], 1.0, epsilon = 8.0 * f64::EPSILON);
        approx::assert_relative_eq!(w[1], 1.0, epsilon = 8.0 * f64::EPSILON);
        approx::assert_relative_eq!(w[2], 4.0, epsilon = 8.0 * f64::EPSILON);
        // A tiny coupling (a_02) between far-apart diagonal entries, rotated
        // while a_01 is still being annihilated: |θ| ≈ 1e300 takes the
        // overflow guard.
        let original = [1.0, 0.5, 1e-300, 0.5, 2.0, 0.0, 1e-300, 0.0, -1.0];
        let mut b = original;
        let (mut w, mut v) = ([0.0; 3], [0.0; 9]);
        let report = symmetric_eigen(&mut b, 3, &mut w, &mut v);
        assert!(report.converged, "{report:?}");
        let r = 0.5f64.sqrt();
        for (got, want) in w.iter().zip([-1.0, 1.5 - r, 1.5 + r]) {
            approx::assert_relative_eq!(*got, want, max_relative = 8.0 * f64::EPSILON);
        }
        let (eig, orth) = residuals(&original, 3, &w, &v);
        assert!(eig <= 16.0 * f64::EPSILON && orth <= 16.0 * f64::EPSILON);
        // Entries whose squares overflow still converge.
        let mut c = [1e300, 5e299, 5e299, 1e300];
        let (mut w, mut v) = ([0.0; 2], [0.0; 4]);
        assert!(symmetric_eigen(&mut c, 2, &mut w, &mut v).converged);
        approx::assert_relative_eq!(w[0], 5e299, max_relative = 4.0 * f64::EPSILON);
        approx::assert_relative_eq!(w[1], 1.5e300, max_relative = 4.0 * f64::EPSILON);
    }
}
