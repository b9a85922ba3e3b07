//! The constraint force of the current iterate, ∇C(x)ᵀλ, per particle: the
//! term whose mismatch with M(x − x~) is XPBD's primal residual.
//!
//! ```text
//! q_i = Σ_{elements e ∋ i} ∇_i C_e(x) λ_e        (family order, slot order;
//!                                                 dynamic particles only)
//! g_i = m_i (x_i − x~_i) − q_i                   (Macklin et al. 2016, eq. 17)
//! ```
//! Standard XPBD assumes g = 0 when it projects (eq. 18); at its fixed
//! point on a stressed material g is not 0 (docs/equilibria.md, measured
//! by `cargo run --release --example patch_residual`). λ is in the backend's units (force · h²), so q / h²
//! is a force; at backward Euler's equilibrium (λ = −C/α~, α~ = 1/h² for
//! materials) it is [`elastic_force`]. Used by that measurement and by the
//! tests; not by a step.

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use crate::project::{Workspace, gathered_value};
use hyperpbd_core::kinds::mesh_contact;
use hyperpbd_core::material::{MaterialScratch, energy_constraint};
use hyperpbd_core::{Family, FamilyKind, Plan};

/// q = ∇C(x)ᵀλ (module docs), `plan.dim` values per particle; fixed
/// particles get 0. `multipliers[f]` holds family f's λ per colour-ordered
/// slot (what [`CpuBackend::multipliers`](crate::CpuBackend::multipliers)
/// returns). Err names the family and slot whose value was not finite (or
/// whose material element was refused).
pub fn constraint_force(
    plan: &Plan,
    x: &[f64],
    multipliers: &[&[f64]],
) -> Result<Vec<f64>, (usize, usize)> {
    let mut force = vec![0.0; x.len()];
    let mut ws = Workspace::default();
    for (f, family) in plan.families.iter().enumerate() {
        accumulate(plan, family, x, multipliers[f], &mut force, &mut ws)
            .map_err(|slot| (f, slot))?;
    }
    Ok(force)
}

/// The elastic force −∇W(x) of the material families, per particle (fixed
/// particles 0): [`constraint_force`] with λ_e = −C_e, C = √(2W) (then
/// Σ_e ∇C_e λ_e = −Σ_e ∇W_e). Other families contribute nothing. Err names
/// the family and slot of an element the law refuses.
pub fn elastic_force(plan: &Plan, x: &[f64]) -> Result<Vec<f64>, (usize, usize)> {
    let (dim, mut scratch) = (plan.dim, MaterialScratch::default());
    let mut multipliers = Vec::with_capacity(plan.families.len());
    for (f, family) in plan.families.iter().enumerate() {
        let arity = family.arity;
        let (mut points, mut grad) = (vec![0.0; arity * dim], vec![0.0; arity * dim]);
        let mut lambda = vec![0.0; family.len()];
        for (e, l) in lambda.iter_mut().enumerate() {
            for (j, &i) in family.elements[e * arity..(e + 1) * arity]
                .iter()
                .enumerate()
            {
                let i = i as usize;
                points[j * dim..(j + 1) * dim].copy_from_slice(&x[i * dim..(i + 1) * dim]);
            }
            if let Some(element) = family.kind.material_element(e, &points, dim) {
                *l = -energy_constraint(element, &mut grad, &mut scratch).map_err(|_| (f, e))?;
            }
        }
        multipliers.push(lambda);
    }
    let multipliers: Vec<&[f64]> = multipliers.iter().map(Vec::as_slice).collect();
    constraint_force(plan, x, &multipliers)
}

/// q += ∇C(x)ᵀλ over the slots of `family`, in order.
fn accumulate(
    plan: &Plan,
    family: &Family,
    x: &[f64],
    lambda: &[f64],
    force: &mut [f64],
    ws: &mut Workspace,
) -> Result<(), usize> {
    let (dim, arity) = (plan.dim, family.arity);
    let w = &plan.inverse_mass;
    if let FamilyKind::Expression(kind) = &family.kind {
        kind.gradient_slots(dim, &family.elements, 0..family.len(), x, &mut ws.columns);
    }
    ws.points.resize(arity * dim, 0.0);
    ws.grad.resize(arity * dim, 0.0);
    for e in 0..family.len() {
        let element = &family.elements[e * arity..(e + 1) * arity];
        let value = match &family.kind {
            FamilyKind::HyperplaneContact { normal, .. } => {
                let i = element[0] as usize;
                ws.grad[..dim].copy_from_slice(&normal[..dim]);
                (0..dim).map(|a| normal[a] * x[i * dim + a]).sum()
            }
            // ∇C = n where the contact is within reach w λ; else no term.
            FamilyKind::MeshContact { mesh, .. } => {
                let i = element[0] as usize;
                let (xi, reach) = (&x[i * dim..(i + 1) * dim], w[i] * lambda[e]);
                let mesh = &plan.meshes[*mesh];
                let closest = mesh_contact::closest(mesh, xi, 0.0, reach, &mut ws.grad[..dim]);
                closest.unwrap_or_else(|| {
                    ws.grad[..dim].fill(0.0);
                    0.0
                })
            }
            FamilyKind::Expression(kind) => {
                for (k, &slot) in kind.gradient.gradient.iter().enumerate() {
                    ws.grad[k] = ws.columns.column(slot)[e];
                }
                ws.columns.column(kind.gradient.value)[e]
            }
            FamilyKind::Distance
            | FamilyKind::Tether
            | FamilyKind::SimplexMeasure { .. }
            | FamilyKind::OrientedMeasure
            | FamilyKind::Material { .. } => {
                for (j, &i) in element.iter().enumerate() {
                    let i = i as usize;
                    ws.points[j * dim..(j + 1) * dim].copy_from_slice(&x[i * dim..(i + 1) * dim]);
                }
                gathered_value(family, e, dim, ws)?
            }
        };
        if !value.is_finite() {
            return Err(e);
        }
        for (j, &i) in element.iter().enumerate() {
            let i = i as usize;
            if w[i] == 0.0 {
                continue;
            }
            for a in 0..dim {
                force[i * dim + a] += ws.grad[j * dim + a] * lambda[e];
            }
        }
    }
    Ok(())
}
