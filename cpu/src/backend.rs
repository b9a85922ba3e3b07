//! `CpuBackend`: resident f64 state and the transactional step.
//!
//! ```text
//! step:  save (x, v)
//!        repeat substeps: for kernel in plan.substep_kernels: run kernel
//!        on any non-finite value: restore (x, v) byte for byte, return error
//! ```
//! A step runs on the backend's threads (`threads.rs`, `parallel.rs`): the
//! kernels run in the plan's order, each split over the cores where its
//! items are independent, with the same bytes for any thread count.

use hyperpbd_core::adaptive::{Subdivided, step_adaptive};
use hyperpbd_core::guards;
use hyperpbd_core::violation::ball_overlap_residual;
use hyperpbd_core::{
    Backend, BackendError, FamilyResidual, Kernel, MinimisationReport, Plan, StageName, State,
    StepError, StepReport, check_forces, check_kernel, check_state,
};

use crate::carried::CarriedForces;
use crate::collide::{self, Contacts};
use crate::integrate::{Failed, Motion};
use crate::parallel::{DisjointSlice, Workers};
use crate::project::{Batch, Workspace, project};
use crate::schedule::{fused_tail, splits_somewhere};
use crate::{
    colours, consistent, coupled, guard, incremental_potential, integrate, mesh_contact, motion,
    threads,
};
use hyperpbd_core::broadphase::Aabbs;
use hyperpbd_core::impulse_recorder::ImpulseRecorder;
use hyperpbd_core::motion::SubstepMotion;

/// The golden backend.
pub struct CpuBackend {
    plan: Plan,
    x: Vec<f64>,
    v: Vec<f64>,
    /// Positions at the start of the current substep.
    p: Vec<f64>,
    force: Vec<f64>,
    /// Multipliers per family, color-ordered like the family's elements.
    /// (all families in one vector, reset in one pass; family f's are
    /// `lambda[lambda_starts[f]..lambda_starts[f + 1]]`).
    lambda: Vec<f64>,
    lambda_starts: Vec<usize>,
    saved_x: Vec<f64>,
    saved_v: Vec<f64>,
    /// Whether `saved_x`/`saved_v` hold the state before the last step
    /// and nothing has changed the state since that step succeeded.
    revertible: bool,
    workspace: Workspace,
    /// Candidate particle pairs of the current substep (with `collisions`).
    contacts: Contacts,
    /// The broadphase's boxes (scratch kept between substeps).
    boxes: Aabbs,
    /// Substep being run (for error messages).
    substep: u32,
    /// Scratch of the barrier path.
    minimiser: incremental_potential::Workspace,
    /// Scratch of the coupled implicit step.
    coupled: coupled::Workspace,
    /// Minimisation reports of the current step, one per substep.
    minimisation: Vec<MinimisationReport>,
    /// The threads the kernels run on.
    workers: Workers,
    /// Kernels at the end of a substep (velocity, and damping) that run
    /// fused with the next substep's prediction, when the plan allows.
    fused_tail: Option<usize>,
    /// Whether some kernel of the plan splits over the threads: only then
    /// does a step move to the pool (a hand-over costs microseconds, more
    /// than a small scene's whole step).
    on_pool: bool,
    /// `plan.subdivided(j)` for j = 1, 2, … (adaptive retries), made on
    /// first use.
    subdivided: Vec<Plan>,
    /// The element forces of `primal_residual` (empty without it).
    carried: CarriedForces,
    /// Steps completed (the clock of prescribed motion: t = step·dt).
    step_count: u64,
    /// The prescribed values of the current substep (`motion.rs`).
    motion_now: SubstepMotion,
    /// Contact forces, when requested (`contact_forces.rs`).
    forces: Option<ImpulseRecorder>,
    /// The mesh families' kept candidates (`mesh_contact.rs`).
    kept: mesh_contact::KeptCandidates,
}

impl CpuBackend {
    /// Loads `plan` with `state`, on the default number of threads
    /// ([`default_threads`](crate::default_threads): the CLI's `--threads`,
    /// else `HYPERPBD_THREADS`, else every core).
    pub fn new(plan: Plan, state: &State) -> Result<Self, BackendError> {
        Self::with_threads(plan, state, threads::default_threads()?)
    }

