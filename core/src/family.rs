//! A compiled constraint family: what its elements project and their
//! colour-ordered data, as the plan holds it and the kernels read it.

use crate::material::{Law, Material, MaterialElement, RestView};

/// What one family projects.
#[derive(Debug, Clone, PartialEq)]
pub enum FamilyKind {
    /// |x1 − x0| = rest.
    Distance,
    /// det(EᵀE)/(k!)² = rest for k-simplices.
    SimplexMeasure {
        /// Simplex order k (k + 1 particles per element).
        k: usize,
    },
    /// det([x1−x0 … xN−x0])/N! = rest.
    OrientedMeasure,
    /// |x1 − x0| ≤ rest: one-sided distance (λ ≤ 0, it only pulls).
    Tether,
    /// Hyperelastic k-simplices: the energy constraint C = √(2W) ≥ 0 of
    /// the law (docs/materials.md §5), rest value 0, compliance 1.
    Material {
        /// The law and its Lamé parameters.
        material: Material,
        /// Simplex order k (k + 1 particles per element).
        order: usize,
        /// Rest frame R per (colour-ordered) element, k × k each.
        frames: Vec<f64>,
        /// Rest k-measure V_0 per (colour-ordered) element.
        measures: Vec<f64>,
    },
    /// n·x − rest ≥ 0 with rest = offset + radius, per dynamic particle.
    HyperplaneContact {
        /// Unit normal.
        normal: Vec<f64>,
        /// Coulomb coefficient μ (static in the projection, dynamic as a
        /// velocity response).
        friction: f64,
    },
    /// |x − q| − rest ≥ 0 with q the closest point of a simplex mesh and
    /// rest = radius, per dynamic particle (kinds/mesh_contact.rs).
    MeshContact {
        /// The mesh: its index in `Plan::meshes` (its simplices and their
        /// hierarchy; held by the plan, so that this file does not depend
        /// on the barrier's).
        mesh: usize,
        /// Coulomb coefficient μ (as [`FamilyKind::HyperplaneContact`]).
        friction: f64,
    },
    /// C = value − rest of a user's expression (kinds/expression.rs).
    Expression(std::sync::Arc<crate::kinds::ExpressionKind>),
}

impl FamilyKind {
    /// Short name as printed by `hyperpbd plan`.
    pub fn name(&self) -> &'static str {
        match self {
            FamilyKind::Distance => "distance",
            FamilyKind::SimplexMeasure { .. } => "simplex_measure",
            FamilyKind::OrientedMeasure => "oriented_measure",
            FamilyKind::Tether => "tether",
            FamilyKind::Material { material, .. } => match material.law {
                Law::StVenantKirchhoff => "stvk",
                Law::NeoHookean => "neo_hookean",
            },
            FamilyKind::HyperplaneContact { .. } => "hyperplane_contact",
            FamilyKind::MeshContact { .. } => "mesh_contact",
            FamilyKind::Expression(kind) => kind.name,
        }
    }

    /// The compiled expression of an expression family; `None` for other
    /// kinds.
    pub fn expression(&self) -> Option<&crate::kinds::ExpressionKind> {
        let FamilyKind::Expression(kind) = self else {
            return None;
        };
        Some(kind)
    }

    /// The law of a material family; `None` for other kinds.
    pub fn material(&self) -> Option<&Material> {
        let FamilyKind::Material { material, .. } = self else {
            return None;
        };
        Some(material)
    }

    /// The rest data of element `e` (colour-ordered slot) of a material
    /// family; `None` for other kinds.
    pub fn rest_view(&self, e: usize) -> Option<(&Material, RestView<'_>)> {
        let FamilyKind::Material {
            material,
            order,
            frames,
            measures,
        } = self
        else {
            return None;
        };
        let kk = order * order;
        Some((
            material,
            RestView {
                frame: frames.get(e * kk..(e + 1) * kk)?,
                measure: *measures.get(e)?,
            },
        ))
    }

    /// Element `e` of a material family at its gathered `points`; `None`
    /// for other kinds.
    pub fn material_element<'a>(
        &'a self,
        e: usize,
        points: &'a [f64],
        dim: usize,
    ) -> Option<MaterialElement<'a>> {
        let (material, rest) = self.rest_view(e)?;
        Some(MaterialElement {
            material,
            points,
            dim,
            rest,
        })
    }

    /// True for a material family (stvk, neo_hookean).
    pub fn is_material(&self) -> bool {
        matches!(self, FamilyKind::Material { .. })
    }

    /// True for an expression family.
    pub fn is_expression(&self) -> bool {
        matches!(self, FamilyKind::Expression(_))
    }

    /// True for contact families (inequality C ≥ 0 whose active elements
    /// are counted as contacts). Tethers are one-sided too but are not
    /// contacts.
    pub fn is_inequality(&self) -> bool {
        matches!(
            self,
            FamilyKind::HyperplaneContact { .. } | FamilyKind::MeshContact { .. }
        )
    }

    /// The Coulomb coefficient μ of a contact family (0 for other kinds).
    pub fn contact_friction(&self) -> f64 {
        match self {
            FamilyKind::HyperplaneContact { friction, .. }
            | FamilyKind::MeshContact { friction, .. } => *friction,
            FamilyKind::Distance
            | FamilyKind::SimplexMeasure { .. }
            | FamilyKind::OrientedMeasure
            | FamilyKind::Tether
            | FamilyKind::Material { .. }
            | FamilyKind::Expression(_) => 0.0,
        }
    }
}

/// One compiled family: elements reordered color by color (authored order
/// within a color).
#[derive(Debug, Clone, PartialEq)]
pub struct Family {
    /// Where it came from: `constraints[2]` or `obstacles[0]`.
    pub label: String,
    /// The relation.
    pub kind: FamilyKind,
    /// Compliance α ≥ 0.
    pub compliance: f64,
    /// Particles per element.
    pub arity: usize,
    /// Particle indices, `arity` per element, color-ordered.
    pub elements: Vec<u32>,
    /// Rest value per (color-ordered) element.
    pub rest: Vec<f64>,
    /// Authored element index per (color-ordered) element.
    pub source: Vec<u32>,
    /// Elements of color c are `color_starts[c]..color_starts[c + 1]`.
    pub color_starts: Vec<usize>,
}

impl Family {
    /// Number of elements.
    pub fn len(&self) -> usize {
        self.rest.len()
    }

    /// True for a family without elements.
    pub fn is_empty(&self) -> bool {
        self.rest.is_empty()
    }

    /// The authored element index of (colour-ordered) slot `slot` (the
    /// slot itself past the end, so an error can always name something).
    pub fn authored_element(&self, slot: usize) -> usize {
        self.source.get(slot).map_or(slot, |&s| s as usize)
    }

    /// α~ = α / h², the compliance in the units of the XPBD update at
    /// substep length `h` (every backend takes it from here).
    pub fn alpha_tilde(&self, h: f64) -> f64 {
        self.compliance / (h * h)
    }

    /// Number of colors.
    pub fn color_count(&self) -> usize {
        self.color_starts.len().saturating_sub(1)
    }

    /// Element range of color `c`.
    pub fn color(&self, c: usize) -> std::ops::Range<usize> {
        self.color_starts[c]..self.color_starts[c + 1]
    }
}
