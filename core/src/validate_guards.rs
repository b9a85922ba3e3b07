//! Validation of `guards` and `adaptive`.
//!
//! ```text
//! guards.min_measure_ratio   in (0, 1]
//! guards.max_speed           > 0, finite
//! guards                     XPBD path only (the barrier path has its own
//!                            filter and no constraint families)
//! adaptive.max_subdivisions  in 1 ..= MAX_SUBDIVISIONS, substeps · 2^k < 2^32;
//!                            needs `guards` or a moving simplex mesh (its reach
//!                            guard: only a guard rejection is retried)
//! ```

use crate::guard_rules::MAX_SUBDIVISIONS;
use crate::{Scene, SceneError};

impl Scene {
    pub(crate) fn validate_guards(&self) -> Result<(), SceneError> {
        if let Some(guards) = &self.guards {
            if let Some(r) = guards.min_measure_ratio
                && !(r > 0.0 && r <= 1.0)
            {
                return Err(SceneError::OutOfRange {
                    path: "guards.min_measure_ratio".into(),
                    value: r,
                    range: "(0, 1]",
                });
            }
            if let Some(v) = guards.max_speed
                && !(v > 0.0 && v.is_finite())
            {
                return Err(SceneError::OutOfRange {
                    path: "guards.max_speed".into(),
                    value: v,
                    range: "(0, inf)",
                });
            }
            if !matches!(self.solver, crate::Solver::Xpbd(_)) {
                return Err(SceneError::UnsupportedBySolver {
                    path: "guards".into(),
                    solver: "incremental_potential",
                    why: "guards check XPBD substeps (the barrier path keeps feasibility with its step filter)".into(),
                });
            }
        }
        if let Some(adaptive) = &self.adaptive {
            let k = adaptive.max_subdivisions;
            if !(1..=MAX_SUBDIVISIONS).contains(&k) {
                return Err(SceneError::OutOfRange {
                    path: "adaptive.max_subdivisions".into(),
                    value: f64::from(k),
                    range: "1 ..= 16",
                });
            }
            if self
                .substeps
                .checked_shl(k)
                .is_none_or(|s| s >> k != self.substeps)
            {
                return Err(SceneError::Inconsistent {
                    path: "adaptive.max_subdivisions".into(),
                    why: format!(
                        "substeps {} times 2^{k} does not fit in 32 bits",
                        self.substeps
                    ),
                });
            }
            let moving_mesh = self.obstacles.iter().any(
                |o| matches!(o, crate::Obstacle::SimplexMesh { motion, .. } if !motion.is_empty()),
            );
            if self.guards.is_none() && !moving_mesh {
                return Err(SceneError::Inconsistent {
                    path: "adaptive".into(),
                    why: "needs \"guards\" or a moving simplex_mesh: only a guard rejection is \
                          retried"
                        .into(),
                });
            }
        }
        Ok(())
    }
}
