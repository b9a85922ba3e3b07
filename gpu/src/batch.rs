//! Batches of worlds on the GPU: W worlds of one topology stepped by the
//! same dispatches, the world part of the invocation index.
//!
//! ```text
//! shared      the schedule (every call's op, count, colour, flags), the
//!             elements, the contact slot maps, the residual chunks, the
//!             dispatch blocks (world 0's): one pipeline set, one compute
//!             pass, one submit per step for all W worlds
//! per world   world-major: particle records x v p force (n each),
//!             gravity scales, `rest` (rest values, hyperplane offsets,
//!             material rest data), λ, residual partials and report, and
//!             the reals of every call block (compliance, gravity, damping
//!             factor, friction, normal, Lamé): `calls` = W copies
//! kernels     invocation t = world · count + index (step.wgsl's
//!             `split_world`); WORLDS, WORLD_* are override constants, so
//!             a one-world backend compiles to the single-world kernels
//! failure     each failed world (its status word; every world with
//!             particle contact) is stepped alone on a backend of its own
//!             plan from its start-of-step copy, the failed worlds in
//!             lockstep (retry.rs): a guard
//!             rejection is retried with more substeps as its own
//!             adaptive run does, the result put back in its place; an
//!             error that stays fails the step: every world rolled back,
//!             the lowest such world named with its own single run's error
//! ```
//! World k runs exactly its own single-world step: the same kernels on the
//! same values in the same order, its parameters read from its own call
//! blocks. So in f64 (origin 0) it is bit for bit world k run alone, and
//! so the CPU golden path (tests/gpu/batch.rs). In f32 all worlds share
//! one origin (the box of every world), within the single-world bound.
//!
//! The worlds run one schedule: the union of their stages (union.rs). A
//! world whose gravity, forces, friction or damping are zero (stages its
//! own plan compiles away) runs those stages as exact identities: it
//! skips the responses it lacks (`Call::absent`, per world) and its zero
//! gravity / forces leave prediction's sum as its own kernel computes it.
//! Every other call must match world 0's (the same kernels, laws and
//! flags: another law is refused, naming the world and the call).
//!
//! Particle contact runs in the same dispatches too (contact_step.rs,
//! contact.wgsl): per world its own grid, lists (grown on their own) and
//! outcome, its μ and margin from its own plan (μ = 0 takes the kernel's
//! frictionless branch, as its own run does: an exact identity).
//! Guards and adaptive steps run per world (retry.rs); the small schedule
//! and the primal residual are refused.
//!
//! Worlds of the incremental-potential solvers (barrier, coupled) are
//! stepped another way (lockstep.rs): a backend of its own plan per world,
//! the worlds' steps on host threads in lockstep, sharing the device and
//! the host's waits (one wait per round for every world), each world bit
//! for bit its own run.

mod lockstep;
mod retry;
mod union;

use hyperpbd_core::{
    Attempt, Backend, BackendError, GpuError, Plan, State, StepReport, check_state,
};

use crate::backend::contact_step::contact_report;
use crate::backend::status::{StatusReader, refuse_cut_loops};
use crate::backend::worlds::Worlds;
use crate::backend::{GpuBackend, XpbdStep};
use crate::contact::Outcome;
use crate::context::DeviceSource;
use crate::params::read_reals;
use crate::resident_backend::{Resident, ResidentBackend};
use crate::xpbd::Families;
use crate::xpbd::call::Call;
use crate::xpbd::schedule::{Schedule, StepMode};
use crate::{Precision, SceneOrigin};
use lockstep::LockstepWorlds;
use retry::Retries;
use union::Union;

