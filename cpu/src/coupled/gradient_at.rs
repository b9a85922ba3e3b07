//! ∇F of the coupled step at an arbitrary point, in f64, by the golden
//! path's own gradient code: what the GPU's f32 bound (docs/implicit.md
//! §12) recomputes on the host at the GPU's iterate instead of trusting
//! the residual the device reports.
//!
//! ```text
//! from the step's start (x^t, v^t):  x~, loads, plane lags and pair lags at x^t   (setup.rs)
//! at y:   pairs P(y) = every pair within d^ at y (static boxes, margin d^/2)
//!         elements (springs, materials, balls, pair friction) evaluated at y
//!         g = M (y − x~) − h² load + h² (own terms + gathered elements)          (particles.rs)
//! ```
//! A pair farther than d^ at y contributes exactly 0, so P(y) gives the
//! same gradient as any superset (the minimiser's swept pair sets).

use super::Workspace;
use super::elements::Terms;
use super::particles::Context;
use super::setup;
use crate::parallel::Workers;
use hyperpbd_core::{Plan, Refusal};

/// ∇F at `y` (flat, N per particle; 0 for fixed particles) of the coupled
/// step that starts from `start` = (x^t, v^t) with external forces
/// `force`. A refusal where the golden step would refuse at x^t (d ≤ 0,
/// overlapping balls) or where an element or particle is not finite at y.
pub fn coupled_gradient(
    plan: &Plan,
    start: (&[f64], &[f64]),
    force: &[f64],
    y: &[f64],
) -> Result<Vec<f64>, Refusal> {
    let invalid = || Refusal::NonFinite { particle: 0 };
    let ip = plan.incremental_potential().ok_or_else(invalid)?;
    let coupled = ip.coupled.as_ref().ok_or_else(invalid)?;
    let workers = Workers::serial();
    let mut ws = Workspace::default();
    let Workspace {
        particles,
        elements,
        setup,
        ..
    } = &mut ws;
    setup::start(plan, start.0, start.1, force, particles);
    setup.lags(&workers, plan, ip, coupled, particles)?;
    let pair_lags = std::mem::take(&mut setup.pair_lags);
    setup.sweep_pairs(&workers, plan, ip, y, y);
    elements.rebuild(plan, &setup.pairs, &pair_lags);
    let start = particles.start.clone();
    let slip_length = coupled.slip_velocity * plan.h;
    let terms = Terms {
        plan,
        law: &ip.law,
        start: &start,
        lags: &pair_lags,
        slip_length,
    };
    let context = Context {
        plan,
        ip,
        slip_length,
    };
    elements
        .evaluate(&workers, &terms, y)
        .map_err(|e| Refusal::NonFinite {
            particle: elements.first_particle(e),
        })?;
    let mut gradient = vec![0.0; y.len()];
    particles
        .gradient(&workers, &context, elements, y, &mut gradient)
        .map_err(|particle| Refusal::NonFinite { particle })?;
    Ok(gradient)
}
