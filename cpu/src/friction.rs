//! Dynamic Coulomb friction against a hyperplane (velocity response).
//!
//! ```text
//! for each contact with λ > 0 in this substep:
//!   v_n = n·v;  v_t = v − v_n n               (complete tangent vector)
//!   Δv_max = μ · w λ / h                      (μ × normal velocity change)
//!   v −= v_t · min(Δv_max, |v_t|) / |v_t|     (one clamp on the norm)
//! ```
//! The clamp is core's `kinds::contact_friction` (one code with the f32
//! reference); v_n here is `project::dot`. A contact family holds each particle once, so its elements are
//! independent and run in chunks (`parallel.rs`).

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use crate::dim::{Dim, with_dim};
use crate::parallel::{Coordinates, DisjointSlice, Shared, Workers, first_error};
use crate::project::ELEMENT_GRAIN;
use hyperpbd_core::kinds::contact_friction::{clamp_relative, clamp_tangential};
use hyperpbd_core::motion::Carry;
use hyperpbd_core::{Family, FamilyKind};
use std::ops::Range;

/// Applies friction of one contact family; returns the first particle
/// (in element order) whose velocity became non-finite.
pub fn friction(
    workers: &Workers,
    dim: usize,
    h: f64,
    inverse_mass: &[f64],
    family: &Family,
    lambda: &[f64],
    v: &mut [f64],
) -> Result<(), usize> {
    let FamilyKind::HyperplaneContact { normal, friction } = &family.kind else {
        return Ok(());
    };
    let contact = Contact {
        h,
        inverse_mass,
        family,
        normal,
        friction: *friction,
        lambda,
    };
    let count = lambda.len();
    let result = if workers.splits(count, ELEMENT_GRAIN) {
        // SAFETY: a contact family holds each particle once (checked by
        // `colours::check` when the backend loaded the plan), and element e
        // writes only the velocity of its particle: chunks write disjoint data.
        let v = unsafe { DisjointSlice::new(v) };
        workers.try_for_chunks(count, ELEMENT_GRAIN, |r| {
            with_dim!(dim, friction_in(&contact, r, &mut Shared(&v)))
        })
    } else {
        workers
            .chunks(count, ELEMENT_GRAIN)
            .map(|r| with_dim!(dim, friction_in(&contact, r, v)))
            .fold(Ok(()), first_error)
    };
    result.map_err(|e| family.elements[e] as usize)
}

/// What every element of the family shares.
struct Contact<'a> {
    h: f64,
    inverse_mass: &'a [f64],
    family: &'a Family,
    normal: &'a [f64],
    friction: f64,
    lambda: &'a [f64],
}

/// Friction of elements `elements`; the first non-finite element.
fn friction_in<D: Dim, V: Coordinates + ?Sized>(
    dim: D,
    contact: &Contact,
    elements: Range<usize>,
    v: &mut V,
) -> Result<(), usize> {
    let n = dim.n();
    let normal = &contact.normal[..n];
    for e in elements {
        let l = contact.lambda[e];
        if l <= 0.0 {
            continue;
        }
        let i = contact.family.elements[e] as usize;
        let vi = v.values_mut(i * n..(i + 1) * n);
        let limit = contact.friction * contact.inverse_mass[i] * l / contact.h;
        let vn = crate::project::dot(normal, vi);
        if clamp_tangential(normal, limit, vn, vi) && !vi.iter().all(|c| c.is_finite()) {
            return Err(e);
        }
    }
    Ok(())
}

/// Dynamic friction of one particle (velocity `v`, substep start `p`)
/// against an obstacle that carries its points by `carry`: u = v − D(p)/h,
/// v −= u_t · min(`limit`, |u_t|) / |u_t| (`rel`: scratch). Whether v
/// changed.
pub(crate) fn carried_friction(
    normal: &[f64],
    carry: &Carry,
    p: &[f64],
    (limit, h): (f64, f64),
    rel: &mut [f64],
    v: &mut [f64],
) -> bool {
    carry.at(p, rel);
    for a in 0..v.len() {
        rel[a] = v[a] - rel[a] / h;
    }
    let vn = crate::project::dot(normal, rel);
    clamp_relative(normal, limit, (vn, rel), v)
}