    /// Loads `plan` with `state`, to run on `threads` threads (1: all on
    /// the calling thread). Results are bit-identical for every count.
    pub fn with_threads(plan: Plan, state: &State, threads: usize) -> Result<Self, BackendError> {
        check_state(&plan, state)?;
        colours::check(&plan)?;
        let mut lambda_starts = vec![0];
        for f in &plan.families {
            lambda_starts.push(lambda_starts[lambda_starts.len() - 1] + f.len());
        }
        let lambda = vec![0.0; lambda_starts[lambda_starts.len() - 1]];
        let carried = CarriedForces::new(&plan);
        Ok(CpuBackend {
            kept: mesh_contact::KeptCandidates::new(&plan),
            force: plan.force.clone(),
            x: state.positions.clone(),
            v: state.velocities.clone(),
            p: state.positions.clone(),
            saved_x: Vec::with_capacity(state.positions.len()),
            saved_v: Vec::with_capacity(state.velocities.len()),
            revertible: false,
            lambda,
            lambda_starts,
            plan,
            workspace: Workspace::default(),
            contacts: Contacts::default(),
            boxes: Aabbs::default(),
            substep: 0,
            minimiser: incremental_potential::Workspace::default(),
            coupled: coupled::Workspace::default(),
            minimisation: Vec::new(),
            workers: Workers::new(threads)?,
            on_pool: false,
            fused_tail: None,
            subdivided: Vec::new(),
            carried,
            step_count: 0,
            motion_now: SubstepMotion::default(),
            forces: None,
        }
        .with_pool_choice())
    }

    /// Sets `on_pool` from the plan's largest loops.
    fn with_pool_choice(mut self) -> Self {
        self.on_pool = splits_somewhere(&self.plan, &self.workers);
        self.fused_tail = fused_tail(&self.plan);
        self
    }

    /// The number of threads this backend runs on.
    pub fn threads(&self) -> usize {
        self.workers.threads()
    }

    /// Caps every parallel chunk at `max_chunk` items (rounded down to a
    /// power of two) instead of the kernels' own grain, so that even a
    /// small scene splits over the threads. For determinism tests: the
    /// results are the same bytes for any cap.
    pub fn with_max_chunk(mut self, max_chunk: usize) -> Self {
        self.workers = self.workers.with_max_chunk(max_chunk);
        self.with_pool_choice()
    }

    /// Multipliers of family `family` from the last projection
    /// (color-ordered), for inspection and kernel-level tests.
    pub fn multipliers(&self, family: usize) -> Option<&[f64]> {
        let range = *self.lambda_starts.get(family)?..*self.lambda_starts.get(family + 1)?;
        self.lambda.get(range)
    }

    /// Candidate pairs and contact lists of the last broadphase.
    pub fn contacts(&self) -> &Contacts {
        &self.contacts
    }

    fn particle_error(&self, stage: StageName, particle: usize) -> BackendError {
        StepError::NonFiniteParticle {
            stage,
            substep: self.substep,
            particle,
        }
        .into()
    }

