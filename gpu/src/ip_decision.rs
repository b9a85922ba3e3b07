//! Newton's stop test of the incremental-potential path on the device
//! (`ip_decide`, shaders/incremental_potential.wgsl), so that a substep
//! waits on the host once instead of once per Newton iteration.
//!
//! ```text
//! chunk        [ip_gradient, reductions, ip_decide, ip_newton] × k, ip_velocity;
//!              one read of the decision block; k: the last substep's evaluations
//!              (at least 2), doubled per chunk, never past max_iterations + 1
//! ip_decide    after evaluation j: log (terms[0], status[0..4]); stop on
//!              status[2] or status[1] ≠ NONE (refused), j > 0 ∧ status[0] = 0
//!              (the rounding floor if status[3] = 0, else refused: no descent),
//!              value ≤ threshold (converged), j = max (budget)
//! threshold    the largest real v with residual(v) ≤ tolerance, where the host's
//!              residual is √v in f64 (packed) or v (acceleration):
//!              v ≤ threshold ⟺ residual(v) ≤ tolerance for every real v ≥ 0
//!              (√ is monotone), so the device's test is the host's, bit for bit
//! host         replays its own loop over the log (the same branches and core's
//!              record_residual) for the report, and refuses a log whose last
//!              evaluation is not where that loop stops (GpuError::Other)
//! ```
//! The kernels after a stop do nothing (every entry point checks the flag
//! first), so the iterates are exactly those of the host-decided loop.

use hyperpbd_core::{Convergence, GpuError};

use crate::Precision;
use crate::params::read_reals;

/// Words before the per-evaluation status words.
pub(crate) const HEADER_WORDS: usize = 4;
/// Status words logged per evaluation.
pub(crate) const LOGGED_WORDS: usize = 4;

/// The largest real `v` (of `precision`) whose residual meets the
/// tolerance of `convergence` (module docs).
pub(crate) fn threshold(convergence: Convergence, precision: Precision) -> f64 {
    let (tolerance, packed) = match convergence {
        Convergence::PackedGradient { tolerance } => (tolerance, true),
        Convergence::MaxAccelerationResidual { tolerance } => (tolerance, false),
    };
    let meets = |v: f64| {
        let residual = if packed { v.sqrt() } else { v };
        residual <= tolerance
    };
    let single = precision == Precision::F32;
    let round = |v: f64| if single { v as f32 as f64 } else { v };
    // Neighbours of a non-negative real of the precision (+∞ above MAX).
    let up = |v: f64| {
        if single {
            f32::from_bits((v as f32).to_bits() + 1) as f64
        } else {
            f64::from_bits(v.to_bits() + 1)
        }
    };
    let down = |v: f64| {
        if single {
            f32::from_bits((v as f32).to_bits() - 1) as f64
        } else {
            f64::from_bits(v.to_bits() - 1)
        }
    };
    let guess = if packed {
        tolerance * tolerance
    } else {
        tolerance
    };
    let mut v = round(guess);
    while v > 0.0 && !meets(v) {
        v = down(v);
    }
    while v.is_finite() && meets(up(v)) {
        v = up(v);
    }
    v
}

/// One evaluation as the device logged it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Evaluation {
    /// status[0..4] after the gradient pass.
    pub status: [u32; LOGGED_WORDS],
    /// terms[0]: Σ|g|² (packed) or the largest acceleration residual.
    pub value: f64,
}

/// The decision block read back.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Decisions {
    /// Whether ip_decide stopped the loop.
    pub stopped: bool,
    /// The stop code: 0 none, 1 converged, 2 budget, 3 rounding floor,
    /// 4 refused.
    pub code: u32,
    /// Every evaluation so far, in order.
    pub evaluations: Vec<Evaluation>,
}

/// Parses the decision words and the logged values.
pub(crate) fn parse(words: &[u8], values: &[u8], precision: Precision) -> Decisions {
    let words: Vec<u32> = words
        .chunks_exact(4)
        .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
        .collect();
    let values = read_reals(values, precision);
    let count = (words.get(1).copied().unwrap_or(0) as usize).min(values.len());
    let evaluations = (0..count)
        .map(|k| {
            let at = HEADER_WORDS + LOGGED_WORDS * k;
            let mut status = [0; LOGGED_WORDS];
            status.copy_from_slice(&words[at..at + LOGGED_WORDS]);
            Evaluation {
                status,
                value: values[k],
            }
        })
        .collect();
    Decisions {
        stopped: words.first().is_some_and(|&w| w != 0),
        code: words.get(2).copied().unwrap_or(0),
        evaluations,
    }
}

/// The error of a log whose stop the host's loop does not reproduce.
pub(crate) fn disagreement(what: &str) -> GpuError {
    GpuError::Other {
        message: format!("the device's Newton stop test disagrees with the host's loop: {what}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The threshold is the boundary: it meets the tolerance, its next
    /// real up does not.
    #[test]
    fn thresholds_are_the_boundary_of_the_host_test() {
        for tolerance in [1e-8, 1e-4, 0.3, 1.0, 7.0e3] {
            for precision in [Precision::F32, Precision::F64] {
                let packed = threshold(Convergence::PackedGradient { tolerance }, precision);
                let above = match precision {
                    Precision::F32 => f32::from_bits((packed as f32).to_bits() + 1) as f64,
                    Precision::F64 => f64::from_bits(packed.to_bits() + 1),
                };
                assert!(packed.sqrt() <= tolerance, "{tolerance} {precision:?}");
                assert!(above.sqrt() > tolerance, "{tolerance} {precision:?}");
                let max = threshold(
                    Convergence::MaxAccelerationResidual { tolerance },
                    precision,
                );
                assert!(max <= tolerance);
                if precision == Precision::F64 {
                    assert_eq!(max, tolerance);
                } else {
                    assert!(f32::from_bits((max as f32).to_bits() + 1) as f64 > tolerance);
                }
            }
        }
    }
}
