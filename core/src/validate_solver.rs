//! Validation of the solver choice and of barrier obstacles.
//!
//! ```text
//! xpbd:                   no simplex_mesh with "primal_residual": true
//! incremental_potential:  no `motion` (obstacles or pins), κ > 0, d^ > 0, tolerance > 0, max_iterations ≥ 1;
//!                         cg_iterations ≥ 1, friction_slip_velocity > 0 (when given);
//!                         geometric constraint families with compliance α > 0
//!                         (springs C²/(2α); expression families with a ∇²C within
//!                         the tape limits; α = 0 is no energy; material families
//!                         carry their law's energy), no damping, hyperplanes
//!                         without compliance, simplex meshes without friction;
//!                         every free particle starts at d > 0 from every obstacle
//! simplex_mesh:           arity 2…4 (≤ dim + 1), one arity per mesh, indices in
//!                         range and distinct, k-measure above
//!                         DEGENERATE_VOLUME_RATIO · (longest edge)^k / k!
//! ```

use crate::barrier::BarrierObstacles;
use crate::geometry::{DEGENERATE_VOLUME_RATIO, determinant, factorial};
use crate::{Obstacle, Scene, SceneError, Solver};

const IP: &str = "incremental_potential";

/// Why the implicit paths refuse a `motion` key.
const MOTION_ON_XPBD_ONLY: &str = "prescribed motion runs on the XPBD path only so far (the \
     barrier's step filter and the implicit friction assume static obstacles)";

fn positive(path: &str, value: f64) -> Result<(), SceneError> {
    if !value.is_finite() {
        return Err(SceneError::NonFinite {
            path: path.into(),
            value,
        });
    }
    if value <= 0.0 {
        return Err(SceneError::NonPositive {
            path: path.into(),
            value,
        });
    }
    Ok(())
}

impl Scene {
    /// The path of the first `motion` key (particles first, then obstacles).
    fn first_motion(&self) -> Option<String> {
        if let Some(i) = self.particles.iter().position(|p| !p.motion.is_empty()) {
            return Some(format!("particles[{i}].motion"));
        }
        let obstacle = self.obstacles.iter().position(|o| match o {
            Obstacle::Hyperplane { motion, .. } | Obstacle::SimplexMesh { motion, .. } => {
                !motion.is_empty()
            }
        });
        obstacle.map(|o| format!("obstacles[{o}].motion"))
    }

    pub(crate) fn validate_solver(&self) -> Result<(), SceneError> {
        let Solver::IncrementalPotential(settings) = &self.solver else {
            if let Solver::Xpbd(xpbd) = &self.solver
                && xpbd.primal_residual
                && let Some(path) = self.first_motion()
            {
                return Err(SceneError::UnsupportedBySolver {
                    path,
                    solver: "xpbd",
                    why: "prescribed motion does not run with \"primal_residual\": true yet (its \
                          carried forces assume static planes)"
                        .into(),
                });
            }
            if let Solver::Xpbd(xpbd) = &self.solver
                && xpbd.primal_residual
                && let Some(o) =
                    (self.obstacles.iter()).position(|o| matches!(o, Obstacle::SimplexMesh { .. }))
            {
                return Err(SceneError::UnsupportedBySolver {
                    path: format!("obstacles[{o}]"),
                    solver: "xpbd",
                    why: "a simplex_mesh contact does not run with \"primal_residual\": true yet \
                          (its carried displacement assumes a fixed normal)"
                        .into(),
                });
            }
            return Ok(());
        };
        positive("solver.barrier_stiffness", settings.barrier_stiffness)?;
        positive("solver.activation_distance", settings.activation_distance)?;
        positive(
            "solver.convergence.tolerance",
            settings.convergence.tolerance(),
        )?;
        if settings.max_iterations == 0 {
            return Err(SceneError::NonPositive {
                path: "solver.max_iterations".into(),
                value: 0.0,
            });
        }
        if settings.cg_iterations == Some(0) {
            return Err(SceneError::NonPositive {
                path: "solver.cg_iterations".into(),
                value: 0.0,
            });
        }
        if let Some(slip) = settings.friction_slip_velocity {
            positive("solver.friction_slip_velocity", slip)?;
        }
        let unsupported = |path: String, why: &str| SceneError::UnsupportedBySolver {
            path,
            solver: IP,
            why: why.into(),
        };
        for (f, family) in self.constraints.iter().enumerate() {
            // An expression family's spring needs its ∇²C: derived here, once,
            // so a tape over the limits is refused at load with its path.
            let arity = family.elements.first().map_or(0, Vec::len);
            if arity > 0
                && let Some(expression) =
                    crate::kinds::expression_of(f, family, arity, self.dim, |i| {
                        &self.particles[i].position
                    })?
                && let Err(source) = expression.hessian_tape()
            {
                // Bending is an expression the kind defines, not the scene.
                let bending = family.kind == crate::ConstraintKind::Bending;
                let field = if bending { "type" } else { "value" };
                return Err(SceneError::Expression {
                    path: format!("constraints[{f}].{field}"),
                    source: Box::new(source),
                });
            }
            // A material family's energy is its law's (compliance is not read).
            if family.kind.law().is_none()
                && family.compliance == 0.0
                && !family.elements.is_empty()
            {
                return Err(unsupported(
                    format!("constraints[{f}].compliance"),
                    "a constraint is the spring C²/(2α) of the incremental potential, and α = 0 \
                     is no energy; give compliance > 0, e.g. 1e-8 (m/N for distance and tether: \
                     a 0.1 m link holding 1 kg then stretches 1e-7 m)",
                ));
            }
        }
        if self.damping.is_some() {
            return Err(unsupported(
                "damping".into(),
                "velocity damping is not a term of the incremental potential",
            ));
        }
        for (o, obstacle) in self.obstacles.iter().enumerate() {
            if let Obstacle::Hyperplane { compliance, .. } = obstacle
                && *compliance != 0.0
            {
                return Err(unsupported(
                    format!("obstacles[{o}].compliance"),
                    "a barrier obstacle has no compliance (κ and d^ set its stiffness)",
                ));
            }
        }
        if let Some(path) = self.first_motion() {
            return Err(unsupported(path, MOTION_ON_XPBD_ONLY));
        }
        let obstacles = BarrierObstacles::compile(self);
        for (i, p) in self.particles.iter().enumerate() {
            if p.fixed {
                continue;
            }
            if let Some((o, distance)) = obstacles.first_infeasible(&p.position, p.radius) {
                return Err(SceneError::BarrierInfeasible {
                    path: format!("particles[{i}].position"),
                    obstacle: obstacles.source(o) as usize,
                    distance,
                });
            }
        }
        Ok(())
    }
}

