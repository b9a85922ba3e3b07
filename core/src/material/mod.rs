//! Hyperelastic simplices in R^N: deformation measures, the St. Venant–
//! Kirchhoff and compressible Neo-Hookean laws, their energy and vertex
//! gradients, the XPBD energy constraint, and lumped mass from density —
//! one source for every backend (the CPU kernel calls these functions; the
//! WGSL kernel repeats their arithmetic in the same order).
//!
//! A k-simplex (k + 1 vertices) lives in R^N with 1 ≤ k ≤ N: k = N is a
//! full-dimensional solid, k < N an embedded curve, membrane, … measured
//! through its intrinsic edge Gram metric, with no ambient cross product.
//!
//! ```text
//! rest edges     D_m = [X_1 − X_0 … X_k − X_0]        (N × k)
//! rest metric    G_0 = D_mᵀ D_m = L Lᵀ                 (k × k; L = Uᵀ from D_m = Q U,
//!                                                      modified Gram–Schmidt, rest.rs)
//! rest frame     R = L⁻ᵀ (upper triangular); for k = N its last column is
//!                negated when det D_m < 0, so Q = D_m R has orthonormal
//!                columns (Q ∈ SO(N) when k = N)
//! rest measure   V_0 = √det G_0 / k! = Π L_jj / k!
//! deformed       D_s = [x_1 − x_0 … x_k − x_0],   F̂ = D_s R   (N × k)
//!                F̂ = F Q: the deformation gradient acting on the orthonormal
//!                rest frame Q
//! Cauchy–Green   C = F̂ᵀ F̂  (k × k, symmetric; similar to G_0⁻¹ G, G = D_sᵀ D_s)
//! Green strain   E = ½ (C − I)
//! stretches      √ of the eigenvalues of C (symmetric Jacobi, ascending)
//! measure ratio  J = det F̂ = det D_s / det D_m        (k = N, signed)
//!                J = √det C = √(det G / det G_0)       (k < N, ≥ 0)
//! laws           Ψ(C, J) with S = 2 ∂Ψ/∂C (second Piola stress, rest frame)
//! element        W = V_0 Ψ,   ∂W/∂D_s = V_0 F̂ S Rᵀ,
//!                ∇_j W = column j−1 of ∂W/∂D_s (j = 1..k),  ∇_0 W = −Σ_j ∇_j W
//! ```
//! The symmetric form C = F̂ᵀF̂ (rather than the mixed G_0⁻¹G) is chosen
//! because it is what the principal stretches need (a symmetric eigen
//! problem), it keeps S symmetric, and it costs one triangular product per
//! element: R is precomputed once per element at rest.
//!
//! The derivations, the choice of Lamé parameters per dimension, the XPBD
//! energy constraint and the uniaxial closed forms are in docs/materials.md.

// Index loops mirror the math (and the later WGSL port) line by line.
#![allow(clippy::needless_range_loop)]

mod cholesky;
mod deformation;
mod energy;
mod energy_constraint;
mod error;
mod lame;
mod ln;
mod ln_f32;
mod mass;
mod measures;
mod neo_hookean;
mod rest;
mod stvk;
mod uniaxial;

pub use cholesky::{
    NotPositiveDefinite, cholesky, inverse_from_factor_inverse, lower_triangular_inverse,
    solve_factored,
};
pub use deformation::{
    deform_into, measure_ratio, pull_back_of, ratio_and_factor_of, scatter_frame_rows,
};
pub use energy::element_energy;
pub use energy_constraint::energy_constraint;
pub use error::{LawRefusal, MaterialError};
pub use lame::{Lame, poisson_ratio_range};
pub use ln::{ATANH_SERIES, ATANH_TERMS_F32, ln};
pub use ln_f32::ln_f32;
pub use mass::{LumpedMass, lump_masses};
pub use measures::{DeformationMeasures, deformation_measures};
pub use neo_hookean::neo_hookean_stress;
pub use rest::{DegenerateRest, RestShapes, rest_element};
pub use stvk::stvk_stress;
pub use uniaxial::{UniaxialState, uniaxial_state, uniaxial_stretch_under_stress};

