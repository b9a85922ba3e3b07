//! The deformation measures of one element, for reports, guards and tests
//! (the laws use the same C and J through deformation.rs, not this
//! allocating summary).
//!
//! ```text
//! C = F̂ᵀF̂,  E = ½ (C − I)                      (orthonormal rest frame)
//! C = V diag(λ_i²) Vᵀ                           (geometry::symmetric_eigen, ascending)
//! principal stretches λ_i = √max(λ_i², 0)       (C ⪰ 0; rounding may dip below 0)
//! J = det F̂ (k = N, signed),  Π L_jj of C = L Lᵀ (k < N, 0 when C is singular)
//! ```

use super::deformation::{deform, ratio_and_factor};
use super::{MaterialScratch, RestView};
use crate::geometry::{SymmetricEigen, symmetric_eigen};

/// C, E, stretches and J of one element, in its orthonormal rest frame.
#[derive(Debug, Clone, PartialEq)]
pub struct DeformationMeasures {
    /// k.
    pub order: usize,
    /// C = F̂ᵀF̂ (k × k, row-major).
    pub right_cauchy_green: Vec<f64>,
    /// E = ½ (C − I) (k × k, row-major).
    pub green_strain: Vec<f64>,
    /// Principal stretches, ascending.
    pub principal_stretches: Vec<f64>,
    /// Principal directions in the rest frame: column i (of k × k,
    /// row-major) belongs to stretch i.
    pub principal_directions: Vec<f64>,
    /// J: signed for k = N, ≥ 0 for k < N.
    pub measure_ratio: f64,
    /// Whether `measure_ratio` carries an orientation (k = N).
    pub signed: bool,
    /// Evidence of the eigen-decomposition of C.
    pub eigen: SymmetricEigen,
}

/// The measures of the simplex `points` (k + 1 points of length `dim`)
/// against its rest data.
pub fn deformation_measures(
    points: &[f64],
    dim: usize,
    rest: RestView<'_>,
    scratch: &mut MaterialScratch,
) -> DeformationMeasures {
    let k = deform(points, dim, rest.frame, scratch);
    let (measure_ratio, _) = ratio_and_factor(k, dim, scratch);
    let right_cauchy_green = scratch.cauchy_green[..k * k].to_vec();
    let mut green_strain = right_cauchy_green.clone();
    for i in 0..k {
        for j in 0..k {
            let delta = if i == j { 1.0 } else { 0.0 };
            green_strain[i * k + j] = 0.5 * (right_cauchy_green[i * k + j] - delta);
        }
    }
    let mut work = right_cauchy_green.clone();
    let mut squares = vec![0.0; k];
    let mut principal_directions = vec![0.0; k * k];
    let eigen = symmetric_eigen(&mut work, k, &mut squares, &mut principal_directions);
    let principal_stretches = squares.iter().map(|&q| q.max(0.0).sqrt()).collect();
    DeformationMeasures {
        order: k,
        right_cauchy_green,
        green_strain,
        principal_stretches,
        principal_directions,
        measure_ratio,
        signed: k == dim,
        eigen,
    }
}
