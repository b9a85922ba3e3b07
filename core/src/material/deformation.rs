//! Kinematics shared by both laws: the deformed frame F̂ and Cauchy–Green
//! tensor C of one element, its measure ratio J, and the pull-back of a
//! second Piola stress S to vertex gradients. The loop orders here are the
//! arithmetic order a kernel repeats: each step is written once over the
//! precision ([`deform_into`], [`ratio_and_factor_of`], [`pull_back_of`]),
//! the golden path running it in f64, the f32 reference in f32.
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
use crate::geometry::{determinant, edge_matrix, gram, sum_of_products};
use crate::kinds::ProjectionReal;

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
    deform_into(points, (dim, k), frame, [edges, image, cauchy_green]);
    k
}

/// D, F̂ = D R and C = F̂ᵀF̂ (module docs) of the k-simplex `points` with
/// rest frame `frame` into `[edges, image, c]`, in precision `R` (f64:
/// `deform`; f32: the f32 reference, as `material.wgsl`).
pub fn deform_into<R: ProjectionReal>(
    points: &[R],
    (dim, k): (usize, usize),
    frame: &[R],
    [edges, image, c]: [&mut [R]; 3],
) {
    edge_matrix(points, dim, k, edges);
    for a in 0..dim {
        for j in 0..k {
            image[a * k + j] = sum_of_products(0..j + 1, |i| (edges[a * k + i], frame[i * k + j]));
        }
    }
    gram(image, dim, k, c);
}

/// J of the element whose F̂ and C [`deform`] filled, and the Cholesky
/// factor of C in `s.factor` (second value: whether C = L Lᵀ succeeded).
pub(crate) fn ratio_and_factor(k: usize, dim: usize, s: &mut MaterialScratch) -> (f64, bool) {
    ratio_and_factor_of(
        (k, dim),
        [&s.image, &s.cauchy_green],
        [&mut s.factor, &mut s.square],
    )
}

/// J (det F̂ for k = N, Π L_jj for k < N, 0 when C is not positive
/// definite) of `[F̂, C]`, L into `factor` (`square`: k × k scratch), and
/// whether C = L Lᵀ succeeded, in precision `R`.
pub fn ratio_and_factor_of<R: ProjectionReal>(
    (k, dim): (usize, usize),
    [image, c]: [&[R]; 2],
    [factor, square]: [&mut [R]; 2],
) -> (R, bool) {
    let factored = cholesky(c, k, factor).is_ok();
    let ratio = if k == dim {
        square[..k * k].copy_from_slice(&image[..k * k]);
        determinant(square, k)
    } else if factored {
        let mut product = R::constant(1.0);
        for j in 0..k {
            product *= factor[j * k + j];
        }
        product
    } else {
        R::constant(0.0)
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
    pull_back_of(
        (k, dim),
        (rest.frame, rest.measure),
        [image, stress],
        first_piola,
        grad,
    );
}

/// ∇W (module docs: P̂ = F̂ S into `first_piola`, then H = V_0 P̂ Rᵀ) of
/// `[F̂, S]` with rest frame R and measure V_0, into `grad`, in
/// precision `R`.
pub fn pull_back_of<R: ProjectionReal>(
    (k, dim): (usize, usize),
    (frame, measure): (&[R], R),
    [image, stress]: [&[R]; 2],
    first_piola: &mut [R],
    grad: &mut [R],
) {
    for a in 0..dim {
        for j in 0..k {
            first_piola[a * k + j] =
                sum_of_products(0..k, |m| (image[a * k + m], stress[m * k + j]));
        }
    }
    scatter_frame_rows((k, dim), (frame, measure), first_piola, grad);
}

/// The vertex vector of the N × k rows `y` (P̂ for ∇W, H dF for the
/// curvature), into `out`:
///
/// ```text
/// H[a][i] = V_0 Σ_{j=i..k−1} y[a][j] R[i][j]   (j ascending)
/// ∇_{i+1}[a] = H[a][i],   ∇_0[a] = −H[a][0] − … − H[a][k−1]
/// ```
pub fn scatter_frame_rows<R: ProjectionReal>(
    (k, dim): (usize, usize),
    (frame, measure): (&[R], R),
    y: &[R],
    out: &mut [R],
) {
    for a in 0..dim {
        let mut first = R::constant(0.0);
        for i in 0..k {
            let h = measure * sum_of_products(i..k, |j| (y[a * k + j], frame[i * k + j]));
            out[(i + 1) * dim + a] = h;
            first -= h;
        }
        out[a] = first;
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
