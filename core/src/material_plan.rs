//! The material families of a plan: each family's law and rest shapes,
//! the lumped masses of particles without an authored `mass`, and the
//! per-family mass report `hyperpbd plan` prints.
//!
//! ```text
//! per material family f (authored order):
//!   material    Material::new(law, k, E, ν)               (Lamé per k, docs/materials.md §2)
//!   rest        R_e, V_0(e) from rest_positions or the initial positions
//!   density ρ:  m_i^f = Σ_{e ∋ i} ρ V_0(e) / (k + 1)       (material::lump_masses)
//! mass of particle i:  authored mass, else Σ_f m_i^f (families in authored order)
//! plan family: rest value 0 (the minimum of C = √(2W)), compliance 1,
//!              R and V_0 colour-ordered like the elements
//! ```

use crate::material::{Material, RestShapes, lump_masses};
use crate::validate_material::{material_of, rest_shapes};
use crate::{Family, FamilyKind, Scene, SceneError};

/// The lumped mass of one family with `density`, as `hyperpbd plan`
/// reports it.
#[derive(Debug, Clone, PartialEq)]
pub struct FamilyMass {
    /// `constraints[f]`.
    pub label: String,
    /// ρ.
    pub density: f64,
    /// Σ_e ρ V_0(e).
    pub element_total: f64,
    /// Σ_i of the family's per-vertex shares (equal to the element total
    /// up to rounding; accumulated independently).
    pub vertex_total: f64,
}

/// What the plan needs of a scene's material families.
pub(crate) struct MaterialFamilies {
    /// Per authored constraint family: its material and rest shapes
    /// (`None` for the geometric kinds).
    pub shapes: Vec<Option<(Material, RestShapes)>>,
    /// Lumped mass per particle, summed over the families with density.
    pub lumped: Vec<f64>,
    /// One entry per family with density.
    pub report: Vec<FamilyMass>,
}

/// The material families of a validated `scene`.
pub(crate) fn compile(scene: &Scene) -> Result<MaterialFamilies, SceneError> {
    let n = scene.particles.len();
    let mut out = MaterialFamilies {
        shapes: Vec::with_capacity(scene.constraints.len()),
        lumped: vec![0.0; n],
        report: Vec::new(),
    };
    for (f, family) in scene.constraints.iter().enumerate() {
        if family.kind.law().is_none() {
            out.shapes.push(None);
            continue;
        }
        let label = format!("constraints[{f}]");
        let error = |source| SceneError::Material {
            path: label.clone(),
            source,
        };
        let material = material_of(scene.dim, family).map_err(error)?;
        let shapes = rest_shapes(scene, family).map_err(error)?;
        if let Some(density) = family.density {
            let lumped = lump_masses(n, &family.elements, &shapes, density).map_err(error)?;
            for (total, m) in out.lumped.iter_mut().zip(&lumped.masses) {
                *total += m;
            }
            out.report.push(FamilyMass {
                label: label.clone(),
                density,
                element_total: lumped.element_total,
                vertex_total: lumped.vertex_total,
            });
        }
        out.shapes.push(Some((material, shapes)));
    }
    Ok(out)
}

/// The mass of particle `p` whose lumped mass (from the material families
/// with density) is `lumped`: its authored `mass`, else `lumped`; `None`
/// for a fixed particle. The plan's inverse masses are 1 / this.
pub(crate) fn effective_mass(p: &crate::Particle, lumped: f64) -> Option<f64> {
    match (p.fixed, p.mass) {
        (false, Some(m)) => Some(m),
        (false, None) => Some(lumped),
        _ => None,
    }
}

/// Every particle's mass in a valid `scene`: its authored `mass`, else the
/// lumped mass of the material families with `density`; 0 for a fixed
/// particle. (Metrics and reports that weigh particles use this, so a
/// particle whose mass comes from a density is not left out.)
pub fn particle_masses(scene: &Scene) -> Result<Vec<f64>, SceneError> {
    scene.validate()?;
    let lumped = compile(scene)?.lumped;
    Ok(scene
        .particles
        .iter()
        .zip(lumped)
        .map(|(p, l)| effective_mass(p, l).unwrap_or(0.0))
        .collect())
}

/// `family` (a compiled material family, rest values 0, compliance 1)
/// with its rest frames and measures in its colour order.
pub(crate) fn with_rest_shapes(mut family: Family, shapes: &RestShapes) -> Family {
    let k = shapes.order();
    let mut frames = Vec::with_capacity(family.len() * k * k);
    let mut measures = Vec::with_capacity(family.len());
    for &e in &family.source {
        let rest = shapes.element(e as usize);
        frames.extend_from_slice(rest.frame);
        measures.push(rest.measure);
    }
    if let FamilyKind::Material {
        frames: f,
        measures: m,
        ..
    } = &mut family.kind
    {
        *f = frames;
        *m = measures;
    }
    family
}

/// Why slot `e` (colour order) of the material family `family` fails at
/// positions `x`: the law's refusal of the element there, or `None` when
/// it evaluates (a failure of it was a non-finite value or update) or the
/// family is not a material family. Both backends name a failed material
/// projection with this, at the positions the failing projection saw.
pub fn element_refusal(
    dim: usize,
    family: &crate::Family,
    e: usize,
    x: &[f64],
) -> Option<crate::material::LawRefusal> {
    let (material, rest) = family.kind.rest_view(e)?;
    let arity = family.arity;
    let mut points = vec![0.0; arity * dim];
    for (j, &i) in family
        .elements
        .get(e * arity..(e + 1) * arity)?
        .iter()
        .enumerate()
    {
        let i = i as usize;
        points[j * dim..(j + 1) * dim].copy_from_slice(x.get(i * dim..(i + 1) * dim)?);
    }
    let mut grad = vec![0.0; arity * dim];
    let mut scratch = crate::material::MaterialScratch::new();
    let element = crate::material::MaterialElement {
        material,
        points: &points,
        dim,
        rest,
    };
    crate::material::energy_constraint(element, &mut grad, &mut scratch).err()
}
