//! Contact forces on the golden path, when a step is asked for them: core's
//! [`ImpulseRecorder`] around the step's kernels (`impulse_recorder.rs`
//! has the measurement, `contact_forces.rs` the definition), and the
//! barrier path's part at its accepted iterate, here:
//!
//! ```text
//! barrier path, per substep at the accepted iterate x:
//!   J_i += −b'(d_io) ∇d_io h for every active obstacle o, also on o
//!   coupled step: its contacts' own impulses (coupled::contact_impulses)
//! ```

use hyperpbd_core::Plan;
use hyperpbd_core::impulse_recorder::ImpulseRecorder;

/// The barrier path's contact impulses at the accepted iterate `x` of a
/// substep (`coupled`: the coupled step's scratch, which holds its lags
/// and element records at `x`).
pub(crate) fn minimised(
    recorder: &mut ImpulseRecorder,
    plan: &Plan,
    coupled: &crate::coupled::Workspace,
    x: &[f64],
) {
    let Some(ip) = plan.incremental_potential() else {
        return;
    };
    recorder.barriers(plan, ip, x);
    if ip.coupled.is_some() {
        crate::coupled::contact_impulses(plan, ip, coupled, x, recorder.impulses_mut());
    }
}
