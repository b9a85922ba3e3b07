//! Prediction, velocity reconstruction and damping.
//!
//! ```text
//! predict    for dynamic i: v_i += h (s_i g + w_i f_i);  p_i = x_i;  x_i += h v_i
//! velocity   for dynamic i: v_i = (x_i − p_i) / h
//! damping    for dynamic i: v_i *= exp(−rate h)        (factor from the plan)
//! ```
//! Fixed particles (w = 0) never move; p = x holds for them too. `p` is
//! scratch of the substep: after a failed prediction only the particles up
//! to the failing one have it (the step is rolled back anyway).
//! Each returns the first particle that became non-finite, if any.

use crate::dim::{Dim, with_dim};
use hyperpbd_core::Plan;

/// Prediction. `p` receives the substep's start positions.
pub fn predict(
    plan: &Plan,
    x: &mut [f64],
    v: &mut [f64],
    p: &mut [f64],
    force: &[f64],
) -> Result<(), usize> {
    with_dim!(plan.dim, predict_in(plan, x, v, p, force))
}

fn predict_in<D: Dim>(
    dim: D,
    plan: &Plan,
    x: &mut [f64],
    v: &mut [f64],
    p: &mut [f64],
    force: &[f64],
) -> Result<(), usize> {
    let n = dim.n();
    let h = plan.h;
    let gravity = &plan.gravity[..n];
    p.copy_from_slice(x);
    let particles = x.chunks_exact_mut(n).zip(v.chunks_exact_mut(n));
    let parameters = force
        .chunks_exact(n)
        .zip(plan.inverse_mass.iter().zip(&plan.gravity_scale));
    for (i, ((xi, vi), (fi, (&w, &s)))) in particles.zip(parameters).enumerate() {
        if w == 0.0 {
            continue;
        }
        for a in 0..n {
            let mut acc = 0.0;
            if plan.predict.gravity {
                acc += s * gravity[a];
            }
            if plan.predict.force {
                acc += w * fi[a];
            }
            vi[a] += h * acc;
            xi[a] += h * vi[a];
        }
        if !(vi.iter().all(|c| c.is_finite()) && xi.iter().all(|c| c.is_finite())) {
            return Err(i);
        }
    }
    Ok(())
}

/// Velocity reconstruction.
pub fn velocity(plan: &Plan, x: &[f64], v: &mut [f64], p: &[f64]) -> Result<(), usize> {
    with_dim!(plan.dim, velocity_in(plan, x, v, p))
}

fn velocity_in<D: Dim>(
    dim: D,
    plan: &Plan,
    x: &[f64],
    v: &mut [f64],
    p: &[f64],
) -> Result<(), usize> {
    let n = dim.n();
    let h = plan.h;
    let particles = v
        .chunks_exact_mut(n)
        .zip(x.chunks_exact(n).zip(p.chunks_exact(n)));
    for (i, ((vi, (xi, pi)), &w)) in particles.zip(&plan.inverse_mass).enumerate() {
        if w == 0.0 {
            continue;
        }
        for a in 0..n {
            vi[a] = (xi[a] - pi[a]) / h;
        }
        if !vi.iter().all(|c| c.is_finite()) {
            return Err(i);
        }
    }
    Ok(())
}

/// Exponential damping with the plan's per-substep factor.
pub fn damping(plan: &Plan, v: &mut [f64]) {
    if let Some((_, factor)) = plan.damping {
        with_dim!(plan.dim, damping_in(plan, factor, v));
    }
}

fn damping_in<D: Dim>(dim: D, plan: &Plan, factor: f64, v: &mut [f64]) {
    for (vi, &w) in v.chunks_exact_mut(dim.n()).zip(&plan.inverse_mass) {
        if w > 0.0 {
            for c in vi {
                *c *= factor;
            }
        }
    }
}