/// Every world's rest values and call blocks, world after world, each
/// laid out as world 0's (positions relative to `origin`; the fused
/// schedule of `ran[k]`, world k's plan running the union of the stages,
/// for kernels of `workgroup`, `software` as the adapter is; a response
/// absent from its own `plans[k]` marked `absent`): the first world whose
/// particles, families or calls differ from world 0's is refused by name.
fn lay_out(
    (plans, ran, union): (&[Plan], &[Plan], &Union),
    origin: &SceneOrigin,
    (workgroup, software): (u32, bool),
) -> Result<(Vec<f64>, Vec<Call>), WorldError> {
    let mut shared: Option<(Families, Schedule)> = None;
    let (mut rest, mut calls) = (Vec::new(), Vec::new());
    for (k, (own_plan, plan)) in plans.iter().zip(ran).enumerate() {
        let world = |source: BackendError| WorldError {
            world: Some(k),
            source,
        };
        let own = Families::new(plan, origin).map_err(|e| world(e.into()))?;
        let mut steps = Schedule::new(plan, &own, workgroup, Some(StepMode::Fused), software);
        for call in &mut steps.calls {
            if let Some(kernel) = &call.kernel {
                call.absent = union.absent(own_plan, kernel);
            }
        }
        if let Some((families, schedule)) = &shared {
            if own.elements != families.elements
                || own.slot_maps != families.slot_maps
                || own.rest.len() != families.rest.len()
                || plan.particle_count() != plans[0].particle_count()
            {
                return Err(world(differs("its particles and families")));
            }
            if steps.calls.len() != schedule.calls.len() {
                return Err(world(differs("its stages")));
            }
            for (c, (a, b)) in steps.calls.iter().zip(&schedule.calls).enumerate() {
                if !a.same_shape(b) {
                    let what = match b.kernel {
                        Some(kernel) => format!("call {c} ({kernel:?}): its kernel and flags"),
                        None => format!("call {c} (residual): its families"),
                    };
                    return Err(world(differs(&what)));
                }
            }
        }
        rest.extend_from_slice(&own.rest);
        calls.extend_from_slice(&steps.calls);
        if shared.is_none() {
            shared = Some((own, steps));
        }
    }
    Ok((rest, calls))
}

/// A world whose `what` differs from world 0's.
fn differs(what: &str) -> BackendError {
    GpuError::Unsupported {
        what: format!(
            "{what} differ from worlds[0]'s; a GPU batch runs one schedule for all worlds (the \
             union of their stages, where a world skips the friction or damping it lacks and \
             predicts with its zero gravity or forces; every other call the same kernel, law \
             and flags)"
        ),
    }
    .into()
}

/// A GPU batch failure: the world it names (`None`: the batch as a
/// whole, e.g. the device) and the error.
#[derive(Debug, thiserror::Error)]
#[error("{}{source}", world.map(|k| format!("worlds[{k}]: ")).unwrap_or_default())]
pub struct WorldError {
    /// The world (index into the batch's plans), `None` for the batch.
    pub world: Option<usize>,
    /// What went wrong.
    #[source]
    pub source: BackendError,
}

impl WorldError {
    fn batch(source: impl Into<BackendError>) -> Self {
        WorldError {
            world: None,
            source: source.into(),
        }
    }
}

/// W worlds of one topology on one GPU device (see the module docs).
pub struct GpuBatch {
    plans: Vec<Plan>,
    stepping: Stepping,
}

/// How the worlds are stepped.
enum Stepping {
    /// XPBD: one backend, every world in the same dispatches, and a
    /// backend of its own plan per world for retries (retry.rs).
    Dispatched {
        backend: Box<GpuBackend>,
        retries: Retries,
    },
    /// The incremental-potential solvers: a backend per world, in
    /// lockstep (lockstep.rs).
    Lockstep(LockstepWorlds),
}

