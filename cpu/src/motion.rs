//! Prescribed motion on the golden path (`hyperpbd_core::motion` has the
//! definitions): the Motion kernel, and the contact projection, friction
//! and residual of a moving hyperplane (a moving mesh's are
//! `mesh_contact.rs`'s and `project.rs`'s, given [`mesh`]).
//!
//! ```text
//! Motion     t0 = step·dt + s·h,  t1 = t0's successor (s + 1)
//!            planes: n(t1), s(t1), carry D over [t0, t1]
//!            pins:   x = x(t1),  v = (x(t1) − x(t0)) / h
//! contact    C = n·x − rest − s   (rest = d_0 + r)
//!            Δλ, clamp, x += w n Δλ                   (as project.rs)
//!            static friction (λ > 0): q = p + D(p), the obstacle point
//!            under p at t0, now at q; the tangential part of x − q is
//!            cancelled whole if |·| ≤ μ w λ
//! friction   u = D(p) / h;  v_rel = v − u;  v_t = v_rel − (n·v_rel) n
//!            v −= v_t · min(μ w λ / h, |v_t|) / |v_t|
//! residual   max_e max(0, rest + s − n·x)
//! ```
//! A static plane takes `project.rs` and `friction.rs` unchanged. Moving
//! planes run serially (one contact family per plane; their particles are
//! independent, so a split would give the same bytes).

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use hyperpbd_core::motion::{PlaneAt, SubstepMotion, substep_time};
use hyperpbd_core::moving_mesh::reach_rejection;
use hyperpbd_core::{BackendError, Family, FamilyKind, FamilyResidual, Plan, StepError};

use crate::parallel::{DisjointSlice, Workers};
use crate::project::dot;
use hyperpbd_core::kinds::contact_friction::static_friction;
use hyperpbd_core::kinds::hyperplane_contact::contact_update;
use hyperpbd_core::kinds::mesh_candidates::Candidates;

/// The Motion kernel of substep `substep` of step `step`: the substep's
/// prescribed values, pins placed in `x` with their velocities in `v`; a
/// moving mesh that would move too far in the substep is a guard
/// rejection before anything moves (`hyperpbd_core::moving_mesh`).
pub fn place(
    plan: &Plan,
    (step, substep): (u64, u32),
    x: &mut [f64],
    v: &mut [f64],
) -> Result<SubstepMotion, BackendError> {
    let Some(motion) = &plan.motion else {
        return Ok(SubstepMotion::default());
    };
    let t0 = substep_time(step, plan.dt, substep, plan.h);
    let t1 = substep_time(step, plan.dt, substep + 1, plan.h);
    let now = motion.substep(plan.dim, t0, t1, plan.h);
    if let Some(rejection) = reach_rejection(motion, &now, substep) {
        return Err(StepError::GuardRejected(rejection).into());
    }
    let n = plan.dim;
    for (k, pin) in motion.pins.iter().enumerate() {
        let i = pin.particle;
        x[i * n..(i + 1) * n].copy_from_slice(&now.pin_positions[k * n..(k + 1) * n]);
        v[i * n..(i + 1) * n].copy_from_slice(&now.pin_velocities[k * n..(k + 1) * n]);
    }
    Ok(now)
}

/// Projection of moving-plane family `family` (every element; one
/// colour). Returns the first slot whose update was non-finite.
#[allow(clippy::too_many_arguments)]
pub fn project(
    plane: &PlaneAt,
    family: &Family,
    inverse_mass: &[f64],
    alpha_tilde: f64,
    start: &[f64],
    x: &mut [f64],
    lambda: &mut [f64],
) -> Result<(), usize> {
    let FamilyKind::HyperplaneContact { friction, .. } = &family.kind else {
        return Ok(());
    };
    let n = plane.normal.len();
    let normal = &plane.normal[..];
    let mut q = vec![0.0; n];
    for e in 0..family.len() {
        let i = family.elements[e] as usize;
        let w = inverse_mass[i];
        let xi = &mut x[i * n..(i + 1) * n];
        let c = dot(normal, xi) - family.rest[e] - plane.shift;
        lambda[e] = contact_update(c, (lambda[e], w, alpha_tilde), normal, xi).ok_or(e)?;
        if *friction > 0.0 && lambda[e] > 0.0 {
            let p = &start[i * n..(i + 1) * n];
            plane.carry.at(p, &mut q);
            for a in 0..n {
                q[a] += p[a];
            }
            static_friction(normal, friction * w * lambda[e], &q, xi);
        }
    }
    Ok(())
}

