//! CPU/GPU differential comparison and its derived error bounds.
//!
//! The GPU runs the plan's schedule with the CPU's arithmetic, so their
//! difference is rounding, and the bound is a rounding model, not a tuned
//! number. Comparisons restart the golden path every frame from the other
//! run's previous state and bound that one frame ([`DivergenceModel`]:
//! [`crate::compare_frame::FrameErrorModel`] for XPBD,
//! [`crate::compare_barrier::BarrierErrorModel`] for the incremental
//! potential). [`ErrorModel`] is the accumulated model, for comparisons
//! of two runs that cannot be restarted from each other (a scene against
//! its copy moved far from the origin):
//!
//! ```text
//! ε        unit roundoff of the GPU precision (f32: 2^-23, f64: 2^-52)
//! X        largest coordinate magnitude seen so far (absolute rounding of a
//!          position is relative to its magnitude, not to the scene size)
//! ops      roundings that reach one particle in one substep:
//!          8 (predict, velocity, friction, damping)
//!          + iterations × degree × 8 (each projection of an element that
//!            touches the particle: difference, length, C, Δλ, correction)
//!          degree = most elements (all families) sharing one particle
//!          + iterations × (8N + 40) with particle contact (one averaged
//!            gather-Jacobi pass per iteration: the pair terms in R^N and
//!            the gather, as in tests/gpu/collide.rs)
//! S        substeps run so far
//! position bound = ε · X · ops · S            (errors add, never cancel)
//! velocity bound = 2 · position bound / h     (v = (x − p) / h)
//! ```
//! The model assumes errors grow at most linearly, which holds for stable
//! (dissipative, resting, converging) scenes over the horizons tested. A
//! chaotic scene amplifies rounding exponentially; such scenes are compared
//! on short horizons or on invariants, and the tests say which. Particle
//! contact is also discontinuous: a pair within rounding of touching can be
//! active in one precision and not in the other, a jump of the size of the
//! overlap, not of ε — granular scenes are compared on invariants
//! (tests/gpu/granular.rs), and `compare` says so.

use hyperpbd_core::{BackendError, Plan, Precision, State, StepReport};

/// A bound on how far one frame of a run may be from one frame of the
/// golden path when both start from the same state (the run's own state of
/// the previous frame): [`crate::compare_frame::FrameErrorModel`] (XPBD, a
/// rounding count) and [`crate::compare_barrier::BarrierErrorModel`] (the
/// incremental potential, driven by both runs' residuals) serve one
/// comparison loop.
pub trait DivergenceModel {
    /// The (position, velocity) bounds of one frame run by the golden path
    /// and by the other run.
    fn frame_bounds(&mut self, frame: Frame<'_>) -> Result<(f64, f64), BackendError>;

    /// What the bound is, in one line (printed by `hyperpbd compare`).
    fn describe(&self) -> String;
}

/// One frame of a comparison: the state both runs start from, and the
/// golden path's and the other run's (report, state) after it.
#[derive(Debug, Clone, Copy)]
pub struct Frame<'a> {
    /// The other run's state of the previous frame.
    pub start: &'a State,
    /// The golden path's report and state.
    pub golden: (&'a StepReport, &'a State),
    /// The other run's report and state.
    pub other: (&'a StepReport, &'a State),
}

impl<'a> Frame<'a> {
    /// The start and both end states.
    pub fn states(&self) -> [&'a State; 3] {
        [self.start, self.golden.1, self.other.1]
    }
}

/// The rounding model of one plan at one precision.
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorModel {
    /// ε.
    pub epsilon: f64,
    /// Roundings reaching one particle per substep.
    pub ops_per_substep: f64,
    /// Substeps per step.
    pub substeps: u32,
    /// Substep length.
    pub h: f64,
}

/// Most elements (over all families) that share one particle.
pub fn max_degree(plan: &Plan) -> usize {
    let mut degree = vec![0usize; plan.particle_count()];
    for f in &plan.families {
        for &i in &f.elements {
            degree[i as usize] += 1;
        }
    }
    degree.into_iter().max().unwrap_or(0)
}

impl ErrorModel {
    /// The model of `plan` run at `precision`.
    pub fn new(plan: &Plan, precision: Precision) -> Self {
        let iterations = f64::from(plan.iterations);
        let contact = if plan.contacts.is_some() {
            iterations * (8.0 * plan.dim as f64 + 40.0)
        } else {
            0.0
        };
        ErrorModel {
            epsilon: precision.epsilon(),
            ops_per_substep: 8.0 + 8.0 * iterations * max_degree(plan) as f64 + contact,
            substeps: plan.substeps,
            h: plan.h,
        }
    }

    /// Position bound after `steps` steps with coordinates up to `scale`.
    pub fn position_bound(&self, scale: f64, steps: u64) -> f64 {
        self.epsilon
            * scale.max(f64::MIN_POSITIVE)
            * self.ops_per_substep
            * (steps * u64::from(self.substeps)) as f64
    }

    /// Velocity bound matching [`ErrorModel::position_bound`].
    pub fn velocity_bound(&self, scale: f64, steps: u64) -> f64 {
        2.0 * self.position_bound(scale, steps) / self.h
    }
}

/// Largest coordinate magnitude of a state.
pub fn coordinate_scale(state: &State) -> f64 {
    state.positions.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// Largest absolute difference of two equally long slices.
pub fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

/// Difference of two states against the bounds after `steps` steps.
#[derive(Debug, Clone, PartialEq)]
pub struct Divergence {
    /// Steps run.
    pub steps: u64,
    /// max |x_gpu − x_cpu|.
    pub position: f64,
    /// Its bound.
    pub position_bound: f64,
    /// max |v_gpu − v_cpu|.
    pub velocity: f64,
    /// Its bound.
    pub velocity_bound: f64,
}

impl Divergence {
    /// `other` against the golden `golden` after `steps` steps (or at frame
    /// `steps`), with the (position, velocity) `bounds` of a model.
    pub fn new(steps: u64, golden: &State, other: &State, bounds: (f64, f64)) -> Self {
        Divergence {
            steps,
            position: max_abs_diff(&golden.positions, &other.positions),
            position_bound: bounds.0,
            velocity: max_abs_diff(&golden.velocities, &other.velocities),
            velocity_bound: bounds.1,
        }
    }

    /// True when both metrics are within their bounds (NaN is never within).
    pub fn within(&self) -> bool {
        self.position <= self.position_bound && self.velocity <= self.velocity_bound
    }

    /// The larger of the two measured / bound ratios (NaN when a metric is).
    pub fn ratio(&self) -> f64 {
        (self.position / self.position_bound).max(self.velocity / self.velocity_bound)
    }
}
