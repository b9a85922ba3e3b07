//! The linear patch test: a Kuhn-triangulated block of a hyperelastic law
//! whose boundary nodes are held on a homogeneous deformation x = F X.
//!
//! ```text
//! nodes      X on a grid of `cells` + 1 per axis, `spacing` apart (the rest shape)
//! boundary   nodes on the block's faces: fixed at F X
//! interior   dynamic (`mass` each), started at X or at F X
//! exact      x = F X for every node: the strain is the same in every
//!            simplex, so the elastic forces cancel at every interior node
//!            (for any hyperelastic law)
//! ```
//! The scene is authored at X (so the rest shapes are X's); [`Patch::state`]
//! moves the boundary (and, if asked, the interior) onto F X.

use super::grid::coords_of;
use super::kuhn::kuhn_grid_elements;
use crate::{
    ConstraintFamily, ConstraintKind, Convergence, Damping, IncrementalPotentialSettings, Particle,
    Scene, Solver, State,
};

/// A patch test to build.
#[derive(Debug, Clone)]
pub struct PatchSpec {
    /// Cells along each of the N axes.
    pub cells: Vec<usize>,
    /// Cell edge length.
    pub spacing: f64,
    /// `stvk` or `neo_hookean`.
    pub law: ConstraintKind,
    /// Young's modulus E.
    pub youngs_modulus: f64,
    /// Poisson ratio ν.
    pub poisson_ratio: f64,
    /// Mass of each interior node.
    pub mass: f64,
    /// F, N × N, row-major (x_a = Σ_b F_ab X_b).
    pub deformation: Vec<f64>,
}

impl PatchSpec {
    /// The stressed patch of docs/equilibria.md in R^dim: 4 cells per axis
    /// in 2D, 3 in 3D, 2 from 4D on; 0.1 m cells, E = 1e5 Pa, ν = 0.3,
    /// 0.05 kg per node, and
    /// F = I + 0.03 e0e0ᵀ − 0.02 e1e1ᵀ + 0.02 e0e1ᵀ + 0.01 e1e0ᵀ + 0.01 Σ_{a≥2} e_a e_aᵀ
    /// (a few % stretch and shear).
    pub fn stressed(dim: usize, law: ConstraintKind) -> Self {
        let cells = match dim {
            0..=2 => 4,
            3 => 3,
            _ => 2,
        };
        let mut f = vec![0.0; dim * dim];
        for a in 0..dim {
            f[a * dim + a] = if a >= 2 { 1.01 } else { 1.0 };
        }
        f[0] = 1.03;
        if dim >= 2 {
            f[dim + 1] = 0.98;
            f[1] = 0.02;
            f[dim] = 0.01;
        }
        PatchSpec {
            cells: vec![cells; dim],
            spacing: 0.1,
            law,
            youngs_modulus: 1e5,
            poisson_ratio: 0.3,
            mass: 0.05,
            deformation: f,
        }
    }
}

/// A built patch test.
#[derive(Debug, Clone)]
pub struct Patch {
    /// The scene (authored at X; boundary nodes fixed; damping 5 /s; no
    /// gravity).
    pub scene: Scene,
    /// Whether each node is on the boundary.
    pub boundary: Vec<bool>,
    /// F X, flat.
    pub target: Vec<f64>,
}

impl Patch {
    /// Builds `spec` with `dt`, `substeps` and `iterations`.
    pub fn new(spec: &PatchSpec, dt: f64, substeps: u32, iterations: u32) -> Patch {
        let dim = spec.cells.len();
        let nodes: Vec<usize> = spec.cells.iter().map(|c| c + 1).collect();
        let total: usize = nodes.iter().product();
        let mut scene = Scene::new(dim, dt, substeps, iterations);
        scene.damping = Some(Damping { rate: 5.0 });
        let (mut boundary, mut target) =
            (Vec::with_capacity(total), Vec::with_capacity(total * dim));
        for i in 0..total {
            let c = coords_of(i, &nodes);
            let x: Vec<f64> = c.iter().map(|&k| spec.spacing * k as f64).collect();
            for a in 0..dim {
                target.push((0..dim).map(|b| spec.deformation[a * dim + b] * x[b]).sum());
            }
            let on_face = c.iter().zip(&spec.cells).any(|(&k, &n)| k == 0 || k == n);
            boundary.push(on_face);
            scene.particles.push(if on_face {
                Particle::fixed(x)
            } else {
                Particle::new(x, spec.mass)
            });
        }
        scene.constraints.push(ConstraintFamily::material(
            spec.law,
            spec.youngs_modulus,
            spec.poisson_ratio,
            kuhn_grid_elements(&spec.cells, 0),
        ));
        Patch {
            scene,
            boundary,
            target,
        }
    }

    /// Steps the patch on the implicit path instead (one Newton
    /// minimisation per substep, stopped at an acceleration residual of
    /// 1e-9 m/s², ≤ 50 iterations), without damping, which that path
    /// refuses: backward Euler's own equilibrium, the reference.
    pub fn use_implicit_path(&mut self) {
        self.scene.damping = None;
        self.scene.solver = Solver::IncrementalPotential(IncrementalPotentialSettings {
            barrier_stiffness: 1e3,
            activation_distance: 1e-3,
            convergence: Convergence::MaxAccelerationResidual { tolerance: 1e-9 },
            max_iterations: 50,
            cg_iterations: None,
            warm_start: None,
            friction_slip_velocity: None,
        });
    }

    /// The start: boundary on F X, the interior on F X (`at_target`) or
    /// on X; at rest.
    pub fn state(&self, at_target: bool) -> State {
        let dim = self.scene.dim;
        let mut positions = Vec::with_capacity(self.target.len());
        for (i, p) in self.scene.particles.iter().enumerate() {
            let on_target = self.boundary[i] || at_target;
            positions.extend_from_slice(if on_target {
                &self.target[i * dim..(i + 1) * dim]
            } else {
                &p.position
            });
        }
        State {
            dim,
            velocities: vec![0.0; positions.len()],
            positions,
        }
    }

    /// max over interior nodes of |x_i − F X_i| (Euclidean).
    pub fn interior_error(&self, positions: &[f64]) -> f64 {
        let dim = self.scene.dim;
        (0..self.boundary.len())
            .filter(|&i| !self.boundary[i])
            .map(|i| {
                (0..dim)
                    .map(|a| (positions[i * dim + a] - self.target[i * dim + a]).powi(2))
                    .sum::<f64>()
                    .sqrt()
            })
            .fold(0.0, f64::max)
    }
}
