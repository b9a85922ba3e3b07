//! The `Backend` trait: one plan, resident state, steps, read-back.
//!
//! A backend is created from a [`Plan`] and an initial [`State`] (by its
//! own constructor), keeps the state resident between steps, and executes
//! exactly the kernel sequence of [`Plan::substep_kernels`], `substeps`
//! times per step. Kernels can also be run one at a time
//! ([`Backend::run_kernel`]) so each can be checked against the golden path
//! in isolation.

use crate::{BackendError, Kernel, MinimisationReport, Plan, StageName, State};

/// Largest constraint violation of one family after a step.
#[derive(Debug, Clone, PartialEq)]
pub struct FamilyResidual {
    /// `constraints[i]` or `obstacles[i]`.
    pub label: String,
    /// max over elements of |C(x)| (equalities) or max(0, −C(x))
    /// (contacts), in the constraint's own units: length for distance and
    /// contact, length^(2k) for the squared k-measure, length^N for the
    /// oriented measure.
    pub max_violation: f64,
}

/// What one step did.
///
/// Equality compares what the step computed and how it was scheduled;
/// `host_waits` (a cost of the backend that ran it, like wall time) is
/// left out, so a CPU and a GPU report of the same step compare equal.
#[derive(Debug, Clone, Default)]
pub struct StepReport {
    /// Kernel calls per stage in this step, in stage order.
    pub kernel_calls: Vec<(StageName, u64)>,
    /// Constraint violation per family at the end of the step.
    pub residuals: Vec<FamilyResidual>,
    /// Contacts with a positive multiplier in the last substep.
    pub active_contacts: usize,
    /// Incremental-potential path: one minimisation report per substep
    /// (empty on the XPBD path).
    pub minimisation: Vec<MinimisationReport>,
    /// CPU threads the step ran on (the CPU backend's thread count; 0 for
    /// a GPU backend, whose kernels run on the device).
    pub threads: usize,
    /// Every attempt of the step in order, the accepted one last: one
    /// attempt, or more when `adaptive` retried guard rejections
    /// (`adaptive.rs`).
    pub attempts: Vec<crate::Attempt>,
    /// Times the host waited for the device during this step (every
    /// `device.poll` of the GPU crate: submissions waited for and buffers
    /// read back); 0 on the CPU.
    pub host_waits: u64,
    /// Contact forces of the step (docs/collisions.md#contact-forces),
    /// when requested with [`Backend::request_contact_forces`]; `None`
    /// otherwise.
    pub contact_forces: Option<crate::ContactForces>,
}

impl PartialEq for StepReport {
    fn eq(&self, other: &Self) -> bool {
        // Destructured, so a new field cannot be forgotten here.
        let StepReport {
            kernel_calls,
            residuals,
            active_contacts,
            minimisation,
            threads,
            attempts,
            host_waits: _,
            contact_forces,
        } = self;
        *kernel_calls == other.kernel_calls
            && *residuals == other.residuals
            && *active_contacts == other.active_contacts
            && *minimisation == other.minimisation
            && *threads == other.threads
            && *attempts == other.attempts
            && *contact_forces == other.contact_forces
    }
}

impl StepReport {
    /// Attempts a guard rejected before the accepted one.
    pub fn retries(&self) -> usize {
        self.attempts.len().saturating_sub(1)
    }

    /// Largest violation over all families (0 with no families).
    pub fn max_violation(&self) -> f64 {
        self.residuals
            .iter()
            .map(|r| r.max_violation)
            .fold(0.0, f64::max)
    }
}

/// A physics backend executing a [`Plan`].
pub trait Backend {
    /// Short name, e.g. `cpu-f64`.
    fn name(&self) -> String;

    /// The plan this backend executes.
    fn plan(&self) -> &Plan;

    /// Advances one step of `plan().dt`. On error the state is exactly as
    /// before the call.
    fn step(&mut self) -> Result<StepReport, BackendError>;

    /// Copies the current state out.
    fn read_state(&mut self) -> Result<State, BackendError>;

    /// Replaces the current state (same particle count and dimension).
    fn write_state(&mut self, state: &State) -> Result<(), BackendError>;

    /// Replaces the constant external forces (flat, `particles × dim`).
    /// Only possible when the plan has a force term.
    fn set_forces(&mut self, forces: &[f64]) -> Result<(), BackendError>;

    /// Runs one kernel on the resident state (for kernel-level checks).
    /// `Kernel::Predict` starts a substep: it saves p = x and resets the
    /// multipliers used by the following `Project` calls.
    fn run_kernel(&mut self, kernel: Kernel) -> Result<(), BackendError>;

    /// Says that [`Backend::read_state`] will follow the next
    /// [`Backend::step`] (a trajectory frame). A GPU backend then copies the
    /// state out inside that step's own submission, so the read waits for
    /// nothing more; the others ignore it. Results do not change.
    fn prefetch_state(&mut self) {}

    /// Asks every following step to report its contact forces
    /// ([`StepReport::contact_forces`]; `false` stops it). A backend that
    /// cannot refuses with a typed error saying why; the default refuses.
    /// Results do not change, and a step that was not asked pays nothing.
    fn request_contact_forces(&mut self, on: bool) -> Result<(), BackendError> {
        if !on {
            return Ok(());
        }
        Err(BackendError::InvalidCall(format!(
            "{} does not report contact forces (the CPU golden path does: --backend cpu)",
            self.name()
        )))
    }
}

/// Checks that a replacement state fits the plan.
pub fn check_state(plan: &Plan, state: &State) -> Result<(), BackendError> {
    let expected = plan.particle_count() * plan.dim;
    if state.dim != plan.dim
        || state.positions.len() != expected
        || state.velocities.len() != expected
    {
        return Err(BackendError::InvalidCall(format!(
            "state has dim {} with {} position and {} velocity values; the plan needs dim {} and {} each",
            state.dim,
            state.positions.len(),
            state.velocities.len(),
            plan.dim,
            expected
        )));
    }
    Ok(())
}

/// Checks a replacement force vector against the plan.
pub fn check_forces(plan: &Plan, forces: &[f64]) -> Result<(), BackendError> {
    if forces.len() != plan.particle_count() * plan.dim {
        return Err(BackendError::InvalidCall(format!(
            "forces has {} values; the plan needs {}",
            forces.len(),
            plan.particle_count() * plan.dim
        )));
    }
    if !plan.predict.force {
        return Err(BackendError::InvalidCall(
            "the plan has no external-force term (the scene authors no nonzero force on a dynamic particle), so forces would be ignored; author a force in the scene to enable it".into(),
        ));
    }
    Ok(())
}

/// Checks a kernel call against the plan: it must be one of the calls of
/// [`Plan::substep_kernels`] (a frictionless plane has no friction kernel,
/// a scene without dynamic particles has no kernels at all).
pub fn check_kernel(plan: &Plan, kernel: Kernel) -> Result<(), BackendError> {
    if plan.substep_kernels.contains(&kernel) {
        Ok(())
    } else {
        Err(BackendError::InvalidCall(format!(
            "{kernel:?} is not in this plan's schedule"
        )))
    }
}