    fn kernel(&mut self, kernel: Kernel) -> Result<(), BackendError> {
        let plan = &self.plan;
        let workers = &self.workers;
        match kernel {
            Kernel::Motion => {
                let clock = (self.step_count, self.substep);
                self.motion_now = motion::place(plan, clock, &mut self.x, &mut self.v)?;
                Ok(())
            }
            Kernel::Predict => {
                let predicted = self.predicting(integrate::predict);
                predicted.map_err(|i| self.particle_error(StageName::Predict, i))?;
                self.warm_start();
                Ok(())
            }
            Kernel::Project { family, color } => {
                let fam = &plan.families[family];
                // SAFETY: a slot is touched by its element only (project.rs).
                let kept = unsafe { DisjointSlice::new(self.kept.family(family)) };
                let batch = Batch {
                    dim: plan.dim,
                    inverse_mass: &plan.inverse_mass,
                    family: fam,
                    alpha_tilde: fam.alpha_tilde(plan.h),
                    start: &self.p,
                    meshes: &plan.meshes,
                    moving_mesh: self.motion_now.mesh(plan.motion.as_ref(), family),
                    kept: &kept,
                };
                let lambda =
                    &mut self.lambda[self.lambda_starts[family]..self.lambda_starts[family + 1]];
                let moving = self.motion_now.plane(plan.motion.as_ref(), family);
                let projected = if let Some(plane) = moving {
                    let (w, alpha_tilde) = (&plan.inverse_mass[..], batch.alpha_tilde);
                    motion::project(plane, fam, w, alpha_tilde, &self.p, &mut self.x, lambda)
                } else if plan.primal_residual {
                    let (carried, scratch) = self.carried.family(family, lambda);
                    consistent::project(
                        &batch,
                        fam.color(color),
                        &mut self.x,
                        carried,
                        &mut self.workspace,
                        scratch,
                    )
                } else {
                    project(
                        workers,
                        &batch,
                        fam.color(color),
                        &mut self.x,
                        lambda,
                        &mut self.workspace,
                    )
                };
                projected.map_err(|slot| {
                    let substep = self.substep;
                    match hyperpbd_core::element_refusal(plan.dim, fam, slot, &self.x) {
                        Some(refusal) => {
                            guards::material_refusal_error(plan, family, slot, refusal, substep)
                        }
                        None => StepError::NonFiniteConstraint {
                            stage: StageName::Project,
                            substep,
                            family,
                            family_label: fam.label.clone(),
                            element: fam.authored_element(slot),
                        },
                    }
                    .into()
                })
            }
            Kernel::Velocity => integrate::velocity(workers, plan, &self.x, &mut self.v, &self.p)
                .map_err(|i| self.particle_error(StageName::Velocity, i)),
            Kernel::Friction { family } => {
                let lambda =
                    &self.lambda[self.lambda_starts[family]..self.lambda_starts[family + 1]];
                let moving = (&self.motion_now, &self.p[..], &self.x[..]);
                let of = (family, lambda, self.kept.family(family));
                motion::friction_of(workers, plan, of, moving, &mut self.v)
                    .map_err(|i| self.particle_error(StageName::Friction, i))
            }
            Kernel::Damping => {
                integrate::damping(workers, plan, &mut self.v);
                Ok(())
            }
            Kernel::Broadphase => {
                let margin = plan.contacts.map_or(0.0, |c| c.margin);
                let (p, x) = (&self.p, &self.x);
                collide::broadphase_on(
                    workers,
                    plan,
                    margin,
                    p,
                    x,
                    &mut self.boxes,
                    &mut self.contacts,
                );
                Ok(())
            }
            Kernel::Collide => {
                let friction = plan.contacts.map_or(0.0, |c| c.friction);
                collide::collide_on(
                    workers,
                    plan,
                    friction,
                    &self.p,
                    &mut self.x,
                    &mut self.contacts,
                )
                .map_err(|i| self.particle_error(StageName::Project, i))
            }
            Kernel::Minimise => {
                let Some(ip) = plan.incremental_potential() else {
                    return Err(BackendError::InvalidCall(
                        "the plan has no incremental-potential settings".into(),
                    ));
                };
                let report = match &ip.coupled {
                    Some(step) => coupled::minimise(
                        workers,
                        plan,
                        ip,
                        step,
                        &mut self.x,
                        &mut self.v,
                        &self.force,
                        &mut self.coupled,
                    ),
                    None => incremental_potential::minimise(
                        workers,
                        plan,
                        ip,
                        &mut self.x,
                        &mut self.v,
                        &self.force,
                        &mut self.minimiser,
                    ),
                };
                let refused = StepError::refused(self.substep, &report);
                self.minimisation.push(report);
                refused.map_or(Ok(()), |e| Err(e.into()))
            }
            Kernel::GuardMeasure { family } => {
                Ok(guard::measure(plan, family, &self.x, self.substep)?)
            }
            Kernel::GuardSpeed => Ok(guard::speed(plan, &self.v, self.substep)?),
        }
    }

