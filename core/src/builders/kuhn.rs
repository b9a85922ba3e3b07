//! Kuhn simplexization of an N-dimensional cuboid grid into oriented
//! measure elements: a soft N-cube.
//!
//! ```text
//! cell with lowest corner c, permutation π of the N axes (lexicographic):
//!   v_0 = c,  v_j = v_{j−1} + e_{π(j−1)}      j = 1..N
//! ```
//! The N! simplices of a cell tile it exactly; their raw signed measures
//! alternate with the parity of π. The sign is kept as authored (rest values
//! default to the authored geometry, so each element preserves its own
//! orientation).

use super::SceneBuilder;
use super::grid::{Grid, coords_of};
use crate::{ConstraintFamily, ConstraintKind, Particle};

/// A soft N-cuboid to add.
#[derive(Debug, Clone)]
pub struct BlockSpec {
    /// Cells along each of the N axes.
    pub cells: Vec<usize>,
    /// Position of the lowest corner.
    pub origin: Vec<f64>,
    /// Cell edge length.
    pub spacing: f64,
    /// Mass of each node.
    pub mass: f64,
    /// Compliance of the oriented-measure family.
    pub compliance: f64,
    /// Compliance of an edge distance family over every edge of every
    /// simplex, or `None` for volume only. Volume constraints alone resist
    /// compression but not shear: without edges the block flows like a
    /// liquid and its simplices degenerate into slivers.
    pub edge_compliance: Option<f64>,
}

/// All permutations of 0..n in lexicographic order.
fn permutations(n: usize) -> Vec<Vec<usize>> {
    if n == 0 {
        return vec![Vec::new()];
    }
    let mut out = Vec::new();
    for first in 0..n {
        for rest in permutations(n - 1) {
            let mut p = vec![first];
            p.extend(rest.into_iter().map(|x| if x >= first { x + 1 } else { x }));
            out.push(p);
        }
    }
    out
}

/// Node-coordinate simplices of the Kuhn triangulation of one unit cell in
/// R^n: `n!` simplices of `n + 1` offset vectors each.
pub fn kuhn_simplices(n: usize) -> Vec<Vec<Vec<usize>>> {
    permutations(n)
        .into_iter()
        .map(|perm| {
            let mut v = vec![0usize; n];
            let mut simplex = vec![v.clone()];
            for axis in perm {
                v[axis] += 1;
                simplex.push(v.clone());
            }
            simplex
        })
        .collect()
}

/// The Kuhn simplices of a grid of `cells` per axis (k = N elements, N =
/// `cells.len()`), as node indices (axis 0 fastest, node (0, …, 0) at
/// `first`), cell by cell in index order, each cell's N! simplices in
/// [`kuhn_simplices`] order.
pub fn kuhn_grid_elements(cells: &[usize], first: usize) -> Vec<Vec<usize>> {
    let grid = Grid {
        first,
        counts: cells.iter().map(|c| c + 1).collect(),
        family: 0,
    };
    let pattern = kuhn_simplices(cells.len());
    let cell_count: usize = cells.iter().product();
    let mut elements: Vec<Vec<usize>> = Vec::with_capacity(cell_count * pattern.len());
    for cell in 0..cell_count {
        let corner = coords_of(cell, cells);
        for simplex in &pattern {
            elements.push(
                simplex
                    .iter()
                    .map(|offset| {
                        let c: Vec<usize> = corner.iter().zip(offset).map(|(a, b)| a + b).collect();
                        grid.index(&c)
                    })
                    .collect(),
            );
        }
    }
    elements
}

impl SceneBuilder {
    /// Adds the block's nodes, its Kuhn oriented-measure family, and (with
    /// `edge_compliance`) the distance family of the simplices' edges, in
    /// first-seen order. [`Grid::family`] is the oriented-measure family;
    /// the edge family, if any, is the one after it.
    pub fn soft_block(&mut self, spec: &BlockSpec) -> Grid {
        let dim = self.scene().dim;
        let first = self.scene().particles.len();
        let nodes: Vec<usize> = spec.cells.iter().map(|c| c + 1).collect();
        let total: usize = nodes.iter().product();
        for i in 0..total {
            let c = coords_of(i, &nodes);
            let mut position = spec.origin.clone();
            position.resize(dim, 0.0);
            for (a, x) in position.iter_mut().enumerate().take(c.len()) {
                *x += spec.spacing * c[a] as f64;
            }
            self.particle(Particle::new(position, spec.mass));
        }
        let mut grid = Grid {
            first,
            counts: nodes,
            family: 0,
        };
        let elements = kuhn_grid_elements(&spec.cells, first);
        let edges = spec.edge_compliance.map(|compliance| {
            let mut seen = std::collections::HashSet::new();
            let mut edges = Vec::new();
            for simplex in &elements {
                for (a, &i) in simplex.iter().enumerate() {
                    for &j in &simplex[a + 1..] {
                        if seen.insert((i.min(j), i.max(j))) {
                            edges.push(vec![i, j]);
                        }
                    }
                }
            }
            ConstraintFamily::new(ConstraintKind::Distance, compliance, edges)
        });
        grid.family = self.family(ConstraintFamily::new(
            ConstraintKind::OrientedMeasure,
            spec.compliance,
            elements,
        ));
        if let Some(edges) = edges {
            self.family(edges);
        }
        grid
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Scratch, oriented_measure};

    #[test]
    fn kuhn_simplices_tile_the_unit_cube() {
        for n in 1..=5 {
            let mut total = 0.0;
            let mut scratch = Scratch::new();
            for simplex in kuhn_simplices(n) {
                let points: Vec<f64> = simplex.iter().flatten().map(|&c| c as f64).collect();
                let mut grad = vec![0.0; points.len()];
                total += oriented_measure(&points, n, &mut grad, &mut scratch).abs();
            }
            approx::assert_relative_eq!(total, 1.0, epsilon = 1e-12);
        }
    }
}
