//! The rules of the material families (`"type": "stvk" | "neo_hookean"`),
//! checked by `Scene::validate` after the rules every family shares
//! (arity 2..=dim + 1, one k per family, indices in range and distinct).
//!
//! ```text
//! keys         youngs_modulus and poisson_ratio required; no compliance
//!              (α = 1: the stiffness is E, ν) and no rest values
//! material     Material::new(law, k, E, ν): E finite > 0, −1 < ν < 1/(k − 1),
//!              neo_hookean also ν ≥ 0 (docs/materials.md §2)
//! density      finite > 0 when given
//! rest shape   rest_positions (one per scene particle, each of length dim,
//!              finite) or the initial positions; every rest simplex above
//!              the degeneracy floor V_0 > 10⁻¹² ℓ^k / k!  (material::rest)
//! mass         a dynamic particle without `mass` must belong to an element
//!              of a family with `density` (it takes the lumped mass)
//! ```
//! Errors name the field: `constraints[2].poisson_ratio`,
//! `constraints[2].rest_positions[7][1]`, `constraints[2].elements[5]`.

use crate::material::{Material, MaterialError, RestShapes};
use crate::{ConstraintFamily, ConstraintKind, Scene, SceneError};

impl Scene {
    /// The keys of family `f`: material keys only on material kinds, and
    /// no compliance or rest values on them.
    pub(crate) fn validate_family_keys(
        &self,
        f: usize,
        family: &ConstraintFamily,
    ) -> Result<(), SceneError> {
        let at = |field: &str| format!("constraints[{f}].{field}");
        let kind = family.kind.as_str();
        let not_for = |field: &str, why: &str| SceneError::FieldNotForKind {
            path: at(field),
            kind,
            why: why.into(),
        };
        let expression_keys = [
            ("value", family.value.is_some()),
            ("params", family.params.is_some()),
            ("relation", family.relation.is_some()),
        ];
        if family.kind != ConstraintKind::Expression
            && let Some((field, _)) = expression_keys.iter().find(|(_, given)| *given)
        {
            return Err(not_for(field, "only expression families take it"));
        }
        if family.kind != ConstraintKind::Bending && family.model.is_some() {
            return Err(not_for("model", "only bending families take it"));
        }
        if family.kind.law().is_none() {
            let material_keys = [
                ("youngs_modulus", family.youngs_modulus.is_some()),
                ("poisson_ratio", family.poisson_ratio.is_some()),
                ("rest_positions", family.rest_positions.is_some()),
                ("density", family.density.is_some()),
            ];
            if let Some((field, _)) = material_keys.iter().find(|(_, given)| *given) {
                return Err(not_for(field, "only stvk and neo_hookean families take it"));
            }
            return Ok(());
        }
        if family.compliance.to_bits() != 0 {
            return Err(not_for(
                "compliance",
                "a material's stiffness is youngs_modulus and poisson_ratio (its energy \
                 constraint has compliance 1)",
            ));
        }
        if family.rest.is_some() {
            return Err(not_for(
                "rest",
                "a material's rest shape is rest_positions (or the initial positions)",
            ));
        }
        for (field, given) in [
            ("youngs_modulus", family.youngs_modulus.is_some()),
            ("poisson_ratio", family.poisson_ratio.is_some()),
        ] {
            if !given {
                return Err(SceneError::MissingField {
                    path: at(field),
                    kind,
                });
            }
        }
        Ok(())
    }

    /// The material, density and rest shape of family `f` (a material
    /// kind whose elements passed the shared rules).
    pub(crate) fn validate_material(
        &self,
        f: usize,
        family: &ConstraintFamily,
    ) -> Result<(), SceneError> {
        let at = |field: &str| format!("constraints[{f}].{field}");
        let material_error = |field: &str, source: MaterialError| SceneError::Material {
            path: at(field),
            source,
        };
        material_of(self.dim, family).map_err(|e| match e {
            MaterialError::PoissonRatio { .. }
            | MaterialError::NeoHookeanNegativePoisson { .. } => material_error("poisson_ratio", e),
            _ => material_error("youngs_modulus", e),
        })?;
        if let Some(density) = family.density
            && !(density.is_finite() && density > 0.0)
        {
            return Err(material_error(
                "density",
                MaterialError::Density { value: density },
            ));
        }
        if let Some(rest) = &family.rest_positions {
            if rest.len() != self.particles.len() {
                return Err(SceneError::RestPositionsCount {
                    path: at("rest_positions"),
                    expected: self.particles.len(),
                    found: rest.len(),
                });
            }
            for (i, position) in rest.iter().enumerate() {
                crate::validate::vector(&at(&format!("rest_positions[{i}]")), position, self.dim)?;
            }
        }
        rest_shapes(self, family).map_err(|e| match e {
            MaterialError::DegenerateRest {
                element,
                order,
                measure,
                floor,
            } => SceneError::DegenerateRest {
                path: at(&format!("elements[{element}]")),
                why: format!(
                    "the rest {order}-simplex has measure {measure:e}, not above the degeneracy \
                     floor {floor:e}"
                ),
            },
            other => material_error("elements", other),
        })?;
        Ok(())
    }

    /// Which particles belong to an element of a family with `density`
    /// (and so may omit `mass`). Indices out of range are skipped here;
    /// the constraint rules report them.
    pub(crate) fn lumped_particles(&self) -> Vec<bool> {
        let mut lumped = vec![false; self.particles.len()];
        for family in self.constraints.iter().filter(|f| f.density.is_some()) {
            for &i in family.elements.iter().flatten() {
                if let Some(l) = lumped.get_mut(i) {
                    *l = true;
                }
            }
        }
        lumped
    }
}

/// The material of a material family: its law, order k (from element 0;
/// `dim` for a family without elements), E and ν.
pub(crate) fn material_of(
    dim: usize,
    family: &ConstraintFamily,
) -> Result<Material, MaterialError> {
    let law = family.kind.law().ok_or(MaterialError::Order {
        element: 0,
        vertices: 0,
        dim,
    })?;
    let order = family.elements.first().map_or(dim + 1, Vec::len) - 1;
    Material::new(
        law,
        order,
        family.youngs_modulus.unwrap_or(f64::NAN),
        family.poisson_ratio.unwrap_or(f64::NAN),
    )
}

/// The rest shapes of a material family's elements, in authored order:
/// from `rest_positions`, else from the particles' initial positions.
pub(crate) fn rest_shapes(
    scene: &Scene,
    family: &ConstraintFamily,
) -> Result<RestShapes, MaterialError> {
    let positions: Vec<f64> = match &family.rest_positions {
        Some(rest) => rest.iter().flatten().copied().collect(),
        None => scene
            .particles
            .iter()
            .flat_map(|p| p.position.iter().copied())
            .collect(),
    };
    RestShapes::compile(scene.dim, &family.elements, &positions)
}
