//! Constraint functions C(x) and their gradients ∇C, shared by every backend
//! and by validation (rest values, degenerate-geometry checks).
//!
//! Each evaluator takes the element's points gathered into one flat slice
//! (`points[j * dim + a]` is coordinate `a` of point `j`) and writes the
//! gradient with respect to every point into `grad` with the same layout.
//! Where ∇C vanishes (coincident points, a collapsed simplex) the gradient is
//! zero and the projection reports no response rather than inventing a
//! direction.

mod closest_point;
mod distance;
mod edges;
mod linalg;
mod oriented_measure;
mod overlap;
pub mod simplex_hierarchy;
mod simplex_measure;
mod symmetric_eigen;

use crate::kinds::ProjectionReal;

pub use closest_point::{ClosestPoint, MAX_SIMPLEX_ORDER, closest_point_on_simplex};
pub use distance::distance;
pub use edges::{edge_matrix, gram, scatter_edge_gradient, sum_of_products};
pub use linalg::{adjugate, determinant, separation, unit_vector};
pub use oriented_measure::{oriented_measure, oriented_volume};
pub use overlap::{deepest_overlap, overlap};
pub use simplex_hierarchy::SimplexHierarchy;
pub use simplex_measure::simplex_squared_measure;
pub use symmetric_eigen::{MAX_SWEEPS, SymmetricEigen, symmetric_eigen};

/// Reusable scratch space so evaluation allocates nothing per element, in
/// precision `R` (f64: the golden path; f32: the f32 reference).
#[derive(Debug, Default, Clone)]
pub struct Scratch<R = f64> {
    pub(crate) edges: Vec<R>,
    pub(crate) gram: Vec<R>,
    pub(crate) adj: Vec<R>,
    pub(crate) minor: Vec<R>,
    /// An expression's columns (its value at one element).
    pub(crate) columns: crate::expr::Columns<R>,
}

impl Scratch {
    /// Empty scratch; buffers grow on first use.
    pub fn new() -> Self {
        Scratch::default()
    }
}

/// Relative volume below which an oriented rest simplex counts as
/// degenerate: |V| ≤ 1e-12 · (longest edge)^N / N!. Below that the
/// constraint has no meaningful orientation to preserve.
pub const DEGENERATE_VOLUME_RATIO: f64 = 1e-12;

/// Factorial as f64 (exact up to 18!).
pub fn factorial(k: usize) -> f64 {
    factorial_in(k)
}

/// k! accumulated in precision `R` from 1, factor by factor (f32: as
/// `measure.wgsl`; f64: [`factorial`]).
pub(crate) fn factorial_in<R: ProjectionReal>(k: usize) -> R {
    (1..=k).fold(R::constant(1.0), |acc, i| acc * R::constant(i as f64))
}
