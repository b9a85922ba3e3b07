//! Cholesky factor of a small symmetric positive definite matrix, the
//! inverse of a lower-triangular matrix, and A⁻¹ from the two. Row-major.
//!
//! ```text
//! A = L Lᵀ, L lower triangular with L_jj > 0; column by column, j = 0..n−1:
//!   d    = a_jj − Σ_{m<j} L_jm²            (m ascending)      refuse unless d > 0
//!   L_jj = √d
//!   L_ij = (a_ij − Σ_{m<j} L_im L_jm) / L_jj    for i = j+1..n−1
//! Y = L⁻¹ (lower), column by column:
//!   Y_jj = 1 / L_jj,   Y_ij = −(Σ_{m=j}^{i−1} L_im Y_mj) / L_ii    for i > j
//! A⁻¹ = Yᵀ Y:   (A⁻¹)_ij = Σ_{m=max(i,j)}^{n−1} Y_mi Y_mj            (exactly symmetric)
//! det A = Π L_jj²
//! ```

use crate::geometry::sum_of_products;
use crate::kinds::ProjectionReal;

/// A pivot d = a_jj − Σ L_jm² that is not > 0: the matrix is not positive
/// definite to rounding (or holds a NaN).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NotPositiveDefinite {
    /// Column of the failed pivot.
    pub column: usize,
    /// The pivot d.
    pub pivot: f64,
}

/// The lower Cholesky factor of the symmetric `a` (n×n) into `l` (the
/// strictly upper part of `l` is set to 0), in precision `R` (f64: the
/// golden path; f32: the f32 reference, as `shaders/material.wgsl`). Only
/// the lower part of `a` is read.
pub fn cholesky<R: ProjectionReal>(
    a: &[R],
    n: usize,
    l: &mut [R],
) -> Result<(), NotPositiveDefinite> {
    let zero = R::constant(0.0);
    for j in 0..n {
        let mut d = a[j * n + j];
        for m in 0..j {
            d -= l[j * n + m] * l[j * n + m];
        }
        if d.is_nan() || d <= zero {
            return Err(NotPositiveDefinite {
                column: j,
                pivot: d.to_f64(),
            });
        }
        let ljj = d.sqrt();
        l[j * n + j] = ljj;
        for c in j + 1..n {
            l[j * n + c] = zero;
        }
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for m in 0..j {
                s -= l[i * n + m] * l[j * n + m];
            }
            l[i * n + j] = s / ljj;
        }
    }
    Ok(())
}

/// Y = L⁻¹ of the lower-triangular `l` with nonzero diagonal into `y`
/// (strictly upper part 0).
pub fn lower_triangular_inverse<R: ProjectionReal>(l: &[R], n: usize, y: &mut [R]) {
    let zero = R::constant(0.0);
    for j in 0..n {
        for i in 0..j {
            y[i * n + j] = zero;
        }
        y[j * n + j] = R::constant(1.0) / l[j * n + j];
        for i in j + 1..n {
            let mut s = zero;
            for m in j..i {
                s += l[i * n + m] * y[m * n + j];
            }
            y[i * n + j] = -s / l[i * n + i];
        }
    }
}

/// b ← (L Lᵀ)⁻¹ b for the lower factor `l` (n × n, row-major; only its
/// lower part is read): forward substitution L z = b, then Lᵀ y = z, each
/// row's products subtracted in ascending (then descending) order.
pub fn solve_factored<R: ProjectionReal>(l: &[R], n: usize, b: &mut [R]) {
    for i in 0..n {
        let mut s = b[i];
        for m in 0..i {
            s -= l[i * n + m] * b[m];
        }
        b[i] = s / l[i * n + i];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for m in i + 1..n {
            s -= l[m * n + i] * b[m];
        }
        b[i] = s / l[i * n + i];
    }
}

/// A⁻¹ = Yᵀ Y from Y = L⁻¹ into `inverse`.
pub fn inverse_from_factor_inverse<R: ProjectionReal>(y: &[R], n: usize, inverse: &mut [R]) {
    for i in 0..n {
        for j in 0..n {
            inverse[i * n + j] = sum_of_products(i.max(j)..n, |m| (y[m * n + i], y[m * n + j]));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factor_inverse_and_refusal() {
        let a = [4.0, 2.0, 0.4, 2.0, 5.0, 1.0, 0.4, 1.0, 3.0];
        let mut l = [9.0; 9];
        cholesky(&a, 3, &mut l).expect("SPD");
        for i in 0..3 {
            for j in 0..3 {
                let llt: f64 = (0..3).map(|m| l[i * 3 + m] * l[j * 3 + m]).sum();
                approx::assert_relative_eq!(llt, a[i * 3 + j], epsilon = 1e-15);
                if j > i {
                    assert_eq!(l[i * 3 + j], 0.0);
                }
            }
        }
        let mut y = [9.0; 9];
        lower_triangular_inverse(&l, 3, &mut y);
        let mut inv = [0.0; 9];
        inverse_from_factor_inverse(&y, 3, &mut inv);
        for i in 0..3 {
            for j in 0..3 {
                let ai: f64 = (0..3).map(|m| a[i * 3 + m] * inv[m * 3 + j]).sum();
                let id = if i == j { 1.0 } else { 0.0 };
                approx::assert_abs_diff_eq!(ai, id, epsilon = 1e-15);
                assert_eq!(inv[i * 3 + j], inv[j * 3 + i]);
            }
        }
        let singular = [1.0, 2.0, 2.0, 4.0];
        let err = cholesky(&singular, 2, &mut [0.0; 4]).expect_err("singular");
        assert_eq!(err.column, 1);
        assert!(err.pivot <= 0.0);
        assert!(cholesky(&[f64::NAN], 1, &mut [0.0]).is_err());
    }
}
