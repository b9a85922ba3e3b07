//! XPBD projection of one color of one family.
//!
//! ```text
//! α~ = α / h²
//! Δλ = (−C − α~ λ) / (Σ_j w_j |∇_j C|² + α~)
//! inequality (C ≥ 0):  λ' = max(λ + Δλ, 0);  Δλ = λ' − λ
//! x_j += w_j ∇_j C Δλ
//! ```
//! Tethers (|x1 − x0| ≤ rest) are distances with the one-sided clamp
//! λ' = min(λ + Δλ, 0); Δλ = λ' − λ (they only pull).
//!
//! Σ_j w_j |∇_j C|² is w_0 + w_1 for distance and w for contacts (their
//! gradients are unit vectors); measure kinds sum the computed gradients.
//! If that sum is 0 (no dynamic particle, or ∇C = 0: coincident points, a
//! collapsed simplex) the element makes no response. Fixed particles
//! (w = 0) are never written, not even with ±0.
//!
//! A contact checks the raw Δλ for NaN/Inf before the clamp (max(NaN, 0)
//! would hide it).
//!
//! Static friction (hyperplane contact with μ > 0), after the normal update
//! of an active contact (λ > 0):
//! ```text
//! Δx = x − p;  Δt = Δx − (n·Δx) n          (tangential motion this substep)
//! if |Δt| ≤ μ · w λ  (the normal correction):  x −= Δt
//! ```
//! The whole tangent vector is cancelled or none of it — never per axis.

use crate::dim::{Dim, with_dim};
use hyperpbd_core::geometry::{Scratch, oriented_measure, simplex_squared_measure};
use hyperpbd_core::{Family, FamilyKind};

/// Inputs shared by every element of a batch.
pub struct Batch<'a> {
    pub dim: usize,
    pub inverse_mass: &'a [f64],
    pub family: &'a Family,
    /// α / h².
    pub alpha_tilde: f64,
    /// Positions at the start of the substep (for static friction).
    pub start: &'a [f64],
}

/// Per-batch scratch.
#[derive(Default)]
pub struct Workspace {
    pub points: Vec<f64>,
    pub grad: Vec<f64>,
    pub scratch: Scratch,
}

/// Projects elements `range` (color-ordered slots) of `batch.family`.
/// Returns the slot of the first element whose update was non-finite.
pub fn project(
    batch: &Batch,
    range: std::ops::Range<usize>,
    x: &mut [f64],
    lambda: &mut [f64],
    ws: &mut Workspace,
) -> Result<(), usize> {
    match &batch.family.kind {
        FamilyKind::Distance | FamilyKind::Tether => distance(batch, range, x, lambda, ws),
        FamilyKind::HyperplaneContact { normal, friction } => {
            contact(batch, normal, *friction, range, x, lambda)
        }
        FamilyKind::SimplexMeasure { .. } | FamilyKind::OrientedMeasure => {
            measure(batch, range, x, lambda, ws)
        }
    }
}

fn distance(
    batch: &Batch,
    range: std::ops::Range<usize>,
    x: &mut [f64],
    lambda: &mut [f64],
    ws: &mut Workspace,
) -> Result<(), usize> {
    if batch.dim <= MAX_INLINE_DIM {
        with_dim!(batch.dim, distance_in(batch, range, x, lambda))
    } else {
        measure(batch, range, x, lambda, ws)
    }
}

/// Largest dimension whose distance difference vector lives on the stack.
const MAX_INLINE_DIM: usize = 8;

/// Distance projection: the same arithmetic, in the same order, as the
/// generic path with `geometry::distance` (which is its reference).
fn distance_in<D: Dim>(
    dim: D,
    batch: &Batch,
    range: std::ops::Range<usize>,
    x: &mut [f64],
    lambda: &mut [f64],
) -> Result<(), usize> {
    let n = dim.n();
    let f = batch.family;
    let w = batch.inverse_mass;
    let alpha_tilde = batch.alpha_tilde;
    let tether = f.kind == FamilyKind::Tether;
    let elements = f.elements[2 * range.start..2 * range.end].chunks_exact(2);
    let slots = f.rest[range.clone()].iter().zip(&mut lambda[range.clone()]);
    for (e, (element, (&rest, lambda))) in range.zip(elements.zip(slots)) {
        let (i, j) = (element[0] as usize, element[1] as usize);
        let (wi, wj) = (w[i], w[j]);
        let mut d = [0.0; MAX_INLINE_DIM];
        let mut d2 = 0.0;
        {
            let (xi, xj) = (&x[i * n..i * n + n], &x[j * n..j * n + n]);
            for a in 0..n {
                d[a] = xj[a] - xi[a];
                d2 += d[a] * d[a];
            }
        }
        let len = d2.sqrt();
        let wsum = wi + wj;
        if len.is_nan() || len <= 0.0 || wsum == 0.0 {
            if !len.is_finite() {
                return Err(e);
            }
            continue;
        }
        let c = len - rest;
        let mut dl = (-c - alpha_tilde * *lambda) / (wsum + alpha_tilde);
        if !dl.is_finite() {
            return Err(e);
        }
        if tether {
            dl = (*lambda + dl).min(0.0) - *lambda;
        }
        *lambda += dl;
        let inv = 1.0 / len;
        for c in &mut d[..n] {
            *c *= inv;
        }
        if wi != 0.0 {
            let xi = &mut x[i * n..i * n + n];
            for a in 0..n {
                xi[a] += wi * -d[a] * dl;
            }
        }
        if wj != 0.0 {
            let xj = &mut x[j * n..j * n + n];
            for a in 0..n {
                xj[a] += wj * d[a] * dl;
            }
        }
    }
    Ok(())
}

