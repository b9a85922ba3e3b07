//! The scene: what the user authored, before any compilation.
//!
//! A scene is plain data. It is built with [`crate::SceneBuilder`] or loaded
//! from JSON ([`Scene::from_json_str`]), and must pass [`Scene::validate`]
//! before it can be compiled into a [`crate::Plan`]. The serde field names
//! are the JSON keys; unknown keys are rejected.

use serde::{Deserialize, Serialize};

use crate::Solver;
use crate::guard_rules::{Adaptive, Guards};
use crate::motion::Motion;

/// Builder setters: `fn name(mut self, field: T) -> Self` that store
/// `value` (the argument, or `Some` of it) in `self.field`.
macro_rules! setters {
    ($($(#[$doc:meta])* $name:ident($field:ident: $ty:ty) = $value:expr;)*) => {
        $(
            $(#[$doc])*
            pub fn $name(mut self, $field: $ty) -> Self {
                self.$field = $value;
                self
            }
        )*
    };
}

/// Largest dimension a scene may have (`Scene::validate` refuses more).
/// Far beyond any practical scene; it keeps the per-dimension allocations
/// of a plan bounded, so a typo such as `"dim": 4611686018427387904` is an
/// error rather than an abort.
pub const MAX_DIM: usize = 256;

/// A whole scene in R^`dim`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Spatial dimension N ≥ 1.
    pub dim: usize,
    /// Time step of one `step` (seconds).
    pub dt: f64,
    /// Substeps per step; h = dt / substeps.
    #[serde(default = "one")]
    pub substeps: u32,
    /// Projection iterations per substep.
    #[serde(default = "one")]
    pub iterations: u32,
    /// Gravitational acceleration (length `dim`); omitted means none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gravity: Option<Vec<f64>>,
    /// The particles, indexed from 0 in this order.
    #[serde(default)]
    pub particles: Vec<Particle>,
    /// Constraint families, projected in this order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub constraints: Vec<ConstraintFamily>,
    /// Static obstacles; each hyperplane contacts every dynamic particle.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub obstacles: Vec<Obstacle>,
    /// Exponential velocity damping, applied after friction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damping: Option<Damping>,
    /// Particle–particle contact between the particles' balls; omitted
    /// means particles pass through each other.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub collisions: Option<Collisions>,
    /// Solver path; XPBD when omitted.
    #[serde(default, skip_serializing_if = "Solver::is_xpbd")]
    pub solver: Solver,
    /// Read-only checks of every completed substep (`guards.rs`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub guards: Option<Guards>,
    /// Retry a guard-rejected step with more substeps (`adaptive.rs`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub adaptive: Option<Adaptive>,
}

fn one() -> u32 {
    1
}

fn unit() -> f64 {
    1.0
}

/// +0.0 only: a −0.0 is written out so that it round-trips.
fn is_zero(x: &f64) -> bool {
    x.to_bits() == 0
}

fn is_one(x: &f64) -> bool {
    *x == 1.0
}

fn is_false(x: &bool) -> bool {
    !*x
}

/// A point mass.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Particle {
    /// Position (length `dim`).
    pub position: Vec<f64>,
    /// Velocity (length `dim`); omitted means zero.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub velocity: Option<Vec<f64>>,
    /// Mass > 0; required unless `fixed`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mass: Option<f64>,
    /// A fixed particle never moves (inverse mass 0).
    #[serde(default, skip_serializing_if = "is_false")]
    pub fixed: bool,
    /// Radius ≥ 0, used by contacts: the admissible set of a hyperplane is
    /// n·x ≥ offset + radius.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub radius: f64,
    /// Multiplier of the scene gravity for this particle.
    #[serde(default = "unit", skip_serializing_if = "is_one")]
    pub gravity_scale: f64,
    /// Constant external force (length `dim`); omitted means zero.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub force: Option<Vec<f64>>,
    /// Prescribed motion of a fixed particle (an animated pin): its
    /// position at time t is M(t) applied to `position` (`motion.rs`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub motion: Vec<Motion>,
}

impl Particle {
    /// A dynamic particle at rest at `position` with mass `mass`.
    pub fn new(position: Vec<f64>, mass: f64) -> Self {
        Particle {
            position,
            velocity: None,
            mass: Some(mass),
            fixed: false,
            radius: 0.0,
            gravity_scale: 1.0,
            force: None,
            motion: Vec::new(),
        }
    }

    /// A fixed particle at `position`.
    pub fn fixed(position: Vec<f64>) -> Self {
        Particle {
            fixed: true,
            mass: None,
            ..Particle::new(position, 0.0)
        }
    }

    setters! {
        /// Sets the velocity.
        with_velocity(velocity: Vec<f64>) = Some(velocity);
        /// Sets the radius.
        with_radius(radius: f64) = radius;
        /// Sets the constant external force.
        with_force(force: Vec<f64>) = Some(force);
        /// Sets the gravity scale.
        with_gravity_scale(gravity_scale: f64) = gravity_scale;
        /// Sets the prescribed motion (fixed particles only).
        with_motion(motion: Vec<Motion>) = motion;
    }
}

/// Which scalar relation a constraint family imposes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ConstraintKind {
    /// C = |x1 − x0| − rest (2 particles).
    Distance,
    /// C = det(EᵀE)/(k!)² − rest for a k-simplex (k+1 particles, 1 ≤ k ≤ N),
    /// E = [x1−x0 … xk−x0]: the unsigned squared k-measure.
    SimplexMeasure,
    /// C = det([x1−x0 … xN−x0])/N! − rest (N+1 particles): the signed
    /// full-dimensional measure.
    OrientedMeasure,
    /// |x1 − x0| ≤ rest (2 particles): a one-sided distance, a long-range
    /// attachment (tether) that only ever pulls.
    Tether,
    /// St. Venant–Kirchhoff k-simplices (k + 1 particles, 1 ≤ k ≤ N): the
    /// XPBD energy constraint C = √(2W) of the law's element energy W.
    Stvk,
    /// Compressible Neo-Hookean k-simplices, as `Stvk`; an element that
    /// collapses or inverts during a step stops the step (typed refusal).
    NeoHookean,
    /// C = value − rest for a user's `value` expression of the element's
    /// particles `x0 … x{arity−1}` (docs/expressions.md): ∇C is derived.
    Expression,
    /// A fold of two triangles sharing an edge (4 particles, N ≥ 3):
    /// `"model"` cosine (C = −u_A·u_B − rest over the conormals) or
    /// quadratic (C = |Σ_j k_j x_j|, Bergou et al. 2006; kinds/bending.rs).
    Bending,
}

