//! The CPU/GPU divergence bound of the incremental-potential path.
//!
//! Both backends minimise the same F; each minimisation reports its final
//! residual r, and r bounds the distance of the returned iterate to the
//! minimiser (F_i is m_i-strongly convex with planes: b is convex in a
//! linear d). So per substep the two iterates differ by at most
//!
//! ```text
//! x_err(r)  max_acceleration_residual:  |g_i| ≤ r m_i h²  → |x − x*| ≤ r h² / μ
//!           packed_gradient:            |g_i| ≤ r         → |x − x*| ≤ r / (m_min μ)
//!           μ = 1/2: near a simplex the tangential curvature h² b'/ρ is negative;
//!           the model assumes it eats at most half of m_i
//! δ_k     = x_err(r_cpu) + x_err(r_gpu) + 16 ε X           (X: largest coordinate)
//! ```
//! (r may exceed the tolerance where a run ended at its rounding floor: the
//! reported residual is used, never the tolerance.) An iterate error feeds
//! the velocity (v = (x − x_prev)/h) and, through x~ = x + h v, the later
//! substeps: with implicit Euler stable, velocity errors add up and
//! positions integrate them:
//!
//! ```text
//! D_S = Σ_{k ≤ S} δ_k        position bound P_S = Σ_{k ≤ S} D_k        velocity bound 2 P_S / h
//! ```
//! (δ constant gives P_S = δ S (S + 1) / 2.) [`BarrierErrorModel::advance`]
//! sums from the start of a run; as a [`DivergenceModel`] (both runs
//! restarted every frame from the other run's previous state) the sums
//! start at 0 every frame and run over that frame's substeps.

use hyperpbd_core::{BackendError, Convergence, MinimisationReport, Plan, Precision};

use crate::compare::{DivergenceModel, Frame};

/// Divergence model of one incremental-potential plan at one precision,
/// advanced step by step with both backends' reports.
#[derive(Debug, Clone, PartialEq)]
pub struct BarrierErrorModel {
    /// ε of the compared precision.
    pub epsilon: f64,
    /// x_err per unit residual (h²/μ or 1/(m_min μ)).
    pub position_per_residual: f64,
    /// Substep length.
    pub h: f64,
    /// Σ δ so far.
    accumulated: f64,
    /// Σ of the running Σ δ: the position bound.
    position: f64,
}

impl BarrierErrorModel {
    /// The model of `plan` (an incremental-potential plan) at `precision`.
    pub fn new(plan: &Plan, precision: Precision) -> Self {
        let modulus = 0.5;
        let lightest = plan
            .inverse_mass
            .iter()
            .filter(|&&w| w > 0.0)
            .map(|&w| 1.0 / w)
            .fold(f64::INFINITY, f64::min);
        let position_per_residual = match plan.incremental_potential().map(|ip| ip.convergence) {
            Some(Convergence::MaxAccelerationResidual { .. }) => plan.h * plan.h / modulus,
            Some(Convergence::PackedGradient { .. }) if lightest.is_finite() => {
                1.0 / (lightest * modulus)
            }
            _ => 0.0,
        };
        BarrierErrorModel {
            epsilon: precision.epsilon(),
            position_per_residual,
            h: plan.h,
            accumulated: 0.0,
            position: 0.0,
        }
    }

    /// Adds one step: the substep reports of the golden run and of the other
    /// run (paired in order), with coordinates up to `scale`.
    pub fn advance(
        &mut self,
        golden: &[MinimisationReport],
        other: &[MinimisationReport],
        scale: f64,
    ) {
        let residual = |m: &MinimisationReport| m.final_residual.unwrap_or(0.0);
        for (a, b) in golden.iter().zip(other) {
            let delta = self.position_per_residual * (residual(a) + residual(b))
                + 16.0 * self.epsilon * scale;
            self.accumulated += delta;
            self.position += self.accumulated;
        }
    }

    /// The sums restarted: a comparison from a common state.
    pub fn restart(&mut self) {
        self.accumulated = 0.0;
        self.position = 0.0;
    }

    /// Position bound after the steps advanced so far.
    pub fn position_bound(&self) -> f64 {
        self.position
    }

    /// Velocity bound after the steps advanced so far.
    pub fn velocity_bound(&self) -> f64 {
        2.0 * self.position / self.h
    }
}

impl DivergenceModel for BarrierErrorModel {
    fn frame_bounds(&mut self, frame: Frame<'_>) -> Result<(f64, f64), BackendError> {
        let scale = frame
            .states()
            .iter()
            .map(|s| crate::compare::coordinate_scale(s))
            .fold(0.0, f64::max);
        self.restart();
        self.advance(
            &frame.golden.0.minimisation,
            &frame.other.0.minimisation,
            scale,
        );
        Ok((self.position_bound(), self.velocity_bound()))
    }

    fn describe(&self) -> String {
        format!(
            "per-frame barrier-path bound = double sum over the frame's substeps of ({:e} x (r_cpu + r_gpu) + 16 eps {:e} x scale)",
            self.position_per_residual, self.epsilon
        )
    }
}