/// Generic path: gather, evaluate C and ∇C, update.
fn measure(
    batch: &Batch,
    range: std::ops::Range<usize>,
    x: &mut [f64],
    lambda: &mut [f64],
    ws: &mut Workspace,
) -> Result<(), usize> {
    let dim = batch.dim;
    let f = batch.family;
    let w = batch.inverse_mass;
    let arity = f.arity;
    ws.points.resize(arity * dim, 0.0);
    ws.grad.resize(arity * dim, 0.0);
    for e in range {
        let element = &f.elements[e * arity..(e + 1) * arity];
        for (j, &i) in element.iter().enumerate() {
            let i = i as usize;
            ws.points[j * dim..(j + 1) * dim].copy_from_slice(&x[i * dim..(i + 1) * dim]);
        }
        let value = match f.kind {
            FamilyKind::Distance | FamilyKind::Tether => {
                hyperpbd_core::geometry::distance(&ws.points, dim, &mut ws.grad)
            }
            FamilyKind::SimplexMeasure { .. } => {
                simplex_squared_measure(&ws.points, dim, &mut ws.grad, &mut ws.scratch)
            }
            _ => oriented_measure(&ws.points, dim, &mut ws.grad, &mut ws.scratch),
        };
        if !value.is_finite() {
            return Err(e);
        }
        let mut wsum = 0.0;
        if matches!(f.kind, FamilyKind::Distance | FamilyKind::Tether) {
            if value > 0.0 {
                wsum = w[element[0] as usize] + w[element[1] as usize];
            }
        } else {
            for (j, &i) in element.iter().enumerate() {
                let g2: f64 = ws.grad[j * dim..(j + 1) * dim].iter().map(|g| g * g).sum();
                wsum += w[i as usize] * g2;
            }
        }
        if wsum == 0.0 {
            continue;
        }
        let c = value - f.rest[e];
        let mut dl = (-c - batch.alpha_tilde * lambda[e]) / (wsum + batch.alpha_tilde);
        if !dl.is_finite() {
            return Err(e);
        }
        if f.kind == FamilyKind::Tether {
            dl = (lambda[e] + dl).min(0.0) - lambda[e];
        }
        lambda[e] += dl;
        for (j, &i) in element.iter().enumerate() {
            let i = i as usize;
            let wi = w[i];
            if wi == 0.0 {
                continue;
            }
            for a in 0..dim {
                x[i * dim + a] += wi * ws.grad[j * dim + a] * dl;
            }
        }
    }
    Ok(())
}

fn contact(
    batch: &Batch,
    normal: &[f64],
    friction: f64,
    range: std::ops::Range<usize>,
    x: &mut [f64],
    lambda: &mut [f64],
) -> Result<(), usize> {
    with_dim!(
        batch.dim,
        contact_in(batch, normal, friction, range, x, lambda)
    )
}

fn contact_in<D: Dim>(
    dim: D,
    batch: &Batch,
    normal: &[f64],
    friction: f64,
    range: std::ops::Range<usize>,
    x: &mut [f64],
    lambda: &mut [f64],
) -> Result<(), usize> {
    let n = dim.n();
    let normal = &normal[..n];
    let f = batch.family;
    let alpha_tilde = batch.alpha_tilde;
    let slots = f.rest[range.clone()].iter().zip(&mut lambda[range.clone()]);
    for (e, (&i, (&rest, lambda))) in range.clone().zip(f.elements[range].iter().zip(slots)) {
        let i = i as usize;
        let w = batch.inverse_mass[i];
        let xi = &mut x[i * n..i * n + n];
        let c = dot(normal, xi) - rest;
        let l = *lambda;
        let raw = (-c - alpha_tilde * l) / (w + alpha_tilde);
        if !raw.is_finite() {
            return Err(e);
        }
        let dl = (l + raw).max(0.0) - l;
        *lambda = l + dl;
        for a in 0..n {
            xi[a] += w * normal[a] * dl;
        }
        if friction > 0.0 && *lambda > 0.0 {
            let p = &batch.start[i * n..i * n + n];
            let mut dn = 0.0;
            for a in 0..n {
                dn += (xi[a] - p[a]) * normal[a];
            }
            let mut t2 = 0.0;
            for a in 0..n {
                let t = (xi[a] - p[a]) - dn * normal[a];
                t2 += t * t;
            }
            let bound = friction * w * *lambda;
            if t2.sqrt() <= bound {
                for a in 0..n {
                    let t = (xi[a] - p[a]) - dn * normal[a];
                    xi[a] -= t;
                }
            }
        }
    }
    Ok(())
}

/// n·x.
pub fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