impl ConstraintKind {
    /// JSON name of the kind.
    pub fn as_str(self) -> &'static str {
        match self {
            ConstraintKind::Distance => "distance",
            ConstraintKind::SimplexMeasure => "simplex_measure",
            ConstraintKind::OrientedMeasure => "oriented_measure",
            ConstraintKind::Tether => "tether",
            ConstraintKind::Stvk => "stvk",
            ConstraintKind::NeoHookean => "neo_hookean",
            ConstraintKind::Expression => "expression",
            ConstraintKind::Bending => "bending",
        }
    }

    /// The constitutive law of a material kind (`None` for the geometric
    /// kinds).
    pub fn law(self) -> Option<crate::material::Law> {
        match self {
            ConstraintKind::Stvk => Some(crate::material::Law::StVenantKirchhoff),
            ConstraintKind::NeoHookean => Some(crate::material::Law::NeoHookean),
            ConstraintKind::Distance
            | ConstraintKind::SimplexMeasure
            | ConstraintKind::OrientedMeasure
            | ConstraintKind::Tether
            | ConstraintKind::Expression
            | ConstraintKind::Bending => None,
        }
    }
}

/// One kind, one compliance, many elements. Material kinds (`stvk`,
/// `neo_hookean`) take `youngs_modulus` and `poisson_ratio` instead of a
/// compliance and rest values, and optionally `rest_positions` and
/// `density`; the geometric kinds take none of those four.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstraintFamily {
    /// The relation every element imposes.
    #[serde(rename = "type")]
    pub kind: ConstraintKind,
    /// Compliance α ≥ 0 (inverse stiffness; 0 is rigid).
    #[serde(default)]
    pub compliance: f64,
    /// Particle indices of each element.
    pub elements: Vec<Vec<usize>>,
    /// Rest value per element; omitted means the authored geometry.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rest: Option<Vec<f64>>,
    /// Material kinds: Young's modulus E > 0 of the k-dimensional material.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub youngs_modulus: Option<f64>,
    /// Material kinds: Poisson's ratio ν, −1 < ν < 1/(k − 1) (ν ≥ 0 for
    /// `neo_hookean`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub poisson_ratio: Option<f64>,
    /// Material kinds: the rest shape, one position per scene particle;
    /// omitted means the particles' initial positions.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rest_positions: Option<Vec<Vec<f64>>>,
    /// Material kinds: density ρ > 0; particles without a `mass` then take
    /// lumped masses ρ·V_0/(k + 1) from every element they belong to.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub density: Option<f64>,
    /// Expression families: the value, e.g. `"let d = x1 - x0; norm(d)"`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub value: Option<String>,
    /// Expression families: named constants, each a number or an N-vector
    /// (authored order kept).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub params: Option<serde_json::Map<String, serde_json::Value>>,
    /// Expression families: `"=="` (default), `">="` or `"<="`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub relation: Option<crate::kinds::Relation>,
    /// Bending families: `"cosine"` (default) or `"quadratic"`
    /// (kinds/bending.rs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<crate::kinds::BendingModel>,
}