    fn report(&mut self) -> StepReport {
        let plan = &self.plan;
        let workers = &self.workers;
        let mut residuals: Vec<FamilyResidual> = plan
            .families
            .iter()
            .enumerate()
            .map(|(k, f)| motion::residual_of(workers, plan, &self.motion_now, k, f, &self.x))
            .collect();
        if plan.contacts.is_some() {
            // The coupled step's balls are barriers with pair sets of its
            // own: their overlap is measured over every nearby pair.
            residuals.push(match plan.incremental_potential() {
                Some(_) => ball_overlap_residual(plan, &self.x),
                None => collide::residual(workers, plan, &self.x, &self.contacts),
            });
        }
        StepReport {
            threads: workers.threads(),
            kernel_calls: plan.kernel_counts(),
            residuals,
            active_contacts: plan
                .families
                .iter()
                .zip(self.lambda_starts.windows(2))
                .filter(|(f, _)| f.kind.is_inequality())
                .map(|(_, r)| self.lambda[r[0]..r[1]].iter().filter(|&&l| l > 0.0).count())
                .sum::<usize>()
                + self.contacts.active_count(),
            minimisation: std::mem::take(&mut self.minimisation),
            attempts: Vec::new(),
            host_waits: 0,
            contact_forces: self.forces.as_ref().map(|r| r.forces(plan.dt)),
        }
    }
}

impl Backend for CpuBackend {
    fn name(&self) -> String {
        "cpu-f64".into()
    }

    fn plan(&self) -> &Plan {
        &self.plan
    }

    fn step(&mut self) -> Result<StepReport, BackendError> {
        step_adaptive(self.plan.substeps, self.plan.adaptive, self)
    }

    fn read_state(&mut self) -> Result<State, BackendError> {
        Ok(State {
            dim: self.plan.dim,
            positions: self.x.clone(),
            velocities: self.v.clone(),
        })
    }

    fn write_state(&mut self, state: &State) -> Result<(), BackendError> {
        check_state(&self.plan, state)?;
        self.revertible = false;
        self.x.clone_from(&state.positions);
        self.v.clone_from(&state.velocities);
        self.carried.clear(&self.plan, &mut self.lambda);
        Ok(())
    }

    fn set_forces(&mut self, forces: &[f64]) -> Result<(), BackendError> {
        check_forces(&self.plan, forces)?;
        self.force.copy_from_slice(forces);
        Ok(())
    }

    /// Runs one kernel. A kernel that fails leaves the writes it made
    /// before failing (the step rolls them back; a single kernel does
    /// not) — the same writes for any thread count.
    fn run_kernel(&mut self, kernel: Kernel) -> Result<(), BackendError> {
        check_kernel(&self.plan, kernel)?;
        self.revertible = false;
        if !self.on_pool {
            return self.kernel(kernel);
        }
        let workers = self.workers.clone();
        workers.install(|| self.kernel(kernel))
    }

    fn request_contact_forces(&mut self, on: bool) -> Result<(), BackendError> {
        self.forces = on.then(|| ImpulseRecorder::new(&self.plan));
        Ok(())
    }
}

impl Subdivided for CpuBackend {
    /// The step on `plan.subdivided(subdivision)` (the plan itself for 0).
    fn attempt(&mut self, subdivision: u32) -> Result<StepReport, BackendError> {
        if subdivision == 0 {
            return self.step_on_pool();
        }
        let j = subdivision as usize;
        while self.subdivided.len() < j {
            let next = self.plan.subdivided(self.subdivided.len() as u32 + 1);
            self.subdivided.push(next);
        }
        std::mem::swap(&mut self.plan, &mut self.subdivided[j - 1]);
        let result = self.step_on_pool();
        std::mem::swap(&mut self.plan, &mut self.subdivided[j - 1]);
        result
    }
}

impl CpuBackend {
    /// One attempt of the step on the pool (when the plan splits).
    fn step_on_pool(&mut self) -> Result<StepReport, BackendError> {
        if !self.on_pool {
            return self.step_on_workers();
        }
        let workers = self.workers.clone();
        workers.install(|| self.step_on_workers())
    }

    /// The step's schedule (on the pool's thread when there is a pool).
    fn step_on_workers(&mut self) -> Result<StepReport, BackendError> {
        let workers = &self.workers;
        self.saved_x.resize(self.x.len(), 0.0);
        self.saved_v.resize(self.v.len(), 0.0);
        workers.copy(&self.x, &mut self.saved_x);
        workers.copy(&self.v, &mut self.saved_v);
        self.carried.save(&self.plan, &self.lambda);
        self.minimisation.clear();
        self.revertible = false;
        if let Some(forces) = &mut self.forces {
            forces.clear();
        }
        if let Err(e) = self.substeps() {
            self.x.clone_from(&self.saved_x);
            self.v.clone_from(&self.saved_v);
            self.carried.restore(&self.plan, &mut self.lambda);
            return Err(e);
        }
        self.revertible = true;
        self.step_count += 1;
        Ok(self.report())
    }

