//! Batches of worlds: W scenes of one topology stepped together, each with
//! its own initial state and parameters (gravity, forces, compliance per
//! family, obstacle normal/offset/friction, collision friction, damping
//! rate).
//!
//! ```text
//! topology (shared by every world, checked against worlds[0]):
//!   dim, dt, substeps, iterations, particles (count, masses, radii), per
//!   family its kind, arity, elements and colours, particle contacts on
//!   or off; the stages may differ (a world with μ = 0 or no damping
//!   compiles those stages away, each world runs its own plan)
//! CpuBatch::step:  every world one step, in parallel, one thread each
//!   world k's state == world k's scene stepped alone, bit for bit
//!   all or nothing: if any world fails, every world is put back to its
//!   state before the step and the error names the first failing world
//! GpuBatch::step: every world in the same dispatches, one per kernel for
//!   all worlds (the world part of the invocation index;
//!   hyperpbd_gpu::GpuBatch); world k in f64 == world k alone, bit for
//!   bit; all or nothing as above. The batch runs the union of the
//!   worlds' stages, each world skipping the friction and damping its
//!   own plan lacks (see hyperpbd_gpu::GpuBatch for that and for what a
//!   GPU batch refuses); a world a guard rejects is retried alone with
//!   more substeps, as its own adaptive run, the others untouched.
//!   Incremental-potential worlds: each its own backend, the worlds' steps
//!   in lockstep on one device, sharing the host's waits; world k is its
//!   own run bit for bit in both precisions.
//! ```
//! The CPU batch is the reference the GPU batch is held to
//! (tests/gpu/batch.rs).

use crate::gpu::WorldError;
use crate::{
    Backend, BackendError, CpuBackend, Plan, Precision, Scene, SceneError, State, StepReport,
};
use rayon::prelude::*;

/// Why a batch cannot be built or stepped.
#[derive(Debug, thiserror::Error)]
pub enum BatchError {
    /// A batch needs at least one world.
    #[error("worlds: a batch needs at least one world")]
    Empty,
    /// A world's scene is invalid.
    #[error("worlds[{world}].{source}")]
    Scene {
        world: usize,
        #[source]
        source: SceneError,
    },
    /// A world whose topology differs from `worlds[0]`.
    #[error("worlds[{world}].{field}: differs from worlds[0] (worlds of a batch share {what})")]
    Topology {
        world: usize,
        field: String,
        what: &'static str,
    },
    /// A world's backend refused it or failed.
    #[error("worlds[{world}]: {source}")]
    Backend {
        world: usize,
        #[source]
        source: BackendError,
    },
    /// The GPU batch as a whole failed (no adapter, the device).
    #[error("GPU batch: {source}")]
    Device {
        #[source]
        source: BackendError,
    },
    /// The thread pool could not start.
    #[error("cannot start {threads} threads: {why}")]
    Threads { threads: usize, why: String },
}

/// Validated worlds of one topology, each compiled to its plan.
#[derive(Debug, Clone)]
pub struct Batch {
    plans: Vec<Plan>,
    states: Vec<State>,
}

impl Batch {
    /// Validates and compiles every world and checks that all share
    /// `worlds[0]`'s topology (see the module docs).
    pub fn new(worlds: &[Scene]) -> Result<Batch, BatchError> {
        if worlds.is_empty() {
            return Err(BatchError::Empty);
        }
        let mut plans = Vec::with_capacity(worlds.len());
        for (world, scene) in worlds.iter().enumerate() {
            // `Plan::compile` validates the scene first.
            let plan =
                Plan::compile(scene).map_err(|source| BatchError::Scene { world, source })?;
            plans.push(plan);
        }
        for (world, plan) in plans.iter().enumerate().skip(1) {
            same_topology(&plans[0], plan).map_err(|(field, what)| BatchError::Topology {
                world,
                field,
                what,
            })?;
        }
        let states = worlds.iter().map(State::from_scene).collect();
        Ok(Batch { plans, states })
    }

    /// Number of worlds.
    pub fn len(&self) -> usize {
        self.plans.len()
    }

    /// Whether the batch has no worlds (never: [`Batch::new`] refuses that).
    pub fn is_empty(&self) -> bool {
        self.plans.is_empty()
    }