impl ConstraintFamily {
    /// A family with rest values taken from the authored geometry.
    pub fn new(kind: ConstraintKind, compliance: f64, elements: Vec<Vec<usize>>) -> Self {
        ConstraintFamily {
            kind,
            compliance,
            elements,
            rest: None,
            youngs_modulus: None,
            poisson_ratio: None,
            rest_positions: None,
            density: None,
            value: None,
            params: None,
            relation: None,
            model: None,
        }
    }

    /// An expression family: C = `value` − rest over `elements` (rest from
    /// the authored geometry, relation `==`, no params).
    pub fn expression(value: &str, compliance: f64, elements: Vec<Vec<usize>>) -> Self {
        ConstraintFamily {
            value: Some(value.into()),
            ..ConstraintFamily::new(ConstraintKind::Expression, compliance, elements)
        }
    }

    /// A material family (`kind` `Stvk` or `NeoHookean`) with Young's
    /// modulus E and Poisson's ratio ν, rest shape the initial positions,
    /// no density.
    pub fn material(
        kind: ConstraintKind,
        youngs_modulus: f64,
        poisson_ratio: f64,
        elements: Vec<Vec<usize>>,
    ) -> Self {
        ConstraintFamily {
            youngs_modulus: Some(youngs_modulus),
            poisson_ratio: Some(poisson_ratio),
            ..ConstraintFamily::new(kind, 0.0, elements)
        }
    }

    setters! {
        /// Sets the rest shape (one position per scene particle).
        with_rest_positions(rest_positions: Vec<Vec<f64>>) = Some(rest_positions);
        /// Sets the density (lumped mass for particles without `mass`).
        with_density(density: f64) = Some(density);
        /// Sets an expression family's relation.
        with_relation(relation: crate::kinds::Relation) = Some(relation);
        /// Sets a bending family's model.
        with_model(model: crate::kinds::BendingModel) = Some(model);
    }
}

/// A static obstacle.
///
/// Read through [`ObstacleDocument`], a plain struct, rather than as an
/// internally tagged enum: serde buffers a tagged enum before it knows the
/// variant, which would cut the error path at `obstacles[i]` instead of
/// naming the field. The document also holds the defaults (an omitted
/// offset, friction or compliance is 0).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", try_from = "ObstacleDocument")]
pub enum Obstacle {
    /// The half-space n·x ≥ offset (+ particle radius) is admissible.
    Hyperplane {
        /// Outward normal; normalized on load (need not be unit here).
        normal: Vec<f64>,
        /// Offset along the normalized normal.
        offset: f64,
        /// Coulomb friction coefficient μ ≥ 0 (static and dynamic).
        friction: f64,
        /// Contact compliance α ≥ 0.
        compliance: f64,
        /// Prescribed motion (`motion.rs`); empty: static.
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        motion: Vec<Motion>,
    },
    /// A mesh of k-simplices (segments, triangles, tetrahedra: k = 1, 2,
    /// 3) in R^N: a contact inequality dist(x, mesh) − radius ≥ 0 on the
    /// XPBD path (`kinds/mesh_contact.rs`), a barrier on the implicit
    /// paths. Static, or moving rigidly with a `motion` (XPBD path:
    /// `moving_mesh.rs`).
    SimplexMesh {
        /// Vertex positions (each of length `dim`).
        vertices: Vec<Vec<f64>>,
        /// Vertex indices per simplex; all simplices of a mesh have the
        /// same arity 2, 3 or 4.
        simplices: Vec<Vec<usize>>,
        /// Coulomb friction coefficient μ ≥ 0 of every simplex of the mesh
        /// (the implicit path's lagged friction; 0: frictionless).
        #[serde(default, skip_serializing_if = "is_zero")]
        friction: f64,
        /// Prescribed rigid motion (`motion.rs`); empty: static.
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        motion: Vec<Motion>,
    },
}

