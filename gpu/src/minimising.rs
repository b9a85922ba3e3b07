//! [`Minimising`]: the incremental-potential steps (barrier, coupled) as
//! a [`ResidentStep`], over a [`Minimiser`] that runs one minimisation on
//! the resident state:
//!
//! ```text
//! run_minimise   one minimisation, its report kept, a refusal as StepError
//! run_kernel     Minimise alone: save, run_minimise; results the device could
//!                not finish (GpuError) are rolled back
//! attempt        every Minimise kernel of every substep, the state restored
//!                byte for byte on any error (no adaptive steps); its report
//!                carries the families' residuals (core's violation)
//! ```

use hyperpbd_core::violation::{ball_overlap_residual, family_residuals};
use hyperpbd_core::{
    BackendError, Kernel, MinimisationReport, StepError, StepReport, check_kernel,
};

use crate::resident_backend::{Load, Resident, ResidentStep};

/// One minimisation of an incremental-potential step on the GPU.
pub trait Minimiser: Sized {
    /// Checks what `load`'s plan asks of the minimiser and loads the plan
    /// and state on its device (the state already fits the plan).
    fn load(load: Load<'_>) -> Result<(Resident, Self), BackendError>;

    /// One minimisation on the resident state (CPU: `minimise`).
    fn minimise(&mut self, on: &mut Resident) -> Result<MinimisationReport, BackendError>;
}

/// The substeps of an incremental-potential step, each one minimisation
/// by `M` (see the module docs).
pub struct Minimising<M> {
    pub(crate) minimiser: M,
    substep: u32,
    reports: Vec<MinimisationReport>,
}

impl<M: Minimiser> Minimising<M> {
    fn run_minimise(&mut self, on: &mut Resident) -> Result<(), BackendError> {
        let report = self.minimiser.minimise(on)?;
        let refused = StepError::refused(self.substep, &report);
        self.reports.push(report);
        refused.map_or(Ok(()), |e| Err(e.into()))
    }

    /// Saves the state (no wait: the steps' submissions follow it in
    /// queue order).
    fn save(on: &Resident) -> Result<(), BackendError> {
        let mut encoder = on.ctx.device.create_command_encoder(&Default::default());
        on.state.save(&mut encoder);
        on.ctx.submit(encoder)?;
        Ok(())
    }
}

impl<M: Minimiser> ResidentStep for Minimising<M> {
    type Options = ();

    fn load(load: Load<'_>, (): ()) -> Result<(Resident, Self), BackendError> {
        let (on, minimiser) = M::load(load)?;
        let step = Minimising {
            minimiser,
            substep: 0,
            reports: Vec::new(),
        };
        Ok((on, step))
    }

    fn run_kernel(&mut self, on: &mut Resident, kernel: Kernel) -> Result<(), BackendError> {
        check_kernel(&on.plan, kernel)?;
        Self::save(on)?;
        match self.run_minimise(on) {
            // Results the device could not finish (loops cut short, a lost
            // device) are not kept: the state goes back to the call's start.
            Err(e @ BackendError::Gpu(_)) => Err(on.roll_back_after(e)),
            other => other,
        }
    }

    /// The incremental-potential path runs no guards (validation refuses
    /// them there), so its one attempt is the step itself.
    fn attempt(&mut self, on: &mut Resident, subdivision: u32) -> Result<StepReport, BackendError> {
        if subdivision > 0 {
            return Err(BackendError::InvalidCall(
                "the incremental-potential path has no adaptive steps".into(),
            ));
        }
        Self::save(on)?;
        self.reports.clear();
        for substep in 0..on.plan.substeps {
            self.substep = substep;
            for k in 0..on.plan.substep_kernels.len() {
                if on.plan.substep_kernels[k] != Kernel::Minimise {
                    continue;
                }
                if let Err(e) = self.run_minimise(on) {
                    return Err(on.roll_back_after(e));
                }
            }
        }
        // The families' and the balls' residuals at the accepted state, as
        // the CPU reports them (one read-back, only with families or
        // collisions).
        let plan = &on.plan;
        let residuals = if plan.families.is_empty() && plan.contacts.is_none() {
            Vec::new()
        } else {
            let x = on.state.read(&on.ctx)?.positions;
            let mut residuals = family_residuals(&plan.families, plan.dim, &x);
            if plan.contacts.is_some() {
                residuals.push(ball_overlap_residual(plan, &x));
            }
            residuals
        };
        Ok(StepReport {
            kernel_calls: plan.kernel_counts(),
            minimisation: std::mem::take(&mut self.reports),
            residuals,
            ..StepReport::default()
        })
    }
}
