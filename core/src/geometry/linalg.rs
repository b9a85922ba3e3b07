//! Small dense determinants and adjugates, row-major.
//!
//! ```text
//! det(A)        Gaussian elimination with partial pivoting (first row of
//!               largest |pivot| wins ties), product of pivots, sign per swap
//! adj(A)[j][i]  = (−1)^(i+j) · det(A with row i and column j removed)
//! ```
//!
//! The adjugate is built from minors rather than det(A)·A⁻¹ so that it stays
//! finite and exact in form at singular matrices, where the gradients of the
//! measure constraints must not blow up.
//!
//! ```text
//! unit(n)       = s / |s|,  s = n / max_a |n_a|   (scaled first, so neither
//!               tiny (1e-200) nor huge (1e200) normals under- or overflow)
//! ```

use crate::kinds::ProjectionReal;

/// Determinant of the `n`×`n` row-major matrix `a` (overwritten), in
/// precision `R` (f64: the golden path; f32: the f32 reference, as
/// `shaders/measure.wgsl` computes it).
pub fn determinant<R: ProjectionReal>(a: &mut [R], n: usize) -> R {
    debug_assert!(a.len() >= n * n);
    let zero = R::constant(0.0);
    let mut det = R::constant(1.0);
    for col in 0..n {
        let mut pivot_row = col;
        let mut pivot_abs = a[col * n + col].abs();
        for row in col + 1..n {
            let v = a[row * n + col].abs();
            if v > pivot_abs {
                pivot_abs = v;
                pivot_row = row;
            }
        }
        if pivot_abs == zero {
            return zero;
        }
        if pivot_row != col {
            for c in 0..n {
                a.swap(col * n + c, pivot_row * n + c);
            }
            det = -det;
        }
        let pivot = a[col * n + col];
        det *= pivot;
        for row in col + 1..n {
            let factor = a[row * n + col] / pivot;
            if factor != zero {
                for c in col + 1..n {
                    a[row * n + c] -= factor * a[col * n + c];
                }
            }
        }
    }
    det
}

/// Adjugate of the `n`×`n` row-major matrix `a` into `out`; `minor` is
/// scratch of at least (n−1)² entries.
pub fn adjugate<R: ProjectionReal>(a: &[R], n: usize, out: &mut [R], minor: &mut [R]) {
    if n == 1 {
        out[0] = R::constant(1.0);
        return;
    }
    let m = n - 1;
    for i in 0..n {
        for j in 0..n {
            let mut idx = 0;
            for r in (0..n).filter(|&r| r != i) {
                for c in (0..n).filter(|&c| c != j) {
                    minor[idx] = a[r * n + c];
                    idx += 1;
                }
            }
            let sign = R::constant(if (i + j) % 2 == 0 { 1.0 } else { -1.0 });
            out[j * n + i] = sign * determinant(&mut minor[..m * m], m);
        }
    }
}

/// n / |n|, scaling by the largest component first so that neither tiny
/// (1e-200) nor huge (1e200) normals underflow or overflow on the way.
pub fn unit_vector(n: &[f64]) -> Vec<f64> {
    let largest = n.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let scaled: Vec<f64> = n.iter().map(|x| x / largest).collect();
    let length = scaled.iter().map(|x| x * x).sum::<f64>().sqrt();
    scaled.iter().map(|x| x / length).collect()
}

/// d = x_j − x_i for points `i` and `j` of the `n`-wide array `x` into
/// `d[..n]`; returns |d| = √(Σ_a d_a²), the squares summed in axis order.
#[inline]
pub fn separation(x: &[f64], i: usize, j: usize, n: usize, d: &mut [f64]) -> f64 {
    let mut length2 = 0.0;
    for a in 0..n {
        d[a] = x[j * n + a] - x[i * n + a];
        length2 += d[a] * d[a];
    }
    length2.sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn determinant_of_known_matrices() {
        let mut a = [2.0, 0.0, 0.0, 3.0];
        assert_eq!(determinant(&mut a, 2), 6.0);
        let mut b = [0.0, 1.0, 1.0, 0.0];
        assert_eq!(determinant(&mut b, 2), -1.0);
        let mut c = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 10.0];
        approx::assert_relative_eq!(determinant(&mut c, 3), -3.0, epsilon = 1e-12);
        let mut singular = [1.0, 2.0, 2.0, 4.0];
        assert_eq!(determinant(&mut singular, 2), 0.0);
    }

    #[test]
    fn adjugate_times_matrix_is_det_identity() {
        let a = [1.0, 2.0, 3.0, 0.5, 5.0, 6.0, 7.0, 8.0, 10.0];
        let mut adj = [0.0; 9];
        let mut minor = [0.0; 4];
        adjugate(&a, 3, &mut adj, &mut minor);
        let det = determinant(&mut a.clone(), 3);
        for i in 0..3 {
            for j in 0..3 {
                let v: f64 = (0..3).map(|k| adj[i * 3 + k] * a[k * 3 + j]).sum();
                let expected = if i == j { det } else { 0.0 };
                approx::assert_abs_diff_eq!(v, expected, epsilon = 1e-12);
            }
        }
    }

    #[test]
    fn adjugate_is_finite_at_singular_matrix() {
        let a = [1.0, 2.0, 2.0, 4.0];
        let mut adj = [0.0; 4];
        adjugate(&a, 2, &mut adj, &mut [0.0; 1]);
        assert_eq!(adj, [4.0, -2.0, -2.0, 1.0]);
    }
}