impl Obstacle {
    /// The Coulomb friction coefficient μ of the obstacle's contacts.
    pub fn friction(&self) -> f64 {
        match self {
            Obstacle::Hyperplane { friction, .. } | Obstacle::SimplexMesh { friction, .. } => {
                *friction
            }
        }
    }

    /// The obstacle's prescribed motion (empty: static).
    pub fn motion(&self) -> &[Motion] {
        match self {
            Obstacle::Hyperplane { motion, .. } | Obstacle::SimplexMesh { motion, .. } => motion,
        }
    }
}

/// Obstacle kinds as written in JSON.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObstacleKind {
    /// `"type": "hyperplane"`.
    Hyperplane,
    /// `"type": "simplex_mesh"`.
    SimplexMesh,
}

/// The JSON form of an obstacle: every key any kind may use, checked
/// against the kind by `TryFrom`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObstacleDocument {
    #[serde(rename = "type")]
    kind: ObstacleKind,
    normal: Option<Vec<f64>>,
    #[serde(default)]
    offset: f64,
    #[serde(default)]
    friction: f64,
    #[serde(default)]
    compliance: f64,
    vertices: Option<Vec<Vec<f64>>>,
    simplices: Option<Vec<Vec<usize>>>,
    #[serde(default)]
    motion: Vec<Motion>,
}

impl TryFrom<ObstacleDocument> for Obstacle {
    type Error = String;

    fn try_from(doc: ObstacleDocument) -> Result<Self, String> {
        match doc.kind {
            ObstacleKind::Hyperplane => {
                if doc.vertices.is_some() || doc.simplices.is_some() {
                    return Err("a hyperplane takes no `vertices` or `simplices`".into());
                }
                Ok(Obstacle::Hyperplane {
                    normal: doc.normal.ok_or("missing field `normal`")?,
                    offset: doc.offset,
                    friction: doc.friction,
                    compliance: doc.compliance,
                    motion: doc.motion,
                })
            }
            ObstacleKind::SimplexMesh => {
                if doc.normal.is_some() {
                    return Err("unknown field `normal` for a simplex_mesh".into());
                }
                if doc.offset != 0.0 || doc.compliance != 0.0 {
                    return Err(
                        "a simplex_mesh takes only `vertices`, `simplices` and `friction` (no offset or compliance)"
                            .into(),
                    );
                }
                Ok(Obstacle::SimplexMesh {
                    vertices: doc.vertices.ok_or("missing field `vertices`")?,
                    simplices: doc.simplices.ok_or("missing field `simplices`")?,
                    friction: doc.friction,
                    motion: doc.motion,
                })
            }
        }
    }
}

/// Timestep-invariant exponential velocity damping: v ← v·exp(−rate·h).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Damping {
    /// Decay rate in 1/s (≥ 0).
    pub rate: f64,
}

/// Particle–particle contact: |x_i − x_j| ≥ r_i + r_j for every pair of
/// particles (not both fixed), found by the broadphase each substep.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Collisions {
    /// Coulomb coefficient μ ≥ 0 between particles (0: frictionless).
    #[serde(default)]
    pub friction: f64,
    /// Box margin m ≥ 0 added to every radius in the broadphase, so that
    /// contacts reached by the corrections within a substep are candidates.
    #[serde(default)]
    pub margin: f64,
}

impl Scene {
    /// An empty scene in R^dim with the given step settings and no gravity.
    pub fn new(dim: usize, dt: f64, substeps: u32, iterations: u32) -> Self {
        Scene {
            dim,
            dt,
            substeps,
            iterations,
            gravity: None,
            particles: Vec::new(),
            constraints: Vec::new(),
            obstacles: Vec::new(),
            damping: None,
            collisions: None,
            solver: Solver::default(),
            guards: None,
            adaptive: None,
        }
    }

    /// The largest distance between any particle and the first one — a
    /// length scale for relative error measures (1 if there are fewer than
    /// two particles or all coincide).
    pub fn extent(&self) -> f64 {
        let Some(first) = self.particles.first() else {
            return 1.0;
        };
        let mut extent: f64 = 0.0;
        for p in &self.particles {
            let d2: f64 = p
                .position
                .iter()
                .zip(&first.position)
                .map(|(a, b)| (a - b) * (a - b))
                .sum();
            extent = extent.max(d2.sqrt());
        }
        if extent > 0.0 { extent } else { 1.0 }
    }
}