/// The constitutive law of a material family.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Law {
    /// Ψ = μ tr(E²) + (λ/2)(tr E)²: defined for every deformation.
    StVenantKirchhoff,
    /// Ψ = (μ/2)(tr C − k) − μ ln J + (λ/2)(ln J)²: refuses J ≤ 0.
    NeoHookean,
}

impl std::fmt::Display for Law {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Law::StVenantKirchhoff => "stvk",
            Law::NeoHookean => "neo_hookean",
        })
    }
}

/// A law with its Lamé parameters for one simplex order k.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Which energy.
    pub law: Law,
    /// μ and λ for k-simplices.
    pub lame: Lame,
}

impl Material {
    /// The material of k-simplices (`order` = k) with Young's modulus E and
    /// Poisson's ratio ν, validated ([`Lame::from_young_poisson`]; the
    /// Neo-Hookean law also needs ν ≥ 0, i.e. λ ≥ 0).
    pub fn new(
        law: Law,
        order: usize,
        youngs_modulus: f64,
        poisson_ratio: f64,
    ) -> Result<Material, MaterialError> {
        let lame = Lame::from_young_poisson(youngs_modulus, poisson_ratio, order)?;
        if law == Law::NeoHookean && poisson_ratio < 0.0 {
            return Err(MaterialError::NeoHookeanNegativePoisson {
                value: poisson_ratio,
            });
        }
        Ok(Material { law, lame })
    }
}

/// The precomputed rest data of one element, borrowed from [`RestShapes`]
/// or built by [`rest_element`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RestView<'a> {
    /// R (k × k, row-major, upper triangular): columns of D_m R are an
    /// orthonormal rest frame (positively oriented for k = N).
    pub frame: &'a [f64],
    /// V_0 > 0, the rest k-measure.
    pub measure: f64,
}

/// One material element as the law's functions read it: its material,
/// its k + 1 gathered vertices (`points[j * dim + a]`) and its rest data.
#[derive(Debug, Clone, Copy)]
pub struct MaterialElement<'a> {
    /// The law and its Lamé parameters.
    pub material: &'a Material,
    /// x_0 … x_k, `dim` coordinates each.
    pub points: &'a [f64],
    /// N.
    pub dim: usize,
    /// R and V_0.
    pub rest: RestView<'a>,
}

impl MaterialElement<'_> {
    /// k: the element is a k-simplex (k + 1 points).
    pub fn order(&self) -> usize {
        self.points.len() / self.dim - 1
    }
}

/// Reusable buffers so that evaluation allocates nothing per element.
#[derive(Debug, Default, Clone)]
pub struct MaterialScratch {
    /// D (N × k): edges x_j − x_0 as columns, `edges[a * k + j]`.
    pub(crate) edges: Vec<f64>,
    /// F̂ = D R (N × k).
    pub(crate) image: Vec<f64>,
    /// C = F̂ᵀF̂ (k × k).
    pub(crate) cauchy_green: Vec<f64>,
    /// Cholesky factor L (k × k).
    pub(crate) factor: Vec<f64>,
    /// L⁻¹ (k × k).
    pub(crate) factor_inverse: Vec<f64>,
    /// C⁻¹ (k × k).
    pub(crate) c_inverse: Vec<f64>,
    /// S (k × k).
    pub(crate) stress: Vec<f64>,
    /// P̂ = F̂ S (N × k).
    pub(crate) first_piola: Vec<f64>,
    /// A k × k copy (determinants overwrite their input).
    pub(crate) square: Vec<f64>,
}

impl MaterialScratch {
    /// Empty scratch; buffers grow on first use.
    pub fn new() -> Self {
        MaterialScratch::default()
    }

    /// Sizes every buffer for k-simplices in R^N.
    pub(crate) fn resize(&mut self, k: usize, dim: usize) {
        for b in [&mut self.edges, &mut self.image, &mut self.first_piola] {
            b.resize(dim * k, 0.0);
        }
        for b in [
            &mut self.cauchy_green,
            &mut self.factor,
            &mut self.factor_inverse,
            &mut self.c_inverse,
            &mut self.stress,
            &mut self.square,
        ] {
            b.resize(k * k, 0.0);
        }
    }
}