impl GpuBatch {
    /// Loads `plans[k]` with `states[k]` for every world k on a device of
    /// `adapter` (the fused schedule).
    pub fn new(
        adapter: &wgpu::Adapter,
        plans: Vec<Plan>,
        states: &[State],
        precision: Precision,
    ) -> Result<Self, WorldError> {
        if plans.is_empty() || plans.len() != states.len() {
            return Err(WorldError::batch(BackendError::InvalidCall(format!(
                "a GPU batch needs one state per plan and at least one world ({} plans, {} states)",
                plans.len(),
                states.len()
            ))));
        }
        for (k, (plan, state)) in plans.iter().zip(states).enumerate() {
            let world = |source: BackendError| WorldError {
                world: Some(k),
                source,
            };
            check_state(plan, state).map_err(&world)?;
            refuse_in_batch(plan, &plans[0]).map_err(|e| world(e.into()))?;
        }
        if plans[0].incremental_potential().is_some() {
            let worlds = LockstepWorlds::new(adapter, &plans, states, precision)?;
            return Ok(GpuBatch {
                plans,
                stepping: Stepping::Lockstep(worlds),
            });
        }
        let dim = plans[0].dim;
        let all: Vec<f64> = states
            .iter()
            .flat_map(|s| s.positions.iter().copied())
            .collect();
        let origin = SceneOrigin::for_state(dim, &all, precision);
        let ctx = DeviceSource::Own(adapter)
            .context(precision)
            .map_err(WorldError::batch)?;
        let software = ctx.summary.device_type == "Cpu";
        let workgroup = crate::shader::ShaderFile::Step.workgroup_size();
        let union = Union::of(&plans).map_err(|k| WorldError {
            world: Some(k),
            source: differs("its stages"),
        })?;
        let ran: Vec<Plan> = plans.iter().map(|p| union.plan_for(p)).collect();
        let (rest, calls) = lay_out((&plans, &ran, &union), &origin, (workgroup, software))?;
        let worlds = Worlds {
            plans: &ran,
            states,
            rest: &rest,
            calls: &calls,
        };
        let how = (precision, origin, Some(StepMode::Fused));
        let (on, step) = ctx
            .building(|| XpbdStep::build(&ctx, ran[0].clone(), &states[0], how, Some(worlds)))
            .map_err(WorldError::batch)?;
        let backend = Box::new(ResidentBackend::from_parts(on, step));
        let retries = Retries::new(plans.len());
        Ok(GpuBatch {
            plans,
            stepping: Stepping::Dispatched { backend, retries },
        })
    }

    /// The worlds' plans, in world order (at least one: [`GpuBatch::new`]
    /// refuses none).
    pub fn plans(&self) -> &[Plan] {
        &self.plans
    }

    /// Compute dispatches per step, for all worlds together (`None` for
    /// incremental-potential worlds, whose dispatches follow their Newton
    /// iterations).
    pub fn dispatches_per_step(&self) -> Option<usize> {
        match &self.stepping {
            Stepping::Dispatched { backend, .. } => Some(backend.dispatches_per_step()),
            Stepping::Lockstep(_) => None,
        }
    }

    /// The origin world 0's device positions are relative to: every
    /// world's in an XPBD batch, world 0's own in an incremental-potential
    /// batch ([`GpuBatch::world_origin`]); 0 in f64.
    pub fn origin(&self) -> &SceneOrigin {
        self.world_origin(0)
    }

    /// The origin world `world`'s device positions are relative to (the
    /// last world's past the last).
    pub fn world_origin(&self, world: usize) -> &SceneOrigin {
        match &self.stepping {
            Stepping::Dispatched { backend, .. } => backend.origin(),
            Stepping::Lockstep(worlds) => worlds.origin(world.min(self.plans.len() - 1)),
        }
    }

    /// One step of every world; their reports in world order. A world
    /// whose step a guard rejects is retried with more substeps as its
    /// own adaptive run would be, the others untouched; the retried worlds
    /// run in lockstep (retry.rs). All or
    /// nothing: when a world fails, every world is put back to its state
    /// before the step and the error is the lowest failing world's, as its
    /// own single run names it. Every report's `host_waits` is the whole
    /// batch step's.
    pub fn step(&mut self) -> Result<Vec<StepReport>, WorldError> {
        match &mut self.stepping {
            Stepping::Dispatched { backend, retries } => {
                step_dispatched(backend, retries, &self.plans)
            }
            Stepping::Lockstep(worlds) => worlds.step(),
        }
    }

    /// Every world's contact list slots per particle (`None` without
    /// particle contact on the XPBD path): each world's grow on their own,
    /// when a step finds a longer list in it (that step then runs again
    /// for every world).
    pub fn contact_list_slots(&self) -> Option<Vec<usize>> {
        match &self.stepping {
            Stepping::Dispatched { backend, .. } => backend.world_list_slots(),
            Stepping::Lockstep(_) => None,
        }
    }