/// Checks one simplex mesh's connectivity and geometry (vertex vectors are
/// already checked).
pub(crate) fn validate_simplex_mesh(
    o: usize,
    vertices: &[Vec<f64>],
    simplices: &[Vec<usize>],
) -> Result<(), SceneError> {
    let dim = vertices.first().map_or(0, Vec::len);
    let first_arity = simplices.first().map_or(0, Vec::len);
    for (s, simplex) in simplices.iter().enumerate() {
        let path = format!("obstacles[{o}].simplices[{s}]");
        let largest = 4.min(dim + 1);
        if !(2..=largest).contains(&simplex.len()) || simplex.len() != first_arity {
            return Err(SceneError::WrongSimplexArity {
                path,
                expected: format!(
                    "2..={largest} (segments, triangles, tetrahedra; at most dim + 1), \
                     the same for every simplex ({first_arity} in simplices[0])"
                ),
                found: simplex.len(),
            });
        }
        for (j, &index) in simplex.iter().enumerate() {
            if index >= vertices.len() {
                return Err(SceneError::VertexOutOfRange {
                    path: format!("{path}[{j}]"),
                    index,
                    count: vertices.len(),
                });
            }
            if simplex[..j].contains(&index) {
                return Err(SceneError::DegenerateSimplex {
                    path: format!("{path}[{j}]"),
                    why: format!("vertex {index} appears twice"),
                });
            }
        }
        let k = simplex.len() - 1;
        let origin = &vertices[simplex[0]];
        let edge = |j: usize, a: usize| vertices[simplex[j]][a] - origin[a];
        let mut gram = vec![0.0; k * k];
        for s1 in 0..k {
            for s2 in 0..k {
                gram[s1 * k + s2] = (0..dim).map(|a| edge(s1 + 1, a) * edge(s2 + 1, a)).sum();
            }
        }
        let mut longest: f64 = 0.0;
        for &i in simplex {
            for &j in simplex {
                let d2: f64 = (0..dim)
                    .map(|a| (vertices[i][a] - vertices[j][a]).powi(2))
                    .sum();
                longest = longest.max(d2.sqrt());
            }
        }
        let measure = determinant(&mut gram, k).max(0.0).sqrt() / factorial(k);
        let floor = DEGENERATE_VOLUME_RATIO * longest.powi(k as i32) / factorial(k);
        if !measure.is_finite() || measure <= floor {
            return Err(SceneError::DegenerateSimplex {
                path,
                why: format!(
                    "its {k}-measure {measure:e} is not above the degeneracy floor {floor:e}"
                ),
            });
        }
    }
    Ok(())
}
