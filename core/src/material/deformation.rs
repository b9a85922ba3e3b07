//! Kinematics shared by both laws: the deformed frame F̂ and Cauchy–Green
//! tensor C of one element, its measure ratio J, and the pull-back of a
//! second Piola stress S to vertex gradients. The loop orders here are the
//! arithmetic order a kernel repeats.
//!
//! ```text
//! D[a][j]  = x_{j+1}[a] − x_0[a]                        (N × k)
//! F̂[a][j]  = Σ_{i=0..j} D[a][i] R[i][j]                 (R upper triangular; i ascending)
//! C[i][j]  = Σ_a F̂[a][i] F̂[a][j]                        (a ascending; C exactly symmetric)
//! J        = det F̂                                       (k = N: elimination as geometry::determinant)
//!          = Π_j L_jj,  C = L Lᵀ                          (k < N; 0 if C is not positive definite)
//! P̂[a][j]  = Σ_m F̂[a][m] S[m][j]                         (m ascending)
//! H[a][i]  = V_0 · Σ_{j=i..k−1} P̂[a][j] R[i][j]           (= ∂W/∂D)
//! ∇_{i+1}W[a] = H[a][i],   ∇_0 W[a] = −H[a][0] − H[a][1] − … − H[a][k−1]
//! ```
//! Derivation of the pull-back: dΨ = ½ tr(S dC) = tr(S F̂ᵀ dF̂) = ⟨F̂ S, dF̂⟩
//! and dF̂ = dD R, so ∂Ψ/∂D = F̂ S Rᵀ; D's column j is x_{j+1} − x_0.

use super::cholesky::cholesky;
use super::{MaterialScratch, RestView};
use crate::geometry::{determinant, edge_matrix, gram};

/// Fills `s.edges`, `s.image` (F̂) and `s.cauchy_green` (C) for the
/// simplex `points` with rest frame `frame`; returns k.
pub(crate) fn deform(points: &[f64], dim: usize, frame: &[f64], s: &mut MaterialScratch) -> usize {
    let k = points.len() / dim - 1;
    s.resize(k, dim);
    let MaterialScratch {
        edges,
        image,
        cauchy_green,
        ..
    } = s;
    edge_matrix(points, dim, k, edges);
    for a in 0..dim {
        for j in 0..k {
            let mut f = 0.0;
            for i in 0..=j {
                f += edges[a * k + i] * frame[i * k + j];
            }
            image[a * k + j] = f;
        }
    }
    gram(image, dim, k, cauchy_green);
    k
}

/// J of the element whose F̂ and C [`deform`] filled, and the Cholesky
/// factor of C in `s.factor` (second value: whether C = L Lᵀ succeeded).
pub(crate) fn ratio_and_factor(k: usize, dim: usize, s: &mut MaterialScratch) -> (f64, bool) {
    let factored = cholesky(&s.cauchy_green, k, &mut s.factor).is_ok();
    let ratio = if k == dim {
        s.square[..k * k].copy_from_slice(&s.image[..k * k]);
        determinant(&mut s.square, k)
    } else if factored {
        let mut product = 1.0;
        for j in 0..k {
            product *= s.factor[j * k + j];
        }
        product
    } else {
        0.0
    };
    (ratio, factored)
}

/// ∇W into `grad` ((k + 1) × `dim`) from the stress S in `s.stress` and
/// the F̂ [`deform`] left in `s.image`.
pub(crate) fn pull_back(
    k: usize,
    dim: usize,
    rest: RestView<'_>,
    s: &mut MaterialScratch,
    grad: &mut [f64],
) {
    let MaterialScratch {
        image,
        stress,
        first_piola,
        ..
    } = s;
    for a in 0..dim {
        for j in 0..k {
            let mut p = 0.0;
            for m in 0..k {
                p += image[a * k + m] * stress[m * k + j];
            }
            first_piola[a * k + j] = p;
        }
    }
    for a in 0..dim {
        let mut first = 0.0;
        for i in 0..k {
            let mut h = 0.0;
            for j in i..k {
                h += first_piola[a * k + j] * rest.frame[i * k + j];
            }
            let h = rest.measure * h;
            grad[(i + 1) * dim + a] = h;
            first -= h;
        }
        grad[a] = first;
    }
}

/// The measure ratio J of the simplex `points` against its rest data:
/// det D_s / det D_m, signed, for k = N; √(det G / det G_0) ≥ 0 for k < N.
pub fn measure_ratio(
    points: &[f64],
    dim: usize,
    rest: RestView<'_>,
    scratch: &mut MaterialScratch,
) -> f64 {
    let k = deform(points, dim, rest.frame, scratch);
    ratio_and_factor(k, dim, scratch).0
}