    /// Every world's state, in world order (world coordinates).
    pub fn read_states(&mut self) -> Result<Vec<State>, BackendError> {
        let backend = match &mut self.stepping {
            Stepping::Dispatched { backend, .. } => backend,
            Stepping::Lockstep(worlds) => {
                return (0..self.plans.len())
                    .map(|k| worlds.backend(k).read_state())
                    .collect();
            }
        };
        let all = backend.read_state()?;
        let dim = all.dim;
        let len = self.plans[0].particle_count() * dim;
        Ok(all
            .positions
            .chunks(len.max(1))
            .zip(all.velocities.chunks(len.max(1)))
            .take(self.plans.len())
            .map(|(x, v)| State {
                dim,
                positions: x.to_vec(),
                velocities: v.to_vec(),
            })
            .collect())
    }

    /// Replaces world `world`'s x and v with `state` (checked against its
    /// plan first: a bad state is a typed error and changes nothing).
    pub fn write_state(&mut self, world: usize, state: &State) -> Result<(), BackendError> {
        let plan = world_plan(&self.plans, world)?;
        match &mut self.stepping {
            Stepping::Dispatched { backend, .. } => {
                let first = world * plan.particle_count();
                let on = &mut backend.on;
                on.state.write_from(&on.ctx, plan, first, state)
            }
            Stepping::Lockstep(worlds) => worlds.backend(world).write_state(state),
        }
    }

    /// Replaces world `world`'s external forces (flat, `dim` per particle;
    /// checked against its plan first), as `Backend::set_forces` does for
    /// one world: they act from the next step on.
    pub fn set_forces(&mut self, world: usize, forces: &[f64]) -> Result<(), BackendError> {
        let plan = world_plan(&self.plans, world)?;
        match &mut self.stepping {
            Stepping::Dispatched { backend, .. } => {
                let first = world * plan.particle_count();
                let on = &mut backend.on;
                on.state.set_forces_from(&on.ctx, plan, first, forces)
            }
            Stepping::Lockstep(worlds) => worlds.backend(world).set_forces(forces),
        }
    }
}

/// One step of the XPBD worlds in the same dispatches (`GpuBatch::step`).
fn step_dispatched(
    backend: &mut GpuBackend,
    retries: &mut Retries,
    plans: &[Plan],
) -> Result<Vec<StepReport>, WorldError> {
    let before = backend.on.ctx.host_waits();
    // With particle contact: every world's lists fitted (a world whose
    // did not grew its own and the step ran again), one outcome each.
    let precision = backend.precision();
    let ResidentBackend { on, step, .. } = backend;
    let (block, outcomes) = match step.has_contacts() {
        true => {
            let (outcomes, block) =
                (step.submit_fitting_contact_step(on)).map_err(WorldError::batch)?;
            refuse_cut_loops(on, &block).map_err(WorldError::batch)?;
            (block, Some(outcomes))
        }
        false => (step.submit_step(on).map_err(WorldError::batch)?, None),
    };
    // The worlds the status names as failed, and those retried alone:
    // the same — but every world with particle contact, whose kernels
    // skip every world's later calls after a failure (contact.wgsl's
    // `failed_before`), so that no world's result stands.
    let status = step.status();
    let (named, retried) = failed_worlds(status, &block, plans.len(), outcomes.is_some());
    let values = read_reals(status.report_of(&block), precision);
    let per_world = values.len() / plans.len();
    // The failed worlds, each stepped alone as its own adaptive run, all
    // of them in lockstep: their waits are the lockstep's rounds, not the
    // sum of their own (their contexts count every wait they make).
    let failed: Vec<usize> = (0..plans.len()).filter(|&k| retried[k]).collect();
    let counted = on.ctx.host_waits();
    let (alone, rounds) = match failed.is_empty() {
        true => (Vec::new(), 0),
        false => retries.step_worlds(on, plans, &failed),
    };
    let retry_calls = on.ctx.host_waits() - counted;
    // One result per retried world, in world order.
    let mut alone = alone.into_iter();
    let mut reports = Vec::with_capacity(plans.len());
    for ((k, plan), report) in plans.iter().enumerate().zip(
        values
            .chunks(per_world.max(1))
            .chain(std::iter::repeat(&[][..])),
    ) {
        if retried[k] {
            let own = alone.next().unwrap_or_else(|| {
                Err(GpuError::Other {
                    message: format!("world {k}'s retry did not run"),
                }
                .into())
            });
            reports.push(match own {
                Ok(r) if !named[k] || r.retries() > 0 => r,
                Ok(_) => return Err(roll_back(on, k, passes_alone(k))),
                Err(e) => return Err(roll_back(on, k, e)),
            });
            continue;
        }
        let mut r = match &outcomes {
            Some(o) => contact_report(plan, report, o.get(k).unwrap_or(&Outcome::EMPTY)),
            None => crate::xpbd::step_report(plan, report),
        };
        r.attempts = vec![Attempt {
            substeps: plan.substeps,
            rejection: None,
        }];
        reports.push(r);
    }
    let waits = on.ctx.host_waits() - before - retry_calls + rounds;
    for r in &mut reports {
        r.host_waits = waits;
    }
    Ok(reports)
}

