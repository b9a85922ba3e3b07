//! Builders for real scenes: particle grids with edge springs (cloth is a
//! 2-grid in R^3), Kuhn-simplexized soft N-cuboids, chains, tethers, and
//! triangulated squares as simplex-mesh obstacles, and the linear patch
//! test of a hyperelastic law.

mod chain;
mod grid;
mod kuhn;
mod patch;
mod tether;
mod triangle_grid;

pub use chain::ChainSpec;
pub use grid::{Grid, GridSpec, coords_of};
pub use kuhn::{BlockSpec, kuhn_grid_elements, kuhn_simplices};
pub use patch::{Patch, PatchSpec};
pub use triangle_grid::triangle_grid;

use crate::{ConstraintFamily, Damping, Obstacle, Particle, Scene};

/// Assembles a [`Scene`] piece by piece. `build` validates.
#[derive(Debug, Clone)]
pub struct SceneBuilder {
    scene: Scene,
}

impl SceneBuilder {
    /// An empty scene in R^dim: dt 1/60, 1 substep, 1 iteration, no gravity.
    pub fn new(dim: usize) -> Self {
        SceneBuilder {
            scene: Scene::new(dim, 1.0 / 60.0, 1, 1),
        }
    }

    /// Step length.
    pub fn dt(mut self, dt: f64) -> Self {
        self.scene.dt = dt;
        self
    }

    /// Substeps per step.
    pub fn substeps(mut self, substeps: u32) -> Self {
        self.scene.substeps = substeps;
        self
    }

    /// Projection iterations per substep.
    pub fn iterations(mut self, iterations: u32) -> Self {
        self.scene.iterations = iterations;
        self
    }

    /// Gravity vector.
    pub fn gravity(mut self, gravity: Vec<f64>) -> Self {
        self.scene.gravity = Some(gravity);
        self
    }

    /// Gravity of magnitude `g` along −axis.
    pub fn gravity_along(self, axis: usize, g: f64) -> Self {
        let mut v = vec![0.0; self.scene.dim];
        if let Some(x) = v.get_mut(axis) {
            *x = -g;
        }
        self.gravity(v)
    }

    /// Exponential damping rate (1/s).
    pub fn damping(mut self, rate: f64) -> Self {
        self.scene.damping = Some(Damping { rate });
        self
    }

    /// Adds a particle; returns its index.
    pub fn particle(&mut self, particle: Particle) -> usize {
        self.scene.particles.push(particle);
        self.scene.particles.len() - 1
    }

    /// Adds a constraint family; returns its index.
    pub fn family(&mut self, family: ConstraintFamily) -> usize {
        self.scene.constraints.push(family);
        self.scene.constraints.len() - 1
    }

    /// Adds a hyperplane n·x ≥ offset with friction μ and zero compliance.
    pub fn hyperplane(&mut self, normal: Vec<f64>, offset: f64, friction: f64) -> usize {
        self.scene.obstacles.push(Obstacle::Hyperplane {
            normal,
            offset,
            friction,
            compliance: 0.0,
            motion: Vec::new(),
        });
        self.scene.obstacles.len() - 1
    }

    /// Marks particle `i` fixed (keeps its mass as evidence).
    pub fn fix(&mut self, i: usize) {
        if let Some(p) = self.scene.particles.get_mut(i) {
            p.fixed = true;
            p.velocity = None;
        }
    }

    /// The scene so far (unvalidated).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Mutable access for anything the builder does not cover.
    pub fn scene_mut(&mut self) -> &mut Scene {
        &mut self.scene
    }

    /// Validates and returns the scene.
    pub fn build(self) -> Result<Scene, crate::SceneError> {
        self.scene.validate()?;
        Ok(self.scene)
    }
}
