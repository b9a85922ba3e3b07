//! Typed errors of the material model: parameters and rest shapes that
//! cannot define a material ([`MaterialError`]), and deformed states outside
//! a law's domain ([`LawRefusal`]).

use thiserror::Error;

/// Material parameters or rest geometry that define no material. The
/// caller adds the scene path (family, element) when it reports one.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum MaterialError {
    /// Young's modulus not finite or ≤ 0.
    #[error("youngs_modulus must be finite and > 0, got {value}")]
    YoungsModulus { value: f64 },
    /// Poisson's ratio outside the open interval where the elasticity
    /// tensor of a k-dimensional material is positive definite.
    #[error(
        "poisson_ratio must be finite with {lower} < ν < {upper} for {order}-simplices, got {value}"
    )]
    PoissonRatio {
        value: f64,
        lower: f64,
        upper: f64,
        order: usize,
    },
    /// Neo-Hookean with ν < 0 (λ < 0): the energy −μ ln J + (λ/2)(ln J)²
    /// is unbounded below as J → 0, so the law has no energy constraint.
    #[error(
        "poisson_ratio {value} < 0 gives the neo_hookean law λ < 0, whose energy is unbounded below as the measure collapses; use ν >= 0"
    )]
    NeoHookeanNegativePoisson { value: f64 },
    /// E and ν whose Lamé parameters overflow.
    #[error(
        "youngs_modulus {youngs_modulus} and poisson_ratio {poisson_ratio} give non-finite Lamé parameters"
    )]
    LameOverflow {
        youngs_modulus: f64,
        poisson_ratio: f64,
    },
    /// Density not finite or ≤ 0.
    #[error("density must be finite and > 0, got {value}")]
    Density { value: f64 },
    /// An element whose simplex order k is not 1 ≤ k ≤ dim.
    #[error("element {element}: {vertices} vertices make no k-simplex with 1 <= k <= dim = {dim}")]
    Order {
        element: usize,
        vertices: usize,
        dim: usize,
    },
    /// An element with a different vertex count from element 0.
    #[error("element {element}: {found} vertices, but element 0 has {expected}")]
    MixedOrder {
        element: usize,
        expected: usize,
        found: usize,
    },
    /// A vertex index naming no particle.
    #[error("element {element}: particle index {index} is out of range ({count} particles)")]
    IndexOutOfRange {
        element: usize,
        index: usize,
        count: usize,
    },
    /// A rest simplex whose k-measure is not above the degeneracy floor
    /// (or whose rest coordinates are not finite).
    #[error(
        "element {element}: rest {order}-measure {measure:e} is not above the degeneracy floor {floor:e}"
    )]
    DegenerateRest {
        element: usize,
        order: usize,
        measure: f64,
        floor: f64,
    },
    /// Elements and rest data of different lengths.
    #[error("{elements} elements but rest data for {rest}")]
    ElementCount { elements: usize, rest: usize },
    /// Flat positions whose length is not a multiple of the dimension.
    #[error("{len} rest coordinates do not split into points of dimension {dim}")]
    PositionsLength { len: usize, dim: usize },
}

/// A deformed element outside the law's domain. Neo-Hookean refuses both;
/// St. Venant–Kirchhoff is defined for every deformation and never refuses.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
#[non_exhaustive]
pub enum LawRefusal {
    /// Measure ratio J = 0 to rounding (or C not positive definite).
    #[error("the element collapsed (measure ratio J = {measure_ratio:e})")]
    Collapsed { measure_ratio: f64 },
    /// Full-dimensional element with J < 0.
    #[error("the element is inverted (measure ratio J = {measure_ratio:e})")]
    Inverted { measure_ratio: f64 },
}

impl LawRefusal {
    /// The element's measure ratio J when it was refused.
    pub fn measure_ratio(&self) -> f64 {
        match *self {
            LawRefusal::Collapsed { measure_ratio } | LawRefusal::Inverted { measure_ratio } => {
                measure_ratio
            }
        }
    }
}
