//! Validation of prescribed motion lists (`motion.rs`).
//!
//! ```text
//! translate   velocity: dim finite numbers
//! rotate      plane [i, j]: i ≠ j, both < dim;  center: dim finite;  rate finite
//! keyframes   times: ≥ 1, finite, strictly increasing;
//!             translations: one per time, dim finite numbers each
//! ```
//! (Only fixed particles take a motion: `validate.rs` checks that.)

use crate::motion::Motion;
use crate::{Scene, SceneError};

impl Scene {
    /// Checks the motion list `motions` at `path` (`particles[1].motion`).
    pub(crate) fn validate_motion(&self, path: &str, motions: &[Motion]) -> Result<(), SceneError> {
        validate(path, motions, self.dim)
    }
}

/// Checks a motion list at `path` (`obstacles[0].motion`).
fn validate(path: &str, motions: &[Motion], dim: usize) -> Result<(), SceneError> {
    let finite = |path: String, value: f64| {
        if value.is_finite() {
            Ok(())
        } else {
            Err(SceneError::NonFinite { path, value })
        }
    };
    for (m, motion) in motions.iter().enumerate() {
        let at = |field: &str| format!("{path}[{m}].{field}");
        match motion {
            Motion::Translate { velocity } => {
                crate::validate::vector(&at("velocity"), velocity, dim)?
            }
            Motion::Rotate {
                plane,
                center,
                rate,
            } => {
                for (k, &axis) in plane.iter().enumerate() {
                    if axis >= dim {
                        return Err(SceneError::Inconsistent {
                            path: at(&format!("plane[{k}]")),
                            why: format!("axis {axis} is not below the dimension {dim}"),
                        });
                    }
                }
                if plane[0] == plane[1] {
                    return Err(SceneError::Inconsistent {
                        path: at("plane"),
                        why: format!("the two axes must differ, both are {}", plane[0]),
                    });
                }
                crate::validate::vector(&at("center"), center, dim)?;
                finite(at("rate"), *rate)?;
            }
            Motion::Keyframes {
                times,
                translations,
            } => {
                if times.is_empty() {
                    return Err(SceneError::Inconsistent {
                        path: at("times"),
                        why: "keyframes need at least one time".into(),
                    });
                }
                for (k, &t) in times.iter().enumerate() {
                    finite(at(&format!("times[{k}]")), t)?;
                    if k > 0 && t <= times[k - 1] {
                        return Err(SceneError::Inconsistent {
                            path: at(&format!("times[{k}]")),
                            why: format!(
                                "keyframe times must increase strictly, {t} follows {}",
                                times[k - 1]
                            ),
                        });
                    }
                }
                if translations.len() != times.len() {
                    return Err(SceneError::Inconsistent {
                        path: at("translations"),
                        why: format!(
                            "{} translations for {} times (one per time)",
                            translations.len(),
                            times.len()
                        ),
                    });
                }
                for (k, v) in translations.iter().enumerate() {
                    crate::validate::vector(&at(&format!("translations[{k}]")), v, dim)?;
                }
            }
        }
    }
    Ok(())
}
