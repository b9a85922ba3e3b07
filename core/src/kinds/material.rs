//! Material kinds (`stvk`, `neo_hookean`): hyperelastic k-simplices (k + 1
//! particles, 1 ≤ k ≤ N) as the XPBD energy constraint C = √(2W) ≥ 0 of
//! the law's element energy W (docs/materials.md §5), rest value 0,
//! compliance 1. The law, its measures and rest frames live in
//! `crate::material`; validation of their keys in `validate_material.rs`.

use super::Arity;
use super::relation::Relation;
use crate::FamilyKind;
use crate::material::Material;

pub(super) const ARITY: Arity = Arity::Simplex;
/// C = √(2W) ≥ 0 is projected towards its rest value 0 with λ free.
pub(super) const RELATION: Relation = Relation::Equal;

/// The rest value: 0 with ∇C = 0 (the minimum of √(2W)).
pub(super) fn rest_value(grad: &mut [f64]) -> f64 {
    grad.fill(0.0);
    0.0
}

pub(super) fn family_kind(material: Material, arity: usize) -> FamilyKind {
    FamilyKind::Material {
        material,
        order: arity - 1,
        frames: Vec::new(),
        measures: Vec::new(),
    }
}
