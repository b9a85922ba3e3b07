//! Naming a failed step's error, as the CPU names it, from the status
//! word (call, index) the device wrote; the state rolled back after.
//!
//! ```text
//! guard call      a violation is the status word (guard call, first slot /
//!                 particle); every later call of the step does nothing, but
//!                 the calls after it still ran, so the step is rerun exactly
//!                 through the guard call; the host reads that state once,
//!                 names the value with the CPU's functions
//!                 (hyperpbd_core::guards), then rolls back
//! fused schedule  the failing call is found by rerunning the step exactly
//!                 (one dispatch per call)
//! material call   the law's refusal (or the element guard's rejection) at
//!                 the positions that projection saw (rerun through it)
//! other           NonFiniteConstraint / NonFiniteParticle (Program::step_error)
//! ```

use hyperpbd_core::element_refusal;
use hyperpbd_core::guards::{
    element_ratio_at, element_verdict, material_refusal_error, measure_rejection, speed_rejection,
    squared_speed,
};
use hyperpbd_core::{BackendError, FamilyKind, GpuError, GuardKind, Kernel, StepError};

use super::contact_step::ContactStage;
use super::program::Program;
use super::status::StatusReader;
use crate::resident_backend::Resident;
use crate::xpbd::schedule::StepMode;

/// The program of a failed step and its contact stage.
pub(crate) type Failed<'a> = (&'a Program, Option<&'a ContactStage>);

/// The error of a step whose status names `failed` (call, index), with
/// the state rolled back. A rollback or rerun that fails keeps the step's
/// error as its source.
pub(crate) fn diagnosed_error(
    on: &mut Resident,
    (program, contacts): Failed<'_>,
    failed: (u32, u32),
) -> BackendError {
    if let Some(rejected) = guard_error(on, (program, contacts), failed) {
        return rejected;
    }
    let diagnosed = if program.schedule.mode == StepMode::Fused {
        diagnose(on, (program, contacts), failed)
    } else {
        on.state.rollback(&on.ctx).map(|()| failed)
    };
    match diagnosed {
        Ok((call, index)) => material_error(on, (program, contacts), call, index)
            .unwrap_or_else(|| program.step_error(&on.plan, call, index)),
        Err(e) => program
            .step_error(&on.plan, failed.0, failed.1)
            .after_rollback(Err(e)),
    }
}

/// The failing call of the step rerun exactly (`fallback` if none fails
/// then), the state rolled back.
fn diagnose(
    on: &mut Resident,
    (program, contacts): Failed<'_>,
    fallback: (u32, u32),
) -> Result<(u32, u32), GpuError> {
    program.rerun_exact(on, None, contacts)?;
    let block = program.status.read(&on.ctx, false)?;
    let found = StatusReader::failure(&block).unwrap_or(fallback);
    on.state.rollback(&on.ctx)?;
    Ok(found)
}

/// The error of a failed material projection (call `call`, slot `index`;
/// the state rolled back): the law's refusal — or, under element guards,
/// the guard's rejection — named as the CPU names it
/// (`guards::material_refusal_error`), from the positions that projection
/// saw (the step rerun exactly through it: the failing element wrote
/// nothing and no other element of its colour moves its particles).
/// `None` for any other call, or when the element evaluates there (a
/// non-finite value or update: the caller's `NonFiniteConstraint`).
fn material_error(
    on: &mut Resident,
    (program, contacts): Failed<'_>,
    call: u32,
    index: u32,
) -> Option<BackendError> {
    let Some(Kernel::Project { family, .. }) = program.schedule.kernel_of(call) else {
        return None;
    };
    if !matches!(on.plan.families[family].kind, FamilyKind::Material { .. }) {
        return None;
    }
    let seen = program
        .rerun_exact(on, Some(call), contacts)
        .and_then(|()| on.state.read(&on.ctx));
    let rolled_back = on.state.rollback(&on.ctx);
    let positions = match seen {
        Ok(state) => state.positions,
        Err(e) => return Some(BackendError::from(e).after_rollback(rolled_back)),
    };
    let f = &on.plan.families[family];
    let refusal = element_refusal(on.plan.dim, f, index as usize, &positions)?;
    let substep = program.substep_of(call);
    let error = material_refusal_error(&on.plan, family, index as usize, refusal, substep);
    Some(BackendError::from(error).after_rollback(rolled_back))
}

/// The rejection of a step whose status names a guard call, with the
/// state rolled back; `None` when the failing call is no guard.
fn guard_error(
    on: &mut Resident,
    (program, contacts): Failed<'_>,
    failed: (u32, u32),
) -> Option<BackendError> {
    let kernel = program.schedule.kernel_of(failed.0)?;
    if !matches!(kernel, Kernel::GuardMeasure { .. } | Kernel::GuardSpeed) {
        return None;
    }
    // The calls after a failing one still run (the step is refused
    // anyway), so the state the step left lies past the rejected substep:
    // rerun the step exactly through the guard call, then name the value
    // from that state, as the CPU does.
    if let Err(e) = program.rerun_exact(on, Some(failed.0), contacts) {
        return Some(on.roll_back_after(e.into()));
    }
    let found = guard_rejection(on, program, failed)?;
    Some(on.roll_back_after(found.unwrap_or_else(BackendError::from)))
}

/// The rejection named by a status word whose failing call `call` is a
/// guard, at `index`, from the state as the failure left it (the caller
/// rolls back); `None` when `call` is no guard.
pub(crate) fn guard_rejection(
    on: &mut Resident,
    program: &Program,
    (call, index): (u32, u32),
) -> Option<Result<BackendError, GpuError>> {
    let kernel = program.schedule.kernel_of(call)?;
    if !matches!(kernel, Kernel::GuardMeasure { .. } | Kernel::GuardSpeed) {
        return None;
    }
    let substep = program.substep_of(call);
    let state = match on.state.read(&on.ctx) {
        Ok(state) => state,
        Err(e) => return Some(Err(e)),
    };
    let plan = &on.plan;
    let guards = plan.guards.clone().unwrap_or_default();
    let slot = index as usize;
    let rejection = match kernel {
        Kernel::GuardMeasure { family } => {
            let j = element_ratio_at(plan, family, slot, &state.positions);
            // f32 kernels may round J across the limit where the f64
            // evaluation of the same state does not: the device's verdict
            // stands, the value is the host's J.
            let (guard, limit) = element_verdict(&guards, j).unwrap_or(if guards.orientation {
                (GuardKind::Orientation, 0.0)
            } else {
                (
                    GuardKind::MinMeasureRatio,
                    guards.min_measure_ratio.unwrap_or(0.0),
                )
            });
            measure_rejection(plan, family, (slot, guard, j, limit), substep)
        }
        _ => {
            let dim = plan.dim;
            let v = state
                .velocities
                .get(slot * dim..(slot + 1) * dim)
                .unwrap_or(&[]);
            let limit = guards.max_speed.unwrap_or(0.0);
            speed_rejection((slot, squared_speed(v).sqrt(), limit), substep)
        }
    };
    Some(Ok(StepError::GuardRejected(rejection).into()))
}
