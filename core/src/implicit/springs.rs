//! Constraint families as springs of the implicit objective: energy
//! C²/(2α), its gradient and a PSD curvature, per element.
//!
//! ```text
//! E = C² / (2α)                  α = compliance > 0 (C-units² / energy)
//! ∇E  = (C/α) ∇C
//! ∇²E = (1/α) ∇C ∇Cᵀ + (C/α) ∇²C          Gauss–Newton part + second-order part
//! ```
//! **Distance** C = ℓ − rest, ℓ = |x_1 − x_0|, is a radial potential
//! (radial.rs) with φ' = C/α, φ'' = 1/α:
//!
//! ```text
//! K = (1/α) n nᵀ + (C/(α ℓ)) (I − n nᵀ)         exact (∇²ℓ = (I − n nᵀ)/ℓ)
//! K⁺ = (1/α) n nᵀ + max(C/(αℓ), 0) (I − n nᵀ)   compressed (C < 0): transverse part clamped
//! ```
//! **Tether** (one-sided, only pulls): E = max(C, 0)²/(2α). Stretched
//! (C > 0) it is the distance spring, whose K is then already PSD; slack
//! (C ≤ 0) it has no energy, gradient or curvature. E is C¹ at C = 0 (its
//! curvature jumps from 0 to 1/α along n there).
//!
//! **Simplex measure / oriented measure** (C = S − rest, S = det(EᵀE)/(k!)²
//! or det(D)/N!): curvature is **Gauss–Newton**, K = (1/α) ∇C ∇Cᵀ, PSD by
//! construction (rank one, eigenvalue |∇C|²/α), and the C∇²C/α part is
//! dropped. Why: ∇²C of a determinant needs the second-order cofactor
//! tensor (k⁴ minors of size k − 2 per element) and a dense
//! ((k + 1)N)² block with an eigensolve per element; with N up to
//! `MAX_DIM` = 256 neither the storage nor the cubic projection scales,
//! while the Gauss–Newton product is O(kN) with two dot products. For a
//! stiff spring (small α) the dropped term C∇²C/α = −λ∇²C (λ = −C/α the
//! multiplier, a finite force) is O(1) while the kept term is O(1/α), so
//! the Newton matrix loses only the geometric stiffness of the measure
//! constraint; the line search keeps every step a decrease of F, and
//! convergence near the minimiser is linear with a rate ≈ h²|λ| ‖∇²C‖ /
//! (m + h² |∇C|²/α) instead of quadratic. At C = 0 the Gauss–Newton block
//! is the exact Hessian (tests/implicit/terms/springs.rs checks both).
//!
//! Material kinds are no springs (their energy is the law's,
//! material_hessian.rs): here their value is 0 with ∇C = 0
//! (`kinds::value`).
//!
//! Products (element layout, (k + 1) × N):
//! ```text
//! radial:        RadialCurvature::apply
//! Gauss–Newton:  s = Σ_j Σ_a ∇C[j][a] p[j][a]  (j, then a ascending);  y = (s/α) ∇C
//! diagonal:      radial: K's diagonal at both vertices;  Gauss–Newton: ∇C[j][a]²/α
//! ```

use super::RadialCurvature;
use crate::ConstraintKind;
use crate::geometry::Scratch;
use crate::kinds;

/// The curvature of one spring element (PSD).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SpringCurvature {
    /// Distance and tether: K⁺ of the edge, normal n = ∇_1 C.
    Radial(RadialCurvature),
    /// Measure kinds: weight · ∇C ∇Cᵀ with weight = 1/α.
    GaussNewton {
        /// 1/α.
        weight: f64,
    },
}

/// One spring element evaluated at its points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spring {
    /// C²/(2α) (0 for a slack tether).
    pub energy: f64,
    /// C = value − rest.
    pub value: f64,
    /// The PSD curvature.
    pub curvature: SpringCurvature,
}

