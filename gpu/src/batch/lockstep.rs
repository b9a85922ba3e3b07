//! Incremental-potential worlds in a GPU batch: W worlds, each its own
//! backend ([`GpuBarrierBackend`] or [`GpuCoupledBackend`], its plan's),
//! on one device, stepped on W host threads in lockstep
//! (crate::lockstep).
//!
//! ```text
//! per world   its backend: buffers, kernels' parameters, Newton and CG (or
//!             the barrier step's decision log) state, chunk lengths, origin
//! shared      the device and its compiled kernels (the pool), and the
//!             host's waits: every read-back of a step (a Newton chunk's log,
//!             PCG's state, the Armijo trials, a residual) is a round, the
//!             device waited for once for every world that reached it
//! step        W threads, world k's step exactly as alone; a world that
//!             stops (its own criterion: converged, rounding floor, budget,
//!             refusal) leaves, the others go on
//! failure     all or nothing: the failing worlds rolled back by their own
//!             step, every other world from its own saved start; the
//!             lowest failing world named with its own error
//! ```
//! World k runs its own single run's kernels on its own buffers in its own
//! order, so its results — state and report — are its own single run's, bit
//! for bit, in both precisions (each world keeps its own f32 origin). What
//! the batch saves is the host's waits: Σ_k n_k for W worlds one after
//! another, max_k n_k here. The dispatches are each world's own (W times
//! one world's): merging them, the world part of the invocation index as
//! in the XPBD batch, is not done.

use std::sync::Arc;

use hyperpbd_core::{Backend, BackendError, GpuError, Plan, State, StepReport};

use super::WorldError;
use crate::context::GpuContext;
use crate::lockstep::Lockstep;
use crate::resident_backend::Resident;
use crate::{GpuBarrierBackend, GpuCoupledBackend, Precision, SceneOrigin};

/// One world's backend, the one its plan's solver runs on.
enum World {
    Barrier(Box<GpuBarrierBackend>),
    Coupled(Box<GpuCoupledBackend>),
}

impl World {
    fn load(
        adapter: &wgpu::Adapter,
        plan: Plan,
        state: &State,
        precision: Precision,
    ) -> Result<World, BackendError> {
        let coupled = match plan.incremental_potential() {
            Some(ip) => ip.coupled.is_some(),
            None => return Err(mixed()),
        };
        Ok(match coupled {
            true => World::Coupled(Box::new(GpuCoupledBackend::with_adapter(
                adapter, plan, state, precision,
            )?)),
            false => World::Barrier(Box::new(GpuBarrierBackend::with_adapter(
                adapter, plan, state, precision,
            )?)),
        })
    }

    fn backend(&mut self) -> (GpuContext, &mut (dyn Backend + Send)) {
        match self {
            World::Barrier(b) => (b.on.ctx.clone(), b.as_mut()),
            World::Coupled(c) => (c.on.ctx.clone(), c.as_mut()),
        }
    }

    fn resident(&mut self) -> &mut Resident {
        match self {
            World::Barrier(b) => &mut b.on,
            World::Coupled(c) => &mut c.on,
        }
    }

    fn origin(&self) -> &SceneOrigin {
        match self {
            World::Barrier(b) => b.on.state.origin(),
            World::Coupled(c) => c.on.state.origin(),
        }
    }
}

/// An XPBD world among incremental-potential ones.
fn mixed() -> BackendError {
    GpuError::Unsupported {
        what: "an XPBD world in a batch of incremental-potential worlds (a GPU batch runs one \
               solver)"
            .into(),
    }
    .into()
}

/// Leaves the lockstep when the world's thread ends, however it ends.
struct Leaving(GpuContext);

impl Drop for Leaving {
    fn drop(&mut self) {
        self.0.leave_lockstep();
    }
}

