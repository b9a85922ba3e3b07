//! Which dispatches run a step: the plan's kernel calls as call blocks, and
//! three schedules over them.
//!
//! ```text
//! calls    substeps × plan.substep_kernels (call = substep · k + index),
//!          one residual call per family, then the kernels of one substep
//!          again with no λ shortcut (run_kernel: exactly the CPU's kernel)
//! exact    one dispatch per call; residual + reduce
//! fused    maximal runs of per-particle calls (predict, contact projection,
//!          velocity, friction, damping — across substep boundaries too) in
//!          ONE `particles` dispatch each; one dispatch per colour of the
//!          other families; residual + reduce
//! small    ONE `step_small` dispatch: the whole step in one workgroup
//!          with a storage barrier between calls; residual + reduce
//! ```
//! Fusing per-particle calls keeps each particle's order of operations:
//! they read and write that particle's records and its own multipliers
//! only. The small schedule keeps the order of all calls (barriers); both
//! give the exact schedule's results bit for bit (tests/gpu/schedules.rs).
//!
//! The automatic choice (measured, docs/performance.md): small on a
//! hardware GPU when the scene's work fits one workgroup — every call has
//! at most WORKGROUP invocations and only per-particle calls and distance or
//! tether colours; fused otherwise, and always on a software adapter
//! (lavapipe runs a workgroup barrier as a coroutine switch, dearer than a
//! dispatch with one worker thread). Plans with particle contact run fused:
//! the contact kernels (gpu/src/contact) are dispatches of their own at the
//! Broadphase and Collide calls, between the fused runs.

use hyperpbd_core::{Family, FamilyKind, Kernel, Plan};

use super::call::{
    Call, OP_DAMPING, OP_FRICTION, OP_GUARD_MEASURE, OP_GUARD_SPEED, OP_HOST, OP_MOTION, OP_NONE,
    OP_PREDICT, OP_PROJECT_CONTACT, OP_PROJECT_DISTANCE, OP_PROJECT_EXPRESSION,
    OP_PROJECT_MATERIAL, OP_PROJECT_ORIENTED, OP_PROJECT_SIMPLEX, OP_RESIDUAL, OP_VELOCITY,
    SEGMENT, dispatch_block, records_io,
};
use super::{Families, friction, guard, integrate, project, residual};
use crate::Precision;

/// How the dispatches of a step are formed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepMode {
    /// One dispatch per kernel call.
    Exact,
    /// Per-particle calls fused into one dispatch per run.
    Fused,
    /// The whole step in one dispatch of one workgroup.
    Small,
}

impl StepMode {
    /// `exact`, `fused` or `small`.
    pub fn as_str(self) -> &'static str {
        match self {
            StepMode::Exact => "exact",
            StepMode::Fused => "fused",
            StepMode::Small => "small",
        }
    }
}

/// The ops, flags and record io of a `particles` pipeline (its
/// overridable constants).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(crate) struct Segment {
    /// Op of call first + k; OP_NONE past the run.
    pub ops: [u8; SEGMENT],
    /// FLAG_* of call first + k (0 past the run).
    pub flags: [u16; SEGMENT],
    /// IO_* of the run.
    pub io: u8,
}

impl Segment {
    fn of(calls: &[Call]) -> Segment {
        let mut ops = [OP_NONE as u8; SEGMENT];
        let mut flags = [0u16; SEGMENT];
        for ((op, flag), call) in ops.iter_mut().zip(&mut flags).zip(calls) {
            *op = call.op as u8;
            *flag = call.flags as u16;
        }
        Segment {
            ops,
            flags,
            io: records_io(calls) as u8,
        }
    }
}

/// What a dispatch runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Run {
    /// `particles`: the per-particle calls of the range (at most
    /// [`SEGMENT`]).
    Particles(Segment),
    /// `project` with OP_PROJECT_DISTANCE / _SIMPLEX / _ORIENTED /
    /// _MATERIAL: one colour, with the call's FLAG_* (pipeline constants
    /// OP0 and FLAGS).
    Distance(u32),
    Simplex(u32),
    Oriented(u32),
    Material(u32),
    /// `project` with OP_PROJECT_EXPRESSION: one colour of an expression
    /// family, with the call's FLAG_*.
    Expression(u32),
    /// `residual`: one workgroup per chunk.
    Residual,
    /// `reduce`: one workgroup per family.
    Reduce,
    /// `residual_lanes`: one invocation per (family, world), when every
    /// family fits one workgroup.
    ResidualLanes,
    /// `step_small`: one workgroup, every call of the range.
    Small,
    /// `guard`: one guard call (guard.wgsl), its op and FLAG_*.
    Guard(u32, u32),
    /// A kernel the host runs between dispatches (broadphase, particle
    /// contact).
    Host(Kernel),
}