    /// World `k`'s plan.
    pub fn plan(&self, k: usize) -> &Plan {
        &self.plans[k]
    }
}

/// Worlds of `scene`'s solver one GPU batch takes at most: 4096 XPBD
/// worlds (one set of dispatches for all), 256 incremental-potential
/// worlds (one host thread each). Sweeps split their worlds into batches of
/// this size.
pub fn gpu_batch_worlds(scene: &Scene) -> usize {
    match scene.solver {
        crate::Solver::Xpbd(_) => 4096,
        crate::Solver::IncrementalPotential(_) => 256,
    }
}

/// The first field where `other`'s topology differs from `first`'s, and
/// what a batch shares there.
fn same_topology(first: &Plan, other: &Plan) -> Result<(), (String, &'static str)> {
    let check = |same: bool, field: &str, what: &'static str| {
        if same {
            Ok(())
        } else {
            Err((field.to_string(), what))
        }
    };
    check(first.dim == other.dim, "dim", "the dimension")?;
    check(
        first.dt.to_bits() == other.dt.to_bits(),
        "dt",
        "the time step",
    )?;
    check(
        first.substeps == other.substeps,
        "substeps",
        "the substep count",
    )?;
    check(
        first.iterations == other.iterations,
        "iterations",
        "the iteration count",
    )?;
    check(
        first.inverse_mass.len() == other.inverse_mass.len(),
        "particles",
        "the particle count",
    )?;
    for i in 0..first.inverse_mass.len() {
        let field = format!("particles[{i}]");
        check(
            first.inverse_mass[i].to_bits() == other.inverse_mass[i].to_bits(),
            &format!("{field}.mass"),
            "masses and fixed particles",
        )?;
        check(
            first.radius[i].to_bits() == other.radius[i].to_bits(),
            &format!("{field}.radius"),
            "radii",
        )?;
    }
    check(
        first.families.len() == other.families.len(),
        "constraints",
        "the constraint families and obstacles",
    )?;
    for (a, b) in first.families.iter().zip(&other.families) {
        check(
            a.label == b.label
                && std::mem::discriminant(&a.kind) == std::mem::discriminant(&b.kind)
                && a.arity == b.arity
                && a.elements == b.elements
                && a.color_starts == b.color_starts,
            &b.label,
            "each family's kind, elements and colours",
        )?;
    }
    check(
        first.contacts.is_some() == other.contacts.is_some(),
        "collisions",
        "particle contacts on or off",
    )?;
    check(
        std::mem::discriminant(&first.solver) == std::mem::discriminant(&other.solver),
        "solver",
        "the solver",
    )
}

/// A batch on the f64 CPU golden path: worlds stepped in parallel, one
/// thread each (see the module docs).
pub struct CpuBatch {
    worlds: Vec<CpuBackend>,
    pool: rayon::ThreadPool,
}

