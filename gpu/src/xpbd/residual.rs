//! Dispatch side of the step's constraint residual (`shaders/residual.wgsl`
//! ↔ `cpu/src/residual.rs`): one call per family, the chunk table, and the
//! report read back after the step.
//!
//! ```text
//! residual   one workgroup per chunk of CHUNK = 16 · WORKGROUP elements of
//!            any family: max violation and active contacts → partials
//! reduce     one workgroup per family: its chunks → report[2f], report[2f+1]
//! ```
//! Two dispatches per step whatever the number of families — or ONE,
//! `residual_lanes` (a lane per family and world), when every family fits a
//! lane (schedule.rs `fits_a_lane`); maxima and integer counts are exact,
//! so the result is independent of the order.

use hyperpbd_core::{FamilyKind, FamilyResidual, Plan, StepReport};

use super::Families;
use super::call::{Call, OP_RESIDUAL};

/// Elements per residual chunk, for a workgroup of `workgroup`
/// (`CHUNK` in residual.wgsl).
pub(crate) fn chunk_len(workgroup: u32) -> u32 {
    16 * workgroup
}

/// One residual call per family, with its first chunk, and the chunk
/// table `(call index, first element)` (`first_call`: index of the first
/// residual call in the call list).
pub(crate) fn residual_calls(
    plan: &Plan,
    families: &Families,
    first_call: u32,
    workgroup: u32,
) -> (Vec<Call>, Vec<[u32; 2]>) {
    let chunk = chunk_len(workgroup);
    let mut calls = Vec::with_capacity(plan.families.len());
    let mut chunks = Vec::new();
    for (family, f) in plan.families.iter().enumerate() {
        let index = first_call + family as u32;
        let mut call = Call {
            op: OP_RESIDUAL,
            kind: crate::codes::residual_code(&f.kind),
            chunk: chunks.len() as u32,
            ..families.family_call(plan, family, index)
        };
        if let FamilyKind::HyperplaneContact { normal, .. } = &f.kind {
            call.normal = normal.clone();
        }
        if let (Some(layout), true) = (&families.motion, f.kind.is_inequality()) {
            layout.mark(plan, family, 0, true, &mut call);
        }
        if f.kind.is_expression() {
            call.slot_map = super::expression::expression_index(plan, family);
        }
        super::material::set_fields(f, families, family, &mut call);
        for first in (0..f.len() as u32).step_by(chunk as usize) {
            chunks.push([index, first]);
        }
        calls.push(call);
    }
    (calls, chunks)
}

/// The step report of `plan` from its report values (`2 × families`):
/// the kernel calls, the per-family residuals and the active contacts.
pub(crate) fn step_report(plan: &Plan, report: &[f64]) -> StepReport {
    let (residuals, active_contacts) = read_report(plan, report);
    StepReport {
        kernel_calls: plan.kernel_counts(),
        residuals,
        active_contacts,
        ..StepReport::default()
    }
}

/// The per-family residuals and the active contact count from the report
/// (`2 × families` values).
fn read_report(plan: &Plan, report: &[f64]) -> (Vec<FamilyResidual>, usize) {
    let mut residuals = Vec::with_capacity(plan.families.len());
    let mut active_contacts = 0;
    for (family, f) in plan.families.iter().enumerate() {
        residuals.push(FamilyResidual {
            label: f.label.clone(),
            max_violation: report[2 * family],
        });
        if f.kind.is_inequality() {
            active_contacts += report[2 * family + 1] as usize;
        }
    }
    (residuals, active_contacts)
}
