//! k-dimensional particle grids embedded in R^N with edge distance springs.
//!
//! ```text
//! node (c_0 … c_{k−1}), 0 ≤ c_a < counts[a]
//! index   = first + Σ_a c_a · Π_{b<a} counts[b]        (axis 0 fastest)
//! position = origin + spacing · Σ_a c_a e_{axes[a]}
//! edges   = every pair of nodes differing by 1 along one grid axis,
//!           grid axis by grid axis, then node by node; with `shear`, also
//!           both diagonals of every unit square of each pair of grid axes
//! ```

use super::SceneBuilder;
use crate::kinds::BendingModel;
use crate::{ConstraintFamily, ConstraintKind, Particle};

/// A grid to add.
#[derive(Debug, Clone)]
pub struct GridSpec {
    /// Nodes along each grid axis (k = `counts.len()` ≤ N).
    pub counts: Vec<usize>,
    /// Ambient axis spanned by each grid axis.
    pub axes: Vec<usize>,
    /// Position of node (0, …, 0).
    pub origin: Vec<f64>,
    /// Node spacing.
    pub spacing: f64,
    /// Mass of each node.
    pub mass: f64,
    /// Compliance of the edge family.
    pub compliance: f64,
    /// Also add unit-square diagonals (shear resistance).
    pub shear: bool,
}

impl GridSpec {
    /// A cloth: an `nx × ny` 2-grid in R^3 spanning axes x and z at height
    /// `height`, centred on the y axis.
    pub fn cloth(nx: usize, ny: usize, spacing: f64, height: f64) -> Self {
        let half_x = 0.5 * spacing * nx.saturating_sub(1) as f64;
        let half_z = 0.5 * spacing * ny.saturating_sub(1) as f64;
        GridSpec {
            counts: vec![nx, ny],
            axes: vec![0, 2],
            origin: vec![-half_x, height, -half_z],
            spacing,
            mass: 1.0 / (nx * ny).max(1) as f64,
            compliance: 0.0,
            shear: true,
        }
    }
}

/// Where a grid landed.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Index of node (0, …, 0).
    pub first: usize,
    /// Nodes per grid axis.
    pub counts: Vec<usize>,
    /// Index of the edge family.
    pub family: usize,
}

impl Grid {
    /// Particle index of grid node `coords`.
    pub fn index(&self, coords: &[usize]) -> usize {
        let mut index = 0;
        let mut stride = 1;
        for (c, n) in coords.iter().zip(&self.counts) {
            index += c * stride;
            stride *= n;
        }
        self.first + index
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.counts.iter().product()
    }

    /// True for a grid without nodes.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Node coordinates of linear index `i` (axis 0 fastest).
pub fn coords_of(mut i: usize, counts: &[usize]) -> Vec<usize> {
    counts
        .iter()
        .map(|&n| {
            let c = i % n;
            i /= n;
            c
        })
        .collect()
}

impl SceneBuilder {
    /// Adds the grid's particles and its edge distance family.
    pub fn grid(&mut self, spec: &GridSpec) -> Grid {
        let dim = self.scene().dim;
        let first = self.scene().particles.len();
        let total: usize = spec.counts.iter().product();
        for i in 0..total {
            let c = coords_of(i, &spec.counts);
            let mut position = spec.origin.clone();
            position.resize(dim, 0.0);
            for (a, &axis) in spec.axes.iter().enumerate() {
                if let Some(x) = position.get_mut(axis) {
                    *x += spec.spacing * c[a] as f64;
                }
            }
            self.particle(Particle::new(position, spec.mass));
        }
        let mut grid = Grid {
            first,
            counts: spec.counts.clone(),
            family: 0,
        };
        let k = spec.counts.len();
        let mut elements = Vec::new();
        for a in 0..k {
            for i in 0..total {
                let mut c = coords_of(i, &spec.counts);
                if c[a] + 1 < spec.counts[a] {
                    let from = grid.index(&c);
                    c[a] += 1;
                    elements.push(vec![from, grid.index(&c)]);
                }
            }
        }
        if spec.shear {
            for a in 0..k {
                for b in a + 1..k {
                    for i in 0..total {
                        let c = coords_of(i, &spec.counts);
                        if c[a] + 1 < spec.counts[a] && c[b] + 1 < spec.counts[b] {
                            let mut d = c.clone();
                            d[a] += 1;
                            d[b] += 1;
                            elements.push(vec![grid.index(&c), grid.index(&d)]);
                            let mut e = c.clone();
                            e[a] += 1;
                            let mut f = c.clone();
                            f[b] += 1;
                            elements.push(vec![grid.index(&e), grid.index(&f)]);
                        }
                    }
                }
            }
        }
        grid.family = self.family(ConstraintFamily::new(
            ConstraintKind::Distance,
            spec.compliance,
            elements,
        ));
        grid
    }
}

impl SceneBuilder {
    /// Adds a bending family (`compliance`, `model`) over the hinges of a 2-grid
    /// `grid` (as [`SceneBuilder::grid`] returned it), each unit square
    /// split along its diagonal c → c + a + b into the triangles
    /// (c, c+a, c+a+b) and (c, c+b, c+a+b). One element per interior edge
    /// [x0, x1, x2, x3]: the edge x0x1 and the third vertices of its two
    /// triangles (kinds/bending.rs). `None` for a grid that is not 2-D or
    /// has no interior edge.
    pub fn grid_bending(
        &mut self,
        grid: &Grid,
        compliance: f64,
        model: BendingModel,
    ) -> Option<usize> {
        let [na, nb] = grid.counts[..] else {
            return None;
        };
        let at = |a: usize, b: usize| grid.index(&[a, b]);
        let mut elements = Vec::new();
        for b in 0..nb.saturating_sub(1) {
            for a in 0..na.saturating_sub(1) {
                // The square's diagonal.
                elements.push(vec![at(a, b), at(a + 1, b + 1), at(a + 1, b), at(a, b + 1)]);
            }
        }
        for b in 1..nb.saturating_sub(1) {
            for a in 0..na.saturating_sub(1) {
                // Edge along a, between the squares at b − 1 and b.
                elements.push(vec![at(a, b), at(a + 1, b), at(a + 1, b + 1), at(a, b - 1)]);
            }
        }
        for b in 0..nb.saturating_sub(1) {
            for a in 1..na.saturating_sub(1) {
                // Edge along b, between the squares at a − 1 and a.
                elements.push(vec![at(a, b), at(a, b + 1), at(a + 1, b + 1), at(a - 1, b)]);
            }
        }
        (!elements.is_empty()).then(|| {
            // The default model is written by omission (scenes stay as they were).
            self.family(ConstraintFamily {
                model: (model != BendingModel::default()).then_some(model),
                ..ConstraintFamily::new(ConstraintKind::Bending, compliance, elements)
            })
        })
    }
}
