//! Two choices of how a CPU step runs, made once per plan: whether it
//! moves to the thread pool, and which kernels at a substep's end fuse
//! with the next prediction. Neither changes a result.

use crate::parallel::Workers;
use crate::{collide, incremental_potential, integrate, project, residual};
use hyperpbd_core::{Kernel, Plan};

/// Whether any loop of `plan` is longer than its kernel's chunk on
/// `workers` (so that it runs on several threads).
pub(crate) fn splits_somewhere(plan: &Plan, workers: &Workers) -> bool {
    let count = plan.particle_count();
    let colours = plan
        .families
        .iter()
        .flat_map(|f| (0..f.color_count()).map(|c| f.color(c).len()));
    let splits = |len: usize, grain: usize| workers.splits(len, grain);
    splits(count, integrate::PARTICLE_GRAIN)
        || colours
            .into_iter()
            .any(|len| splits(len, project::ELEMENT_GRAIN))
        || plan
            .families
            .iter()
            .any(|f| splits(f.len(), residual::RESIDUAL_GRAIN))
        || (plan.contacts.is_some() && splits(count, collide::BOX_GRAIN))
        || (plan.incremental_potential().is_some()
            && splits(count, incremental_potential::PARTICLE_GRAIN))
}

/// How many kernels at the end of the plan's substep fuse with the next
/// substep's prediction: velocity (1) or velocity and damping (2), when
/// the substep begins with the prediction and nothing else follows the
/// velocity (friction works per contact, not per particle).
pub(crate) fn fused_tail(plan: &Plan) -> Option<usize> {
    match plan.substep_kernels.as_slice() {
        [Kernel::Predict, .., Kernel::Velocity] => Some(1),
        [Kernel::Predict, .., Kernel::Velocity, Kernel::Damping] => Some(2),
        _ => None,
    }
}
