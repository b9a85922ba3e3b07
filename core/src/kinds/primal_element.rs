//! The element problems of XPBD with the primal residual (the golden
//! path's `cpu/src/consistent.rs` has the method), one code for both
//! precisions: the golden path runs them in f64, the f32 reference in f32
//! (`primal.wgsl`'s order).
//!
//! ```text
//! distance, tether  a_0 = x_0 − d_0, a_1 = x_1 − d_1;  |a_1 − a_0| = √(Σ_a (a_1 − a_0)_a²)
//!                   |·| NaN, ≤ 0 or W = 0:  λ = 0, d = 0 (a non-finite |·| fails)
//!                   else λ = clamp((rest − |·|)/(W + α~)), u = (a_1 − a_0)/|·|,
//!                        d_0 = −w_0 u λ,  d_1 = w_1 u λ      (a non-finite λ fails)
//! Gauss–Newton      Σ = Σ_j w_j |∇_j C|²,  lin = C − rest + Σ_j ∇_j C·(a_j − y0_j)
//!                   (dynamic j, axes ascending);  Σ = 0 or not finite: λ = 0
//!                   else λ = clamp(−lin/(Σ + α~))
//! ```

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use super::{ProjectionReal, Relation};

/// The distance (or tether) element of the module docs: the anchors
/// x − d into `[a_0, a_1]`, the new d into `[d_0, d_1]` (which hold the
/// old d on entry); λ, or `None` when it failed (d then untouched).
#[inline(always)]
pub fn distance_element<R: ProjectionReal>(
    [x0, x1]: [&[R]; 2],
    [a0, a1]: [&mut [R]; 2],
    [d0, d1]: [&mut [R]; 2],
    (w0, w1, rest, alpha_tilde): (R, R, R, R),
    relation: Relation,
) -> Option<R> {
    let n = a0.len();
    let zero = R::constant(0.0);
    let mut len2 = zero;
    for k in 0..n {
        a0[k] = x0[k] - d0[k];
        a1[k] = x1[k] - d1[k];
        let dk = a1[k] - a0[k];
        len2 += dk * dk;
    }
    let len = len2.sqrt();
    let wsum = w0 + w1;
    if len.is_nan() || len <= zero || wsum == zero {
        if !len.finite() {
            return None;
        }
        d0.fill(zero);
        d1.fill(zero);
        return Some(zero);
    }
    let l = relation.clamp((rest - len) / (wsum + alpha_tilde));
    if !l.finite() {
        return None;
    }
    for k in 0..n {
        let u = (a1[k] - a0[k]) / len;
        d0[k] = -w0 * u * l;
        d1[k] = w1 * u * l;
    }
    Some(l)
}

/// λ of one Gauss–Newton step (module docs) with ∇C `grad`, anchors
/// `anchor`, y0 `points` (all `n` per point) and `weight(j)` = w_j;
/// `residual` = C(y0) − rest. `None`: no response (Σ = 0 or not finite).
#[inline(always)]
pub fn gauss_newton_lambda<R: ProjectionReal>(
    n: usize,
    weight: impl Fn(usize) -> R,
    [grad, anchor, points]: [&[R]; 3],
    (residual, alpha_tilde): (R, R),
    relation: Relation,
) -> Option<R> {
    let zero = R::constant(0.0);
    let (mut wsum, mut lin) = (zero, residual);
    for j in 0..grad.len() / n {
        let w = weight(j);
        if w == zero {
            continue;
        }
        for k in j * n..(j + 1) * n {
            wsum += w * grad[k] * grad[k];
            lin += grad[k] * (anchor[k] - points[k]);
        }
    }
    if wsum == zero || !wsum.finite() {
        return None;
    }
    Some(relation.clamp(-lin / (wsum + alpha_tilde)))
}