    /// Puts positions and velocities back to what they were before the
    /// last step, from the copy every step keeps for its own rollback: for
    /// a caller whose larger step failed after this one succeeded (a batch
    /// of worlds, `hyperpbd::batch`). Refused unless the last thing done
    /// to this backend was a successful step.
    pub fn revert_step(&mut self) -> Result<(), BackendError> {
        if !self.revertible {
            return Err(BackendError::InvalidCall(
                "revert_step: the last call was not a successful step".into(),
            ));
        }
        self.revertible = false;
        self.step_count -= 1;
        self.x.clone_from(&self.saved_x);
        self.v.clone_from(&self.saved_v);
        self.carried.restore(&self.plan, &mut self.lambda);
        Ok(())
    }

    /// The carried forces' warm start of a substep (`carried.rs`).
    fn warm_start(&mut self) {
        self.carried
            .warm_start(&self.plan, &mut self.x, &mut self.lambda);
    }

    /// The plan's kernels, `substeps` times. Where a substep ends with
    /// per-particle kernels only (velocity, damping) and the next begins
    /// with the prediction, those run as one pass
    /// ([`integrate::velocity_then_predict`]).
    fn substeps(&mut self) -> Result<(), BackendError> {
        let (substeps, kernels) = (self.plan.substeps, self.plan.substep_kernels.len());
        for substep in 0..substeps {
            self.substep = substep;
            let fuse_next = self.fused_tail.filter(|_| substep + 1 < substeps);
            let first = usize::from(substep > 0 && self.fused_tail.is_some());
            let last = kernels - fuse_next.unwrap_or(0);
            for k in first..last {
                self.recorded(self.plan.substep_kernels[k])?;
            }
            if let Some(forces) = &mut self.forces {
                let (lambda, starts) = (&self.lambda, &self.lambda_starts);
                forces.end_substep(
                    &self.plan,
                    &self.motion_now,
                    (lambda, starts),
                    (&self.x, &self.p),
                );
            }
            if fuse_next.is_some() {
                self.velocity_then_predict()?;
            }
        }
        Ok(())
    }

    /// A kernel of the step, its contact impulses measured when requested
    /// (`contact_forces.rs`).
    fn recorded(&mut self, kernel: Kernel) -> Result<(), BackendError> {
        let Some(mut forces) = self.forces.take() else {
            return self.kernel(kernel);
        };
        forces.before(&self.plan, kernel, &self.x, &self.v);
        let result = self.kernel(kernel);
        if result.is_ok() {
            let now = (&self.motion_now, &self.lambda[..], &self.lambda_starts[..]);
            let state = (&self.x[..], &self.v[..], &self.p[..]);
            forces.after(&self.plan, now, kernel, state);
            if kernel == Kernel::Minimise {
                crate::contact_forces::minimised(&mut forces, &self.plan, &self.coupled, &self.x);
            }
        }
        self.forces = Some(forces);
        result
    }

    /// `pass` (a prediction) over the particles' [`Motion`], the
    /// multipliers reset to 0 beside it (the substep begins with both).
    fn predicting<T: Send>(
        &mut self,
        pass: impl FnOnce(&Workers, &Plan, Motion<'_>) -> T + Send,
    ) -> T {
        let (workers, plan) = (&self.workers, &self.plan);
        let motion = Motion {
            x: &mut self.x,
            v: &mut self.v,
            p: &mut self.p,
            force: &self.force,
        };
        let ((), result) = workers.join(
            || {
                // With the primal residual the forces carry over (warm_start).
                if !plan.primal_residual {
                    workers.zero(&mut self.lambda);
                }
            },
            || pass(workers, plan, motion),
        );
        result
    }

    /// The end of this substep and the prediction of the next, fused.
    fn velocity_then_predict(&mut self) -> Result<(), BackendError> {
        match self.predicting(integrate::velocity_then_predict) {
            Ok(()) => {
                self.warm_start();
                Ok(())
            }
            Err(Failed::Velocity(i)) => Err(self.particle_error(StageName::Velocity, i)),
            Err(Failed::Predict(i)) => {
                self.substep += 1;
                Err(self.particle_error(StageName::Predict, i))
            }
        }
    }
}
