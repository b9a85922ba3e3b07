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
//! forces         on request, per-particle barriers only: after each
//!                minimisation the accepted iterate x is read back (one more
//!                wait) and the golden path's recorder adds −∇B(x) h per
//!                obstacle (core's impulse_recorder); the coupled step
//!                refuses (its lagged friction and ball barriers live in its
//!                own records on the device)
//! ```

use hyperpbd_core::impulse_recorder::ImpulseRecorder;
use hyperpbd_core::violation::{ball_overlap_residual, family_residuals};
use hyperpbd_core::{
    BackendError, GpuError, Kernel, MinimisationReport, StepError, StepReport, check_kernel,
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
    /// The contact forces' recorder, when asked (per-particle barriers).
    forces: Option<ImpulseRecorder>,
}

impl<M: Minimiser> Minimising<M> {
    fn run_minimise(&mut self, on: &mut Resident) -> Result<(), BackendError> {
        let report = self.minimiser.minimise(on)?;
        let refused = StepError::refused(self.substep, &report);
        self.reports.push(report);
        refused.map_or(Ok(()), |e| Err(e.into()))
    }

    /// The barrier impulses at the accepted iterate, when asked.
    fn record_barriers(&mut self, on: &mut Resident) -> Result<(), BackendError> {
        let (Some(recorder), Some(ip)) = (&mut self.forces, on.plan.incremental_potential()) else {
            return Ok(());
        };
        let x = on.state.read(&on.ctx)?.positions;
        recorder.barriers(&on.plan, ip, &x);
        Ok(())
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
            forces: None,
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
        if let Some(recorder) = &mut self.forces {
            recorder.clear();
        }
        for substep in 0..on.plan.substeps {
            self.substep = substep;
            for k in 0..on.plan.substep_kernels.len() {
                if on.plan.substep_kernels[k] != Kernel::Minimise {
                    continue;
                }
                let done = self
                    .run_minimise(on)
                    .and_then(|()| self.record_barriers(on));
                if let Err(e) = done {
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
            contact_forces: self.forces.as_ref().map(|r| r.forces(plan.dt)),
            ..StepReport::default()
        })
    }

    /// Reported for per-particle barriers (module docs); the coupled step
    /// refuses.
    fn request_contact_forces(
        &mut self,
        on: &mut Resident,
        wanted: bool,
    ) -> Result<(), BackendError> {
        let coupled = on
            .plan
            .incremental_potential()
            .is_some_and(|ip| ip.coupled.is_some());
        if wanted && coupled {
            return Err(GpuError::Unsupported {
                what: format!(
                    "contact forces on gpu-{} with the coupled implicit step: its kernels do not \
                     copy their lags and element records out for the recorder yet; the XPBD \
                     step and the per-particle barrier path on the GPU, and the CPU golden path, \
                     report them (--backend cpu)",
                    on.precision
                ),
            }
            .into());
        }
        self.forces = wanted.then(|| ImpulseRecorder::new(&on.plan));
        Ok(())
    }
}
