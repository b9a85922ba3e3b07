//! What one incremental-potential minimisation reports.

use thiserror::Error;

use crate::Convergence;

/// How a minimisation ended.
#[derive(Debug, Clone, PartialEq)]
pub enum MinimisationStatus {
    /// The authored criterion held (possibly at the warm start).
    Converged,
    /// `max_iterations` Newton iterations ran without meeting the
    /// criterion. The iterate is kept: it is feasible (the filter certified
    /// every accepted step) and F never increased; the report says so.
    BudgetExhausted,
    /// The criterion did not hold, but every free particle is at its
    /// minimiser to the working precision: its gradient is zero or even its
    /// full Newton step x + Δ rounds back to x. The residual left is the
    /// rounding floor of the criterion (for the acceleration residual near
    /// contact ≈ b''(d) ε |x| / m). The iterate is kept and the report says
    /// so; lower precision or a stiffer contact raises that floor.
    RoundingFloor,
    /// The minimisation could not run or could not go on; the step fails
    /// and the state is rolled back.
    Refused(Refusal),
}

/// Why a minimisation was refused.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum Refusal {
    /// A free particle starts at d ≤ 0 from an obstacle: the barrier is
    /// undefined there and no step can be certified.
    #[error("particle {particle} starts at distance {distance:e} <= 0 from obstacles[{obstacle}]")]
    InfeasibleStart {
        particle: usize,
        obstacle: usize,
        distance: f64,
    },
    /// The objective or its gradient was not finite for a particle.
    #[error("particle {particle}: the objective or its gradient is not finite")]
    NonFinite { particle: usize },
    /// No free particle moved while the criterion still failed, and some
    /// particle's representable Newton step found no decrease of F.
    #[error(
        "no particle can decrease the objective (residual {residual:e}): a representable Newton step found no decrease"
    )]
    NoDescent { residual: f64 },
    /// Two balls start touching or overlapping (d ≤ 0): the ball–ball
    /// barrier is undefined there (coupled step, `collisions`).
    #[error("particles {first} and {second} start at ball distance {distance:e} <= 0")]
    OverlappingStart {
        first: usize,
        second: usize,
        distance: f64,
    },
    /// The first CG iteration of a Newton direction met non-positive or
    /// non-finite curvature pᵀHp (coupled step; H is SPD by construction,
    /// so this is rounding or bad input).
    #[error(
        "Newton iteration {iteration}: CG found curvature {curvature:e} at its first iteration"
    )]
    CurvatureBreakdown { iteration: u32, curvature: f64 },
    /// A material element is outside its law's domain at the step's start
    /// (coupled step; a Neo-Hookean J ≤ 0): its energy is +∞ there, so no
    /// iterate can be evaluated. Inside a line search the same refusal is
    /// only a rejected trial.
    #[error("{family_label} element {element}: {refusal} at the step's start")]
    Material {
        /// Index of the family in the plan.
        family: usize,
        /// `constraints[f]`.
        family_label: String,
        /// Element index in the authored order.
        element: usize,
        /// Which refusal, with the element's measure ratio J.
        refusal: crate::material::LawRefusal,
    },
}

/// The result of one minimisation (one substep of the barrier path).
#[derive(Debug, Clone, PartialEq)]
pub struct MinimisationReport {
    /// The authored criterion and its tolerance.
    pub criterion: Convergence,
    /// Residual at the warm start (None when refused before evaluation).
    pub initial_residual: Option<f64>,
    /// Residual at the returned iterate (None when refused before
    /// evaluation).
    pub final_residual: Option<f64>,
    /// Newton iterations run.
    pub iterations: u32,
    /// CG iterations of each Newton direction, in order (coupled step;
    /// empty on the per-particle minimiser, which solves each particle's
    /// N × N system directly).
    pub cg_iterations: Vec<u32>,
    /// How it ended.
    pub status: MinimisationStatus,
}

impl MinimisationReport {
    /// The report before the first Newton iteration: nothing evaluated,
    /// nothing run, `Converged` until an iteration says otherwise.
    pub fn before_first_iteration(criterion: Convergence) -> Self {
        Self {
            criterion,
            initial_residual: None,
            final_residual: None,
            iterations: 0,
            cg_iterations: Vec::new(),
            status: MinimisationStatus::Converged,
        }
    }

    /// Records the residual at Newton iteration `iteration` (the first
    /// one recorded is the initial residual) and, when it ends the
    /// minimisation, sets the status and returns true:
    ///
    /// ```text
    /// residual ≤ tolerance          → Converged
    /// iteration = max_iterations    → BudgetExhausted
    /// ```
    pub fn record_residual(&mut self, residual: f64, iteration: u32, max_iterations: u32) -> bool {
        self.initial_residual.get_or_insert(residual);
        self.final_residual = Some(residual);
        self.iterations = iteration;
        if residual <= self.criterion.tolerance() {
            self.status = MinimisationStatus::Converged;
            return true;
        }
        if iteration == max_iterations {
            self.status = MinimisationStatus::BudgetExhausted;
            return true;
        }
        false
    }
}