impl Run {
    /// The entry point that runs it (`None`: the host runs it).
    pub fn entry(self) -> Option<super::XpbdEntry> {
        use super::XpbdEntry as E;
        Some(match self {
            Run::Particles(segment) => E::Particles(segment),
            Run::Distance(flags) => E::Distance(flags),
            Run::Simplex(flags) => E::Simplex(flags),
            Run::Oriented(flags) => E::Oriented(flags),
            Run::Material(flags) => E::Material(flags),
            Run::Expression(flags) => E::Expression(flags),
            Run::Residual => E::Residual,
            Run::Reduce => E::Reduce,
            Run::ResidualLanes => E::ResidualLanes,
            Run::Small => E::Small,
            Run::Guard(op, flags) => E::Guard(op, flags),
            Run::Host(_) => return None,
        })
    }
}

/// One dispatch: calls `first_call..end_call`, `count` invocations (or
/// workgroups for Residual / Reduce / Small; residual calls for
/// ResidualLanes, each run for every world).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Dispatch {
    pub run: Run,
    pub first_call: u32,
    pub end_call: u32,
    pub count: u32,
}

impl Dispatch {
    /// The uniform `Dispatch` block of step.wgsl (`calls`: every call
    /// block of the schedule): with copies of its calls when its runner
    /// reads them from the block (particles, project, guard).
    pub fn block(&self, calls: &[Call], dim: usize, precision: Precision) -> Vec<u8> {
        let own = match self.run {
            Run::Particles(_)
            | Run::Distance(_)
            | Run::Simplex(_)
            | Run::Oriented(_)
            | Run::Material(_)
            | Run::Expression(_)
            | Run::Guard(..) => calls
                .get(self.first_call as usize..self.end_call as usize)
                .unwrap_or_default(),
            Run::Residual | Run::Reduce | Run::ResidualLanes | Run::Small | Run::Host(_) => &[],
        };
        dispatch_block(
            [self.first_call, self.end_call, self.count, 0],
            own,
            dim,
            precision,
        )
    }
}

/// The calls of a step and its schedules.
pub(crate) struct Schedule {
    /// Every call block (see the module doc for the order).
    pub calls: Vec<Call>,
    /// Residual chunks: (call index, first element).
    pub chunks: Vec<[u32; 2]>,
    /// Kernel calls of one substep.
    pub kernels_per_substep: usize,
    /// Calls of the step proper (before the residual calls).
    pub step_calls: usize,
    /// First call of the run_kernel copies.
    pub run_base: usize,
    /// One dispatch per call.
    pub exact: Vec<Dispatch>,
    /// The dispatches of the chosen mode.
    pub fast: Vec<Dispatch>,
    pub mode: StepMode,
}

