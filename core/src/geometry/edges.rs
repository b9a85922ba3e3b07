//! The edge matrix of a simplex, its Gram matrix, and the scatter of an
//! edge-matrix gradient onto the vertices — shared by the measure
//! constraints and the material deformation measures.
//!
//! ```text
//! D = [x_1 − x_0 … x_k − x_0]        N × k, row-major: D[a][j] = d[a·k + j]
//! G = DᵀD                            G[i][j] = Σ_a D[a][i] D[a][j]  (a ascending)
//! ∂f/∂D = Γ  ⇒  ∇_j f = Γ[·][j − 1]  (j = 1..k),   ∇_0 f = −Σ_j ∇_j f
//! ```
//! Generic over the precision: f64 for the golden path, f32 for the f32
//! reference (`measure.wgsl` and `material.wgsl` run these loops in this
//! order).

use crate::kinds::ProjectionReal;

/// D of the k-simplex `points` (k + 1 points of length `dim`) into
/// `edges` (`dim` × k, row-major).
pub fn edge_matrix<R: ProjectionReal>(points: &[R], dim: usize, k: usize, edges: &mut [R]) {
    for j in 0..k {
        for a in 0..dim {
            edges[a * k + j] = points[(j + 1) * dim + a] - points[a];
        }
    }
}

/// G = DᵀD of the `dim` × k row-major `columns` into `gram` (k × k),
/// each entry summed over the rows in ascending order.
pub fn gram<R: ProjectionReal>(columns: &[R], dim: usize, k: usize, gram: &mut [R]) {
    for i in 0..k {
        for j in 0..k {
            gram[i * k + j] = sum_of_products(0..dim, |a| (columns[a * k + i], columns[a * k + j]));
        }
    }
}

/// Σ_m u_m v_m over m in `range`, with (u_m, v_m) = `term(m)`: from
/// +0.0, m ascending — the order of the matrix products of core, the f32
/// reference and the kernels.
#[inline(always)]
pub fn sum_of_products<R: ProjectionReal>(
    range: std::ops::Range<usize>,
    term: impl Fn(usize) -> (R, R),
) -> R {
    let mut s = R::constant(0.0);
    for m in range {
        let (u, v) = term(m);
        s += u * v;
    }
    s
}

/// The vertex gradient (k + 1 points × `dim`) of a function whose
/// derivative with respect to edge entry `D[a][j]` is `edge_gradient(j, a)`:
/// ∇_{j+1} = that column, ∇_0 = minus the sum of the columns, accumulated
/// in the order j ascending, a ascending.
pub fn scatter_edge_gradient<R: ProjectionReal>(
    grad: &mut [R],
    dim: usize,
    k: usize,
    mut edge_gradient: impl FnMut(usize, usize) -> R,
) {
    grad[..dim].fill(R::constant(0.0));
    for j in 0..k {
        for a in 0..dim {
            let gj = edge_gradient(j, a);
            grad[(j + 1) * dim + a] = gj;
            grad[a] -= gj;
        }
    }
}