/// Steps every backend of `worlds` (each with its context, joined to
/// `lockstep`) on a thread of its own, in lockstep; their results in
/// order. A thread that cannot start is that world's error.
pub(super) fn step_all(
    lockstep: &Lockstep,
    worlds: Vec<(GpuContext, &mut (dyn Backend + Send))>,
) -> Vec<Result<StepReport, BackendError>> {
    let Some(device) = worlds.first().map(|(ctx, _)| ctx.clone()) else {
        return Vec::new();
    };
    lockstep.begin(worlds.len());
    let results = std::thread::scope(|s| {
        let mut running = Vec::with_capacity(worlds.len());
        for (ctx, backend) in worlds {
            let thread = std::thread::Builder::new().spawn_scoped(s, move || {
                let _leaving = Leaving(ctx);
                backend.step()
            });
            running.push(thread.map_err(|e| e.to_string()));
        }
        // A world whose thread did not start never takes part.
        for thread in &running {
            if thread.is_err() {
                device.leave_lockstep();
            }
        }
        running
            .into_iter()
            .map(|thread| match thread {
                Ok(handle) => handle
                    .join()
                    .unwrap_or_else(|panic| std::panic::resume_unwind(panic)),
                Err(why) => Err(GpuError::Other {
                    message: format!("cannot start the world's thread: {why}"),
                }
                .into()),
            })
            .collect()
    });
    lockstep.begin(0);
    results
}

/// The worlds of an incremental-potential batch (module docs).
pub(super) struct LockstepWorlds {
    worlds: Vec<World>,
    lockstep: Arc<Lockstep>,
}

impl LockstepWorlds {
    /// Loads every world on the shared device of `adapter`.
    pub fn new(
        adapter: &wgpu::Adapter,
        plans: &[Plan],
        states: &[State],
        precision: Precision,
    ) -> Result<Self, WorldError> {
        let lockstep = Arc::new(Lockstep::default());
        let mut worlds: Vec<World> = Vec::with_capacity(plans.len());
        for (k, (plan, state)) in plans.iter().zip(states).enumerate() {
            let mut world =
                World::load(adapter, plan.clone(), state, precision).map_err(|source| {
                    WorldError {
                        world: Some(k),
                        source,
                    }
                })?;
            if let Some(first) = worlds.first_mut() {
                // One device: a round's wait must finish every world's work.
                let shared = first.resident().ctx.clone();
                if !shared.same_device(&world.resident().ctx) {
                    return Err(WorldError::batch(GpuError::Other {
                        message: format!("worlds[{k}] was loaded on another device than worlds[0]"),
                    }));
                }
            }
            world.resident().ctx.join(lockstep.clone());
            worlds.push(world);
        }
        Ok(LockstepWorlds { worlds, lockstep })
    }

    /// One step of every world, in lockstep (module docs); every report's
    /// `host_waits` is the batch step's.
    pub fn step(&mut self) -> Result<Vec<StepReport>, WorldError> {
        let before = self.lockstep.waits();
        let worlds = self.worlds.iter_mut().map(World::backend).collect();
        let results = step_all(&self.lockstep, worlds);
        let waits = self.lockstep.waits() - before;
        let Some(failed) = results.iter().position(Result::is_err) else {
            let mut reports: Vec<StepReport> = results.into_iter().flatten().collect();
            for report in &mut reports {
                report.host_waits = waits;
            }
            return Ok(reports);
        };
        // A failed world's step put it back itself; the others go back to
        // the start their step saved.
        let mut rollback = Ok(());
        for (world, result) in self.worlds.iter_mut().zip(&results) {
            if result.is_ok() {
                let on = world.resident();
                let undone = on.state.rollback(&on.ctx);
                rollback = rollback.and(undone);
            }
        }
        let source = results
            .into_iter()
            .nth(failed)
            .and_then(Result::err)
            .unwrap_or_else(|| BackendError::InvalidCall("no failing world".into()));
        Err(WorldError {
            world: Some(failed),
            source: source.after_rollback(rollback),
        })
    }

    /// World `world`'s backend (the caller checks the index).
    pub fn backend(&mut self, world: usize) -> &mut (dyn Backend + Send) {
        self.worlds[world].backend().1
    }

    /// The origin world `world`'s device positions are relative to (its
    /// own; 0 in f64).
    pub fn origin(&self, world: usize) -> &SceneOrigin {
        self.worlds[world].origin()
    }
}