impl CpuBatch {
    /// Loads every world of `batch`; steps run `threads` worlds at a time.
    pub fn new(batch: &Batch, threads: usize) -> Result<CpuBatch, BatchError> {
        let worlds = batch
            .plans
            .iter()
            .zip(&batch.states)
            .enumerate()
            .map(|(world, (plan, state))| {
                CpuBackend::with_threads(plan.clone(), state, 1)
                    .map_err(|source| BatchError::Backend { world, source })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads.max(1))
            .build()
            .map_err(|e| BatchError::Threads {
                threads,
                why: e.to_string(),
            })?;
        Ok(CpuBatch { worlds, pool })
    }

    /// Number of worlds.
    pub fn len(&self) -> usize {
        self.worlds.len()
    }

    /// Whether the batch has no worlds (never).
    pub fn is_empty(&self) -> bool {
        self.worlds.is_empty()
    }

    /// World `k`'s backend (to read its state or set its forces).
    pub fn world(&mut self, k: usize) -> &mut CpuBackend {
        &mut self.worlds[k]
    }

    /// One step of every world; their reports in world order. All or
    /// nothing (see the module docs).
    pub fn step(&mut self) -> Result<Vec<StepReport>, BatchError> {
        let results: Vec<Result<StepReport, BackendError>> = self
            .pool
            .install(|| self.worlds.par_iter_mut().map(|b| b.step()).collect());
        if results.iter().all(Result::is_ok) {
            return Ok(results.into_iter().flatten().collect());
        }
        // A failed world rolled itself back; the others undo their step.
        for ((world, backend), result) in self.worlds.iter_mut().enumerate().zip(&results) {
            if result.is_ok() {
                backend
                    .revert_step()
                    .map_err(|source| BatchError::Backend { world, source })?;
            }
        }
        let (world, source) = results
            .into_iter()
            .enumerate()
            .find_map(|(k, r)| r.err().map(|e| (k, e)))
            .ok_or(BatchError::Empty)?;
        Err(BatchError::Backend { world, source })
    }
}

impl From<WorldError> for BatchError {
    fn from(e: WorldError) -> Self {
        match e.world {
            Some(world) => BatchError::Backend {
                world,
                source: e.source,
            },
            None => BatchError::Device { source: e.source },
        }
    }
}

/// A batch on the GPU: every world in the same dispatches, one per kernel
/// for all worlds (see the module docs).
pub struct GpuBatch {
    inner: crate::gpu::GpuBatch,
}

impl GpuBatch {
    /// Loads every world of `batch` on an adapter for `precision`.
    pub fn new(batch: &Batch, precision: Precision) -> Result<GpuBatch, BatchError> {
        let (adapter, _) = crate::gpu::request_adapter(precision)
            .map_err(|e| BatchError::Device { source: e.into() })?;
        GpuBatch::on_adapter(&adapter, batch, precision)
    }

    /// Loads every world of `batch` on a device of `adapter`.
    pub fn on_adapter(
        adapter: &wgpu::Adapter,
        batch: &Batch,
        precision: Precision,
    ) -> Result<GpuBatch, BatchError> {
        let plans = batch.plans.clone();
        let inner = crate::gpu::GpuBatch::new(adapter, plans, &batch.states, precision)?;
        Ok(GpuBatch { inner })
    }

    /// Number of worlds.
    pub fn len(&self) -> usize {
        self.inner.plans().len()
    }

    /// Whether the batch has no worlds (never).
    pub fn is_empty(&self) -> bool {
        self.inner.plans().is_empty()
    }

    /// Compute dispatches per step, for all worlds together (`None` for
    /// incremental-potential worlds: theirs follow their Newton
    /// iterations).
    pub fn dispatches_per_step(&self) -> Option<usize> {
        self.inner.dispatches_per_step()
    }

    /// Every world's contact list slots per particle (`None` without
    /// particle contact); each world's grow on their own.
    pub fn contact_list_slots(&self) -> Option<Vec<usize>> {
        self.inner.contact_list_slots()
    }

    /// The origin device positions are relative to (every world's in an
    /// XPBD batch, world 0's in an incremental-potential one; 0 in f64).
    pub fn origin(&self) -> &crate::gpu::SceneOrigin {
        self.inner.origin()
    }

    /// The origin world `world`'s device positions are relative to (its
    /// own in an incremental-potential batch, the batch's in an XPBD one).
    pub fn world_origin(&self, world: usize) -> &crate::gpu::SceneOrigin {
        self.inner.world_origin(world)
    }

    /// One step of every world; their reports in world order. All or
    /// nothing (see the module docs).
    pub fn step(&mut self) -> Result<Vec<StepReport>, BatchError> {
        Ok(self.inner.step()?)
    }

    /// Replaces world `world`'s state (checked first: a bad state changes
    /// nothing).
    pub fn write_state(&mut self, world: usize, state: &State) -> Result<(), BatchError> {
        self.inner
            .write_state(world, state)
            .map_err(|source| BatchError::Backend { world, source })
    }

    /// Replaces world `world`'s external forces from the next step on
    /// (only where its plan has a force term, as `Backend::set_forces`).
    pub fn set_forces(&mut self, world: usize, forces: &[f64]) -> Result<(), BatchError> {
        self.inner
            .set_forces(world, forces)
            .map_err(|source| BatchError::Backend { world, source })
    }

    /// Every world's state, in world order.
    pub fn read_states(&mut self) -> Result<Vec<State>, BatchError> {
        self.inner
            .read_states()
            .map_err(|source| BatchError::Device { source })
    }
}