/// The Friction kernel of family `family`: `friction.rs` for a static
/// plane, [`friction`] for a moving one (`moving`: the substep's values,
/// start and end positions), `mesh_contact.rs` for a mesh.
pub fn friction_of(
    workers: &Workers,
    plan: &Plan,
    (family, lambda, kept): (usize, &[f64], &mut [Candidates]),
    (now, start, x): (&SubstepMotion, &[f64], &[f64]),
    v: &mut [f64],
) -> Result<(), usize> {
    let f = &plan.families[family];
    if let FamilyKind::MeshContact { mesh, friction } = &f.kind {
        // SAFETY: element e's slot is touched only by e's friction, and
        // each element belongs to one chunk.
        let kept = unsafe { DisjointSlice::new(kept) };
        let mesh = crate::mesh_contact::MeshFriction {
            dim: plan.dim,
            h: plan.h,
            inverse_mass: &plan.inverse_mass,
            family: f,
            mesh: &plan.meshes[*mesh],
            mu: *friction,
            lambda,
            x,
            moving: now.mesh(plan.motion.as_ref(), family).map(|m| (m, start)),
            kept: &kept,
        };
        return crate::mesh_contact::friction(workers, &mesh, v);
    }
    match now.plane(plan.motion.as_ref(), family) {
        Some(moving) => friction(moving, f, (&plan.inverse_mass, plan.h), lambda, start, v),
        None => {
            crate::friction::friction(workers, plan.dim, plan.h, &plan.inverse_mass, f, lambda, v)
        }
    }
}

/// The report's residual of family `family` (`f`): `residual.rs` for
/// every family but a moving plane's, [`residual`] for that, and
/// `mesh_contact.rs`'s for a mesh.
pub fn residual_of(
    workers: &Workers,
    plan: &Plan,
    now: &SubstepMotion,
    family: usize,
    f: &Family,
    x: &[f64],
) -> FamilyResidual {
    if let FamilyKind::MeshContact { mesh, .. } = &f.kind {
        return FamilyResidual {
            label: f.label.clone(),
            max_violation: crate::mesh_contact::residual(
                plan.dim,
                f,
                (&plan.meshes[*mesh], now.mesh(plan.motion.as_ref(), family)),
                x,
            ),
        };
    }
    match now.plane(plan.motion.as_ref(), family) {
        Some(moving) => FamilyResidual {
            label: f.label.clone(),
            max_violation: residual(moving, f, x),
        },
        None => crate::residual::residual(workers, plan.dim, f, x),
    }
}

/// Dynamic friction of moving-plane family `family`; the first particle
/// whose velocity became non-finite.
pub fn friction(
    plane: &PlaneAt,
    family: &Family,
    (inverse_mass, h): (&[f64], f64),
    lambda: &[f64],
    start: &[f64],
    v: &mut [f64],
) -> Result<(), usize> {
    let FamilyKind::HyperplaneContact { friction, .. } = &family.kind else {
        return Ok(());
    };
    let n = plane.normal.len();
    let normal = &plane.normal[..];
    let mut rel = vec![0.0; n];
    for e in 0..family.len() {
        let l = lambda[e];
        if l <= 0.0 {
            continue;
        }
        let i = family.elements[e] as usize;
        let vi = &mut v[i * n..(i + 1) * n];
        let limit = friction * inverse_mass[i] * l / h;
        let p = &start[i * n..(i + 1) * n];
        if crate::friction::carried_friction(normal, &plane.carry, p, (limit, h), &mut rel, vi)
            && !vi.iter().all(|c| c.is_finite())
        {
            return Err(i);
        }
    }
    Ok(())
}

/// max_e max(0, rest + s − n·x) of a moving-plane family.
pub fn residual(plane: &PlaneAt, family: &Family, x: &[f64]) -> f64 {
    let n = plane.normal.len();
    let mut worst: f64 = 0.0;
    for e in 0..family.len() {
        let i = family.elements[e] as usize;
        let gap = dot(&plane.normal, &x[i * n..(i + 1) * n]) - family.rest[e] - plane.shift;
        worst = worst.max(-gap);
    }
    worst
}