impl Schedule {
    /// The schedule of `plan` (its families laid out by `families`) for
    /// kernels of `workgroup` invocations; `mode` None chooses (`software`:
    /// the adapter is a software rasteriser).
    pub fn new(
        plan: &Plan,
        families: &Families,
        workgroup: u32,
        mode: Option<StepMode>,
        software: bool,
    ) -> Schedule {
        let k = plan.substep_kernels.len();
        let mut calls = Vec::new();
        // A projection in the last iteration: the last time its colour is
        // projected in the substep.
        let last_iteration = |index: usize, kernel: Kernel| {
            matches!(kernel, Kernel::Project { .. })
                && !plan.substep_kernels[index + 1..].contains(&kernel)
        };
        for substep in 0..plan.substeps as usize {
            let mut projected = vec![false; plan.families.len()];
            for (index, &kernel) in plan.substep_kernels.iter().enumerate() {
                let call = (substep * k + index) as u32;
                let last = last_iteration(index, kernel);
                calls.push(kernel_call(
                    plan,
                    families,
                    kernel,
                    call,
                    &mut projected,
                    last,
                ));
            }
        }
        let step_end = calls.len();
        let (residuals, chunks) =
            residual::residual_calls(plan, families, step_end as u32, workgroup);
        calls.extend(residuals);
        let run_base = calls.len();
        let mut projected = vec![true; plan.families.len()];
        for (index, &kernel) in plan.substep_kernels.iter().enumerate() {
            calls.push(kernel_call(
                plan,
                families,
                kernel,
                index as u32,
                &mut projected,
                false,
            ));
        }
        let residual = Residual {
            calls: (step_end as u32, run_base as u32),
            chunks: chunks.len() as u32,
            lanes: plan.families.iter().all(|f| fits_a_lane(f, workgroup)),
        };
        let mode = mode.unwrap_or_else(|| choose(plan, &calls[..step_end], workgroup, software));
        let exact = exact(&calls[..step_end], residual);
        let fast = match mode {
            StepMode::Exact => exact.clone(),
            StepMode::Fused => fused(&calls[..step_end], residual),
            StepMode::Small => {
                let mut small = vec![Dispatch {
                    run: Run::Small,
                    first_call: 0,
                    end_call: step_end as u32,
                    count: 1,
                }];
                small.extend(residual.dispatches());
                small
            }
        };
        Schedule {
            calls,
            chunks,
            kernels_per_substep: k,
            step_calls: step_end,
            run_base,
            exact,
            fast,
            mode,
        }
    }

    /// The dispatch that runs `kernel` alone, the CPU's way (λ from memory).
    pub fn run_kernel(&self, kernel: Kernel) -> Option<Dispatch> {
        let index = self
            .calls
            .iter()
            .skip(self.run_base)
            .position(|c| c.kernel == Some(kernel))?;
        Some(single(
            &self.calls[self.run_base + index],
            self.run_base + index,
        ))
    }

    /// Compute dispatches of one step in the chosen mode (residual
    /// included; host kernels and empty dispatches not counted).
    pub fn dispatches_per_step(&self) -> usize {
        self.fast
            .iter()
            .filter(|d| !matches!(d.run, Run::Host(_)) && (d.count > 0 || d.run == Run::Small))
            .count()
    }

    /// The entry points the exact, chosen and run-alone dispatches use
    /// (one pipeline each: the flags of a run-alone call differ from its
    /// step copies', which may skip λ).
    pub fn entries(&self) -> Vec<super::XpbdEntry> {
        let alone: Vec<Dispatch> = (self.run_base..self.calls.len())
            .map(|index| single(&self.calls[index], index))
            .collect();
        let mut used: Vec<super::XpbdEntry> = self
            .exact
            .iter()
            .chain(&self.fast)
            .chain(&alone)
            .filter(|d| d.count > 0 || d.run == Run::Small)
            .filter_map(|d| d.run.entry())
            .collect();
        let mut unique: Vec<super::XpbdEntry> = Vec::new();
        used.sort_by_key(|e| e.rank());
        for e in used {
            if !unique.contains(&e) {
                unique.push(e);
            }
        }
        unique
    }

    /// The plan kernel of step call `call`.
    pub fn kernel_of(&self, call: u32) -> Option<Kernel> {
        self.calls.get(call as usize).and_then(|c| c.kernel)
    }
}

/// The call of `kernel` (`projected[f]`: family f was projected already
/// this substep; `last`: a projection of the family's last iteration).
fn kernel_call(
    plan: &Plan,
    families: &Families,
    kernel: Kernel,
    call: u32,
    projected: &mut [bool],
    last: bool,
) -> Call {
    match kernel {
        Kernel::Predict => integrate::predict(plan, families, call),
        Kernel::Velocity => integrate::velocity(plan, call),
        Kernel::Damping => integrate::damping(plan, call),
        Kernel::Project { family, color } => {
            let first = !projected[family];
            // Every colour of the first iteration is its slots' first
            // projection in the substep.
            if color + 1 == plan.families[family].color_count() {
                projected[family] = true;
            }
            project::project(plan, families, (family, color), call, (first, last))
        }
        Kernel::Friction { family } => friction::friction(plan, families, family, call),
        Kernel::GuardMeasure { family } => guard::measure(plan, families, family, call),
        Kernel::GuardSpeed => guard::speed(plan, call),
        Kernel::Motion => match &families.motion {
            Some(layout) => layout.motion_call(plan, call, super::motion::substep_of(plan, call)),
            None => Call {
                call,
                kernel: Some(kernel),
                ..Call::default()
            },
        },
        Kernel::Broadphase | Kernel::Collide | Kernel::Minimise => Call {
            op: OP_HOST,
            call,
            kernel: Some(kernel),
            ..Call::default()
        },
    }
}

