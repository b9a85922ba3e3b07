//! A flat triangulated square: the simplex-mesh obstacle of the barrier
//! path's scenes, benches and tests.
//!
//! ```text
//! vertex v(a, b) = a · side + b,   0 ≤ a, b < side
//! position       = spacing · (a e_{axes[0]} + b e_{axes[1]})   (in R^dim)
//! cell (a, b)    → triangles [v(a, b), v(a+1, b), v(a, b+1)]
//!                            [v(a+1, b), v(a+1, b+1), v(a, b+1)]
//!                  cells row by row (a outer, b inner): 2 (side − 1)² triangles
//! ```

use super::SceneBuilder;
use crate::Obstacle;

/// The simplex mesh of a `side × side` vertex grid, `spacing` apart, in
/// the plane of ambient axes `axes` of R^`dim` through the origin.
pub fn triangle_grid(dim: usize, axes: [usize; 2], side: usize, spacing: f64) -> Obstacle {
    let mut vertices = Vec::with_capacity(side * side);
    for a in 0..side {
        for b in 0..side {
            let mut x = vec![0.0; dim];
            x[axes[0]] = a as f64 * spacing;
            x[axes[1]] = b as f64 * spacing;
            vertices.push(x);
        }
    }
    let v = |a: usize, b: usize| a * side + b;
    let mut simplices = Vec::with_capacity(2 * side.saturating_sub(1).pow(2));
    for a in 0..side.saturating_sub(1) {
        for b in 0..side - 1 {
            simplices.push(vec![v(a, b), v(a + 1, b), v(a, b + 1)]);
            simplices.push(vec![v(a + 1, b), v(a + 1, b + 1), v(a, b + 1)]);
        }
    }
    Obstacle::SimplexMesh {
        vertices,
        simplices,
        friction: 0.0,
        motion: Vec::new(),
    }
}

impl SceneBuilder {
    /// Adds [`triangle_grid`] of this scene's dimension as an obstacle;
    /// returns its index.
    pub fn triangle_grid(&mut self, axes: [usize; 2], side: usize, spacing: f64) -> usize {
        let grid = triangle_grid(self.scene().dim, axes, side, spacing);
        let obstacles = &mut self.scene_mut().obstacles;
        obstacles.push(grid);
        obstacles.len() - 1
    }
}

#[cfg(test)]
mod tests {
    use super::triangle_grid;
    use crate::Obstacle;

    #[test]
    fn a_three_by_three_grid_has_eight_triangles_in_its_plane() {
        let Obstacle::SimplexMesh {
            vertices,
            simplices,
            ..
        } = triangle_grid(3, [0, 2], 3, 0.5)
        else {
            unreachable!("triangle_grid builds a simplex mesh")
        };
        assert_eq!(vertices.len(), 9);
        assert_eq!(vertices[5], vec![0.5, 0.0, 1.0]);
        assert_eq!(simplices.len(), 8);
        assert_eq!(simplices[0], vec![0, 3, 1]);
        assert_eq!(simplices[7], vec![7, 8, 5]);
    }
}
