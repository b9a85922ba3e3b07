//! Simplex-mesh contact on the golden path (`hyperpbd_core::kinds::
//! mesh_contact` has the constraint, its reach and its tie rule): the
//! dynamic friction and the residual of one mesh family; its projection
//! (the update below) is `project.rs`'s `mesh_contact_in`.
//!
//! ```text
//! project   reach = w λ;  (C, n) = closest(mesh, x, r, reach)   (none: no update)
//!           Δλ = (−C − α~ λ)/(w + α~);  λ' = max(λ + Δλ, 0);  x += w n (λ' − λ)
//!           static friction (μ > 0, λ' > 0): project.rs's, with this n
//! friction  after Velocity, per element with λ > 0:
//!           n from closest(mesh, x, r, w λ) at the substep's final x (none: no friction)
//!           v_t = v − (n·v) n;  v −= v_t · min(μ w λ / h, |v_t|) / |v_t|   (friction.rs's)
//! residual  max_e max(0, −C_e)    (C from closest(mesh, x, r, 0): only C ≤ 0 counts)
//! moving    closest in the mesh's frame, n turned back (`hyperpbd_core::
//!           moving_mesh`); static friction against q = p + D(p) and
//!           dynamic friction on v − D(p)/h, as a moving plane's (motion.rs)
//! ```
//! These are the hyperplane's updates (`project.rs`, `friction.rs`) with
//! the plane's fixed normal replaced by the mesh's normal at x. A family
//! holds each particle once and an element writes only its particle (and
//! its own kept candidates, [`KeptCandidates`]), so the elements run in
//! chunks on every core with the serial bytes.

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use crate::parallel::{Coordinates, DisjointSlice, Shared, Workers, first_error};
use crate::project::ELEMENT_GRAIN;
use hyperpbd_core::barrier::BarrierObstacles;
use hyperpbd_core::kinds::contact_friction::clamp_tangential;
use hyperpbd_core::kinds::mesh_candidates::Candidates;
use hyperpbd_core::motion::MeshAt;
use hyperpbd_core::moving_mesh::closest_placed;
use hyperpbd_core::{Family, FamilyKind, MAX_DIM, Plan};
use std::ops::Range;

/// The candidates each element of a mesh family keeps between its
/// queries (`hyperpbd_core::kinds::mesh_candidates`: the same answers with
/// fewer walks of the hierarchy); other families keep none. Derived data:
/// any slot may be emptied at any time without changing a bit.
#[derive(Debug, Clone, Default)]
pub(crate) struct KeptCandidates {
    slots: Vec<Candidates>,
    /// Family f's slots: `slots[starts[f]..starts[f + 1]]`.
    starts: Vec<usize>,
}

impl KeptCandidates {
    /// Empty slots for every element of `plan`'s mesh families.
    pub fn new(plan: &Plan) -> Self {
        let mut starts = vec![0];
        for f in &plan.families {
            let own = match f.kind {
                FamilyKind::MeshContact { .. } => f.len(),
                FamilyKind::Distance
                | FamilyKind::SimplexMeasure { .. }
                | FamilyKind::OrientedMeasure
                | FamilyKind::Tether
                | FamilyKind::Material { .. }
                | FamilyKind::HyperplaneContact { .. }
                | FamilyKind::Expression(_) => 0,
            };
            starts.push(starts[starts.len() - 1] + own);
        }
        KeptCandidates {
            slots: vec![Candidates::EMPTY; starts[starts.len() - 1]],
            starts,
        }
    }

    /// Family `family`'s slots (empty unless it is a mesh family).
    pub fn family(&mut self, family: usize) -> &mut [Candidates] {
        &mut self.slots[self.starts[family]..self.starts[family + 1]]
    }
}