/// The dispatch of call `index` alone.
fn single(call: &Call, index: usize) -> Dispatch {
    let run = match call.op {
        OP_PREDICT | OP_PROJECT_CONTACT | OP_VELOCITY | OP_FRICTION | OP_DAMPING | OP_MOTION => {
            Run::Particles(Segment::of(std::slice::from_ref(call)))
        }
        OP_HOST => Run::Host(call.kernel.unwrap_or(Kernel::Broadphase)),
        OP_PROJECT_DISTANCE => Run::Distance(call.flags),
        OP_PROJECT_SIMPLEX => Run::Simplex(call.flags),
        OP_PROJECT_ORIENTED => Run::Oriented(call.flags),
        OP_PROJECT_MATERIAL => Run::Material(call.flags),
        OP_GUARD_MEASURE | OP_GUARD_SPEED => Run::Guard(call.op, call.flags),
        OP_PROJECT_EXPRESSION => Run::Expression(call.flags),
        OP_RESIDUAL | OP_NONE => {
            unreachable!("op {} is never a step call", call.op)
        }
        unknown => unreachable!("op {unknown} is not in codes::OPS"),
    };
    Dispatch {
        run,
        first_call: index as u32,
        end_call: index as u32 + 1,
        count: call.count,
    }
}

/// The step's residual calls and how they run.
#[derive(Debug, Clone, Copy)]
struct Residual {
    /// Its calls, `first..end` (one per family).
    calls: (u32, u32),
    /// Chunks of the chunk table.
    chunks: u32,
    /// Every family fits a lane ([`fits_a_lane`]): one lane per
    /// (family, world) runs the family's elements in order, in one
    /// dispatch without workgroup barriers (lavapipe runs a barrier as a
    /// coroutine switch of every lane). Maxima and integer counts are
    /// exact, so both ways give the same report bit for bit.
    lanes: bool,
}

/// Whether one lane may run family `f`'s residual alone: at most a
/// workgroup of elements, each with O(N) loop trips (distance, tether,
/// plane contact) — a measure or material element loops O(N³) times, and
/// 64 of them in one lane could pass llvmpipe's loop budget (65 535 trips
/// per 8 lanes) in high dimension.
fn fits_a_lane(f: &Family, workgroup: u32) -> bool {
    f.len() <= workgroup as usize
        && matches!(
            f.kind,
            FamilyKind::Distance | FamilyKind::Tether | FamilyKind::HyperplaneContact { .. }
        )
}

impl Residual {
    /// `residual_lanes`; or `residual` over every chunk, then the
    /// per-family reduction.
    fn dispatches(self) -> Vec<Dispatch> {
        let (first_call, end_call) = self.calls;
        let families = end_call - first_call;
        let dispatch = |run, count| Dispatch {
            run,
            first_call,
            end_call,
            count,
        };
        if self.lanes {
            return vec![dispatch(Run::ResidualLanes, families)];
        }
        vec![
            dispatch(Run::Residual, self.chunks),
            dispatch(Run::Reduce, families),
        ]
    }
}

fn exact(step: &[Call], residual: Residual) -> Vec<Dispatch> {
    let mut out: Vec<Dispatch> = step.iter().enumerate().map(|(i, c)| single(c, i)).collect();
    out.extend(residual.dispatches());
    out
}

fn fused(step: &[Call], residual: Residual) -> Vec<Dispatch> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < step.len() {
        if step[i].fusable() {
            let run_end = i + step[i..].iter().take_while(|c| c.fusable()).count();
            for first in (i..run_end).step_by(SEGMENT) {
                let end = (first + SEGMENT).min(run_end);
                out.push(Dispatch {
                    run: Run::Particles(Segment::of(&step[first..end])),
                    first_call: first as u32,
                    end_call: end as u32,
                    count: step[first].count,
                });
            }
            i = run_end;
        } else {
            out.push(single(&step[i], i));
            i += 1;
        }
    }
    out.extend(residual.dispatches());
    out
}

