//! `CgState` of shaders/coupled.wgsl on the host: PCG's scalar state on
//! the device (pcg.rs), its bytes, and the report it ends in.
//!
//! ```text
//! words  pq_at, rr_at, rz_at (tree offsets of p·q, r·r, r·z), iterations,
//!        max_iterations, status (0 running, 1 converged, 2 non-finite,
//!        3 non-positive curvature, 4 budget exhausted), stopped, pad
//! reals  ρ, tolerance, the last p·q, the last ‖r‖, α, β   (the set's precision)
//! ```

use hyperpbd_core::GpuError;
use hyperpbd_core::implicit::{PcgReport, PcgStatus};

use crate::Precision;
use crate::kernel_set::BlockWriter;
use crate::params::{read_reals, real_size};

/// Words of `CgState` before its reals.
const WORDS: usize = 8;
/// Reals of `CgState`.
const REALS: usize = 6;

/// `CgState` of shaders/coupled.wgsl, host side.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct CgState {
    /// Tree offsets of p·q, r·r and r·z.
    pub at: [u32; 3],
    pub iterations: u32,
    pub max_iterations: u32,
    /// 0 running, 1 converged, 2 non-finite, 3 non-positive curvature,
    /// 4 budget exhausted.
    pub status: u32,
    pub stopped: u32,
    pub rho: f64,
    pub tolerance: f64,
    pub curvature: f64,
    pub residual: f64,
    pub alpha: f64,
    pub beta: f64,
}

impl CgState {
    /// The block's bytes in `precision`.
    pub fn bytes(&self, precision: Precision) -> Vec<u8> {
        let [pq, rr, rz] = self.at;
        BlockWriter::new(precision)
            .words(&[
                pq,
                rr,
                rz,
                self.iterations,
                self.max_iterations,
                self.status,
                self.stopped,
                0,
            ])
            .reals(&[
                self.rho,
                self.tolerance,
                self.curvature,
                self.residual,
                self.alpha,
                self.beta,
            ])
            .finish()
    }

    pub fn len(precision: Precision) -> u64 {
        (4 * WORDS + REALS * real_size(precision)) as u64
    }

    pub fn parse(bytes: &[u8], precision: Precision) -> CgState {
        let word = |k: usize| {
            u32::from_le_bytes([
                bytes[4 * k],
                bytes[4 * k + 1],
                bytes[4 * k + 2],
                bytes[4 * k + 3],
            ])
        };
        let reals = read_reals(&bytes[4 * WORDS..Self::len(precision) as usize], precision);
        CgState {
            at: [word(0), word(1), word(2)],
            iterations: word(3),
            max_iterations: word(4),
            status: word(5),
            stopped: word(6),
            rho: reals[0],
            tolerance: reals[1],
            curvature: reals[2],
            residual: reals[3],
            alpha: reals[4],
            beta: reals[5],
        }
    }

    /// The report of a stopped solve that started at ‖b‖ = `initial`.
    pub fn report(&self, initial: f64) -> Result<PcgReport, GpuError> {
        let status = match self.status {
            1 => PcgStatus::Converged,
            2 => PcgStatus::NonFinite,
            3 => PcgStatus::NonPositiveCurvature {
                curvature: self.curvature,
            },
            4 => PcgStatus::BudgetExhausted,
            other => {
                return Err(GpuError::Other {
                    message: format!("the device's PCG stopped with unknown status {other}"),
                });
            }
        };
        Ok(PcgReport {
            status,
            iterations: self.iterations,
            initial_residual: initial,
            final_residual: self.residual,
        })
    }
}