/// What every element of a mesh family's friction shares.
pub(crate) struct MeshFriction<'a> {
    pub dim: usize,
    pub h: f64,
    pub inverse_mass: &'a [f64],
    pub family: &'a Family,
    pub mesh: &'a BarrierObstacles,
    pub mu: f64,
    pub lambda: &'a [f64],
    /// Positions at the substep's end.
    pub x: &'a [f64],
    /// A moving mesh's placement this substep and the positions at the
    /// substep's start (`None`: static).
    pub moving: Option<(&'a MeshAt, &'a [f64])>,
    /// The elements' kept candidates ([`KeptCandidates::family`]).
    pub kept: &'a DisjointSlice<'a, Candidates>,
}

/// Dynamic friction of a mesh family; the first particle (in element
/// order) whose velocity became non-finite.
pub(crate) fn friction(workers: &Workers, m: &MeshFriction, v: &mut [f64]) -> Result<(), usize> {
    let count = m.lambda.len();
    let result = if workers.splits(count, ELEMENT_GRAIN) {
        // SAFETY: a contact family holds each particle once (checked by
        // `colours::check` when the backend loaded the plan), and element
        // e writes only the velocity of its particle.
        let v = unsafe { DisjointSlice::new(v) };
        workers.try_for_chunks(count, ELEMENT_GRAIN, |r| friction_in(m, r, &mut Shared(&v)))
    } else {
        workers
            .chunks(count, ELEMENT_GRAIN)
            .map(|r| friction_in(m, r, v))
            .fold(Ok(()), first_error)
    };
    result.map_err(|e| m.family.elements[e] as usize)
}

/// Friction of elements `elements`; the first non-finite element.
fn friction_in<V: Coordinates + ?Sized>(
    m: &MeshFriction,
    elements: Range<usize>,
    v: &mut V,
) -> Result<(), usize> {
    let dim = m.dim;
    let mut normal = [0.0f64; MAX_DIM];
    let normal = &mut normal[..dim];
    let mut rel = [0.0f64; MAX_DIM];
    let frame = m.moving.map(|(at, _)| at.frame(&[]));
    // SAFETY: each element belongs to one chunk, and its slot is touched
    // only by its own update.
    let kept = unsafe { m.kept.range_mut(elements.clone()) };
    let first = elements.start;
    for e in elements {
        let l = m.lambda[e];
        if l <= 0.0 {
            continue;
        }
        let i = m.family.elements[e] as usize;
        let w = m.inverse_mass[i];
        let xi = &m.x[i * dim..(i + 1) * dim];
        let query = (xi, m.family.rest[e], w * l);
        let slot = Some(&mut kept[e - first]);
        if closest_placed(m.mesh, frame.as_ref(), query, normal, slot).is_none() {
            continue;
        }
        let vi = v.values_mut(i * dim..(i + 1) * dim);
        let limit = m.mu * w * l / m.h;
        let applied = match m.moving {
            None => {
                let vn = crate::project::dot(normal, vi);
                clamp_tangential(normal, limit, vn, vi)
            }
            Some((at, start)) => {
                let p = &start[i * dim..(i + 1) * dim];
                crate::friction::carried_friction(
                    normal,
                    &at.carry,
                    p,
                    (limit, m.h),
                    &mut rel[..dim],
                    vi,
                )
            }
        };
        if applied && !vi.iter().all(|c| c.is_finite()) {
            return Err(e);
        }
    }
    Ok(())
}

/// max_e max(0, −C_e) of mesh family `family` at `x` (a moving mesh
/// where the last substep placed it).
pub(crate) fn residual(
    dim: usize,
    family: &Family,
    (mesh, moving): (&BarrierObstacles, Option<&MeshAt>),
    x: &[f64],
) -> f64 {
    let mut normal = [0.0f64; MAX_DIM];
    let mut worst: f64 = 0.0;
    let frame = moving.map(|m| m.frame(&[]));
    for (e, &i) in family.elements.iter().enumerate() {
        let xi = &x[i as usize * dim..(i as usize + 1) * dim];
        let query = (xi, family.rest[e], 0.0);
        if let Some(c) = closest_placed(mesh, frame.as_ref(), query, &mut normal[..dim], None) {
            worst = worst.max(-c);
        }
    }
    worst
}