/// Whether the small schedule can run these step calls: nothing on the
/// host, only fusable per-particle calls and distance / tether colours.
pub(crate) fn small_supported(step: &[Call]) -> bool {
    step.iter()
        .all(|c| c.fusable() || c.op == super::call::OP_PROJECT_DISTANCE)
}

/// Fused with particle contact (its kernels are dispatches of their own
/// between the fused runs); exact with other host kernels; small on a
/// hardware GPU when every call fits one workgroup; fused otherwise.
fn choose(plan: &Plan, step: &[Call], workgroup: u32, software: bool) -> StepMode {
    if plan.contacts.is_some() {
        return StepMode::Fused;
    }
    if step.iter().any(|c| c.op == OP_HOST) {
        return StepMode::Exact;
    }
    let fits = step.iter().all(|c| c.count <= workgroup);
    if !software && fits && small_supported(step) {
        StepMode::Small
    } else {
        StepMode::Fused
    }
}

/// The schedule mode the backend would choose for `plan` on a software
/// (`software`) or hardware adapter, and the compute dispatches per step
/// that mode and the exact schedule record, the contact stage's
/// (broadphase, contact iterations, report) included — what
/// `GpuBackend::dispatches_per_step` counts (for `hyperpbd plan`). `None`
/// for plans the XPBD backend does not run (the incremental potential).
pub fn dispatches_per_step(plan: &Plan, software: bool) -> Option<(StepMode, usize, usize)> {
    if plan.incremental_potential().is_some() {
        return None;
    }
    let origin = crate::SceneOrigin::zero(plan.dim);
    let families = Families::new(plan, &origin).ok()?;
    let workgroup = crate::shader::ShaderFile::Step.workgroup_size();
    let chosen = Schedule::new(plan, &families, workgroup, None, software);
    let exact = Schedule::new(plan, &families, workgroup, Some(StepMode::Exact), software);
    let contact = crate::contact::contact_dispatches_per_step(plan);
    Some((
        chosen.mode,
        chosen.dispatches_per_step() + contact,
        exact.dispatches_per_step() + contact,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SceneOrigin;
    use hyperpbd_core::{ConstraintFamily, ConstraintKind, Particle, SceneBuilder};

    /// The residual dispatches of the fused schedule of a 2D chain of
    /// `links` links over a ground plane, with `triangle` an oriented
    /// measure family of one triangle.
    fn residual_runs(links: usize, triangle: bool) -> Vec<Run> {
        let mut b = SceneBuilder::new(2).gravity_along(1, 9.81);
        for i in 0..=links {
            b.particle(Particle::new(vec![i as f64, 1.0], 1.0));
        }
        let edges = (1..=links).map(|i| vec![i - 1, i]).collect();
        b.family(ConstraintFamily::new(ConstraintKind::Distance, 0.0, edges));
        if triangle {
            let elements = vec![vec![0, 1, links + 1]];
            b.particle(Particle::new(vec![0.0, 2.0], 1.0));
            b.family(ConstraintFamily::new(
                ConstraintKind::OrientedMeasure,
                0.0,
                elements,
            ));
        }
        b.hyperplane(vec![0.0, 1.0], 0.0, 0.0);
        let plan = Plan::compile(&b.build().expect("valid scene")).expect("plan");
        let families = Families::new(&plan, &SceneOrigin::zero(2)).expect("families");
        let schedule = Schedule::new(&plan, &families, 64, Some(StepMode::Fused), true);
        schedule
            .fast
            .iter()
            .map(|d| d.run)
            .filter(|r| matches!(r, Run::Residual | Run::Reduce | Run::ResidualLanes))
            .collect()
    }

    #[test]
    fn small_distance_and_contact_families_run_the_residual_in_lanes() {
        assert_eq!(residual_runs(20, false), [Run::ResidualLanes]);
        // 64 links and 65 particles: the contact family has 65 elements.
        assert_eq!(residual_runs(64, false), [Run::Residual, Run::Reduce]);
    }

    #[test]
    fn a_measure_family_keeps_the_chunked_residual() {
        assert_eq!(residual_runs(3, true), [Run::Residual, Run::Reduce]);
    }
}