/// Evaluates the spring of `kind` with compliance α > 0 and rest value
/// `rest` at `points` ((k + 1) × `dim`, gathered). Writes ∇C into
/// `constraint_gradient` and ∇E into `energy_gradient` (both the layout of
/// `points`; ∇E = 0 for a slack tether). Where ∇C vanishes (coincident
/// points, collapsed simplex) gradient and curvature are zero (no response),
/// the energy is still C²/(2α).
#[allow(clippy::too_many_arguments)]
pub fn evaluate_spring(
    kind: ConstraintKind,
    compliance: f64,
    rest: f64,
    points: &[f64],
    dim: usize,
    constraint_gradient: &mut [f64],
    energy_gradient: &mut [f64],
    scratch: &mut Scratch,
) -> Spring {
    let value = kinds::value(kind, points, dim, constraint_gradient, scratch);
    let c = value - rest;
    let count = points.len();
    if kind == ConstraintKind::Tether && c <= 0.0 {
        energy_gradient[..count].fill(0.0);
        return Spring {
            energy: 0.0,
            value: c,
            curvature: SpringCurvature::Radial(RadialCurvature::default()),
        };
    }
    let force = c / compliance;
    for i in 0..count {
        energy_gradient[i] = force * constraint_gradient[i];
    }
    let energy = c * c / (2.0 * compliance);
    let curvature = match kind {
        ConstraintKind::Distance | ConstraintKind::Tether => SpringCurvature::Radial(
            RadialCurvature::exact(force, 1.0 / compliance, value).projected(),
        ),
        ConstraintKind::SimplexMeasure
        | ConstraintKind::OrientedMeasure
        | ConstraintKind::Stvk
        | ConstraintKind::NeoHookean => SpringCurvature::GaussNewton {
            weight: 1.0 / compliance,
        },
        ConstraintKind::Expression | ConstraintKind::Bending => {
            unreachable!("expression springs are expression_spring.rs's (their ∇²C is the tape's)")
        }
    };
    Spring {
        energy,
        value: c,
        curvature,
    }
}

impl Spring {
    /// out = K⁺ p for the gathered element vector `p`; `constraint_gradient`
    /// is the ∇C [`evaluate_spring`] wrote. `out` is overwritten.
    pub fn apply(&self, constraint_gradient: &[f64], dim: usize, p: &[f64], out: &mut [f64]) {
        match self.curvature {
            SpringCurvature::Radial(k) => k.apply(&constraint_gradient[dim..2 * dim], p, out),
            SpringCurvature::GaussNewton { weight } => {
                let count = p.len();
                let mut s = 0.0;
                for i in 0..count {
                    s += constraint_gradient[i] * p[i];
                }
                let scale = weight * s;
                for i in 0..count {
                    out[i] = scale * constraint_gradient[i];
                }
            }
        }
    }

    /// Diagonal of K⁺ in the element layout into `out`.
    pub fn diagonal(&self, constraint_gradient: &[f64], dim: usize, out: &mut [f64]) {
        match self.curvature {
            SpringCurvature::Radial(k) => {
                k.diagonal(&constraint_gradient[dim..2 * dim], &mut out[..dim]);
                out.copy_within(..dim, dim);
            }
            SpringCurvature::GaussNewton { weight } => {
                for i in 0..out.len() {
                    out[i] = weight * constraint_gradient[i] * constraint_gradient[i];
                }
            }
        }
    }

    /// The dense ((k + 1)N)² block K⁺ (row-major) into `out`.
    pub fn block(&self, constraint_gradient: &[f64], dim: usize, out: &mut [f64]) {
        match self.curvature {
            SpringCurvature::Radial(k) => k.block(&constraint_gradient[dim..2 * dim], out),
            SpringCurvature::GaussNewton { weight } => {
                let count = constraint_gradient.len();
                for r in 0..count {
                    for c in 0..count {
                        out[r * count + c] =
                            weight * constraint_gradient[r] * constraint_gradient[c];
                    }
                }
            }
        }
    }
}