/// `source`, world `world`'s, after every world is put back to its state
/// before the step.
fn roll_back(on: &mut Resident, world: usize, source: BackendError) -> WorldError {
    WorldError {
        world: Some(world),
        source: source.after_rollback(on.state.rollback(&on.ctx)),
    }
}

/// Per world of `worlds`, whether the status `block` says it failed, and
/// whether it is retried alone (see `GpuBatch::step`); nothing when the
/// step did not fail. Failed: the worlds whose own word is set — only the
/// lowest failing world (status word 3) with particle `contact`, whose
/// kernels set no world words, or with one world. Retried: those, or
/// every world with `contact`, or every world from the lowest failing one
/// on if its own word is missing.
fn failed_worlds(
    status: &StatusReader,
    block: &[u8],
    worlds: usize,
    contact: bool,
) -> (Vec<bool>, Vec<bool>) {
    let Some(_) = StatusReader::failure(block) else {
        return (vec![false; worlds], vec![false; worlds]);
    };
    let lowest = u32::from_le_bytes([block[12], block[13], block[14], block[15]]);
    let lowest = if lowest == crate::xpbd::NONE {
        0
    } else {
        lowest as usize
    };
    let own = status.failed_worlds(block);
    if !contact && own.get(lowest) == Some(&true) {
        return (own.clone(), own);
    }
    let named = (0..worlds).map(|k| k == lowest).collect();
    let retried = (0..worlds).map(|k| contact || k >= lowest).collect();
    (named, retried)
}

/// A world the batch step's status names, which its own run accepts at
/// attempt 0: the batch and its single run disagree.
fn passes_alone(world: usize) -> BackendError {
    GpuError::Other {
        message: format!("a batch step failed in world {world}, which steps alone without error"),
    }
    .into()
}

/// World `world`'s plan, or a typed error past the last world.
fn world_plan(plans: &[Plan], world: usize) -> Result<&Plan, BackendError> {
    plans.get(world).ok_or_else(|| {
        BackendError::InvalidCall(format!(
            "world {world}: the batch has {} worlds",
            plans.len()
        ))
    })
}

/// What a batch does not run: XPBD with the primal residual (its element
/// displacements are per world), a world whose solver is not world 0's.
fn refuse_in_batch(plan: &Plan, first: &Plan) -> Result<(), GpuError> {
    let what = if plan.incremental_potential().is_some() != first.incremental_potential().is_some()
    {
        "worlds of two solvers (XPBD and the incremental potential)"
    } else if plan.primal_residual {
        "XPBD with the primal residual"
    } else {
        return Ok(());
    };
    Err(GpuError::Unsupported {
        what: format!(
            "{what} in a GPU batch (run these worlds on the CPU batch or one GPU backend each)"
        ),
    })
}
