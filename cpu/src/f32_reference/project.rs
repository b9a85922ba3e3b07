//! XPBD projection of one colour of one family in f32, as
//! `shaders/project.wgsl` computes it.
//!
//! ```text
//! Δλ = (−C − α~ λ) / (Σ_j w_j |∇_j C|² + α~)
//! contacts (C ≥ 0): λ' = max(λ + Δλ, 0);  Δλ = λ' − λ
//! tethers: λ' = min(λ + Δλ, 0)
//! x_j += w_j ∇_j C Δλ
//! static friction (active contact, μ > 0): Δt = tangential part of x − p;
//! if |Δt| ≤ μ w λ then x −= Δt
//! ```
//! Each returns the first slot whose update was non-finite. Fixed
//! particles (w = 0) are never written.

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use std::ops::Range;

use super::Particles;
use super::material::Law;
use hyperpbd_core::geometry::{Scratch, oriented_measure, simplex_squared_measure};
use hyperpbd_core::kinds::contact_friction::{dot_from_zero, static_friction};
use hyperpbd_core::kinds::hyperplane_contact::contact_update;

/// An expression family's per-element constants, rounded once to f32
/// (as the GPU uploads them); empty for the other kinds.
pub fn expression_constants(kind: &hyperpbd_core::FamilyKind) -> Vec<f32> {
    match kind {
        hyperpbd_core::FamilyKind::Expression(kind) => {
            kind.constants.iter().map(|&c| c as f32).collect()
        }
        hyperpbd_core::FamilyKind::Distance
        | hyperpbd_core::FamilyKind::Tether
        | hyperpbd_core::FamilyKind::SimplexMeasure { .. }
        | hyperpbd_core::FamilyKind::OrientedMeasure
        | hyperpbd_core::FamilyKind::Material { .. }
        | hyperpbd_core::FamilyKind::HyperplaneContact { .. }
        | hyperpbd_core::FamilyKind::MeshContact { .. } => Vec::new(),
    }
}

/// One colour of one family: its elements (`arity` particle indices per
/// slot), rest values and multipliers, and α / h².
pub struct Colour<'a> {
    pub slots: Range<usize>,
    pub arity: usize,
    pub elements: &'a [u32],
    pub rest: &'a [f32],
    pub alpha_tilde: f32,
}

/// The constraint of a measure family (a material family's C = √(2W)
/// is projected as one, a refused element failing its slot).
#[derive(Clone, Copy)]
pub enum Measure<'a> {
    /// k + 1 points: k from the colour's arity.
    Simplex,
    Oriented,
    Material(&'a Law),
}

pub fn distance(
    s: &mut Particles,
    c: &Colour,
    lambda: &mut [f32],
    tether: bool,
) -> Result<(), usize> {
    let n = s.dim;
    let mut failed = None;
    let mut d = vec![0.0f32; n];
    for e in c.slots.clone() {
        let (i, j) = (c.elements[2 * e] as usize, c.elements[2 * e + 1] as usize);
        let (wi, wj) = (s.w[i], s.w[j]);
        let mut d2 = 0.0f32;
        for a in 0..n {
            d[a] = s.x[j * n + a] - s.x[i * n + a];
            d2 += d[a] * d[a];
        }
        let len = d2.sqrt();
        let wsum = wi + wj;
        if len.is_nan() || len <= 0.0 || wsum == 0.0 {
            if !len.is_finite() {
                failed = failed.or(Some(e));
            }
            continue;
        }
        let l = lambda[e];
        let mut dl = (-(len - c.rest[e]) - c.alpha_tilde * l) / (wsum + c.alpha_tilde);
        if !dl.is_finite() {
            failed = failed.or(Some(e));
            continue;
        }
        if tether {
            dl = (l + dl).min(0.0) - l;
        }
        lambda[e] = l + dl;
        let inv = 1.0 / len;
        if wi != 0.0 {
            for a in 0..n {
                s.x[i * n + a] += wi * -(d[a] * inv) * dl;
            }
        }
        if wj != 0.0 {
            for a in 0..n {
                s.x[j * n + a] += wj * (d[a] * inv) * dl;
            }
        }
    }
    failed.map_or(Ok(()), Err)
}

pub fn measure(
    s: &mut Particles,
    c: &Colour,
    lambda: &mut [f32],
    kind: Measure,
) -> Result<(), usize> {
    let n = s.dim;
    let arity = c.arity;
    let mut failed = None;
    let mut pts = vec![0.0f32; arity * n];
    let mut grad = vec![0.0f32; arity * n];
    let mut scratch = Scratch::<f32>::default();
    for e in c.slots.clone() {
        let element = &c.elements[e * arity..(e + 1) * arity];
        for (j, &i) in element.iter().enumerate() {
            let i = i as usize;
            pts[j * n..(j + 1) * n].copy_from_slice(&s.x[i * n..(i + 1) * n]);
        }
        let value = match kind {
            Measure::Simplex => Some(simplex_squared_measure(&pts, n, &mut grad, &mut scratch)),
            Measure::Oriented => Some(oriented_measure(&pts, n, &mut grad, &mut scratch)),
            Measure::Material(law) => law.constraint(e, &pts, n, &mut grad),
        };
        let Some(value) = value.filter(|v| v.is_finite()) else {
            failed = failed.or(Some(e));
            continue;
        };
        let mut wsum = 0.0f32;
        for (j, &i) in element.iter().enumerate() {
            let mut g2 = 0.0f32;
            for a in 0..n {
                g2 += grad[j * n + a] * grad[j * n + a];
            }
            wsum += s.w[i as usize] * g2;
        }
        if wsum == 0.0 {
            continue;
        }
        let l = lambda[e];
        let dl = (-(value - c.rest[e]) - c.alpha_tilde * l) / (wsum + c.alpha_tilde);
        if !dl.is_finite() {
            failed = failed.or(Some(e));
            continue;
        }
        lambda[e] = l + dl;
        for (j, &i) in element.iter().enumerate() {
            let i = i as usize;
            let w = s.w[i];
            if w == 0.0 {
                continue;
            }
            for a in 0..n {
                s.x[i * n + a] += w * grad[j * n + a] * dl;
            }
        }
    }
    failed.map_or(Ok(()), Err)
}

/// A hyperplane contact family: n·x − rest ≥ 0 (rest in device
/// coordinates), Coulomb μ.
pub struct Plane<'a> {
    pub normal: &'a [f32],
    pub mu: f32,
}

pub fn contact(
    s: &mut Particles,
    c: &Colour,
    plane: &Plane,
    lambda: &mut [f32],
) -> Result<(), usize> {
    let n = s.dim;
    let normal = plane.normal;
    let mut failed = None;
    for e in c.slots.clone() {
        let i = c.elements[e] as usize;
        let w = s.w[i];
        let (x, p) = (&mut s.x[i * n..(i + 1) * n], &s.p[i * n..(i + 1) * n]);
        let nx = dot_from_zero(normal, x);
        let cval = nx - c.rest[e];
        let Some(l_new) = contact_update(cval, (lambda[e], w, c.alpha_tilde), normal, x) else {
            failed = failed.or(Some(e));
            continue;
        };
        lambda[e] = l_new;
        if plane.mu > 0.0 && l_new > 0.0 {
            static_friction(normal, plane.mu * w * l_new, p, x);
        }
    }
    failed.map_or(Ok(()), Err)
}
