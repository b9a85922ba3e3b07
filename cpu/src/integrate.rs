//! Prediction, velocity reconstruction and damping.
//!
//! ```text
//! predict    for dynamic i: v_i += h (s_i g + w_i f_i);  p_i = x_i;  x_i += h v_i
//! velocity   for dynamic i: v_i = (x_i − p_i) / h
//! damping    for dynamic i: v_i *= exp(−rate h)        (factor from the plan)
//! ```
//! Fixed particles (w = 0) never move; p = x holds for them too. `p` is
//! scratch of the substep: after a failed prediction only some particles
//! have it (the step is rolled back anyway).
//! Each returns the first particle that became non-finite, if any.
//! Particles are independent: they run in chunks of [`PARTICLE_GRAIN`]
//! (`parallel.rs`), every particle with the arithmetic above.

use crate::dim::{Dim, with_dim};
use crate::parallel::Workers;
use hyperpbd_core::Plan;
use std::ops::Range;

/// Particles per chunk of a per-particle stage (≈ 10 µs of work: below
/// it a stage runs on the calling thread).
pub const PARTICLE_GRAIN: usize = 4096;

/// Prediction. `p` receives the substep's start positions.
pub fn predict(
    workers: &Workers,
    plan: &Plan,
    x: &mut [f64],
    v: &mut [f64],
    p: &mut [f64],
    force: &[f64],
) -> Result<(), usize> {
    let (count, dim) = (plan.particle_count(), plan.dim);
    workers.try_for_spans(count, PARTICLE_GRAIN, dim, [x, v, p], |r, [x, v, p]| {
        with_dim!(dim, predict_in(plan, r, x, v, p, force))
    })
}

/// Prediction of particles `range` (`x`, `v`, `p`: their coordinates).
fn predict_in<D: Dim>(
    dim: D,
    plan: &Plan,
    range: Range<usize>,
    x: &mut [f64],
    v: &mut [f64],
    p: &mut [f64],
    force: &[f64],
) -> Result<(), usize> {
    let n = dim.n();
    let h = plan.h;
    let gravity = &plan.gravity[..n];
    p.copy_from_slice(x);
    let first = range.start;
    let particles = x.chunks_exact_mut(n).zip(v.chunks_exact_mut(n));
    let parameters = force[range.start * n..range.end * n].chunks_exact(n).zip(
        plan.inverse_mass[range.clone()]
            .iter()
            .zip(&plan.gravity_scale[range]),
    );
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
            return Err(first + i);
        }
    }
    Ok(())
}

/// Velocity reconstruction.
pub fn velocity(
    workers: &Workers,
    plan: &Plan,
    x: &[f64],
    v: &mut [f64],
    p: &[f64],
) -> Result<(), usize> {
    let (count, dim) = (plan.particle_count(), plan.dim);
    workers.try_for_spans(count, PARTICLE_GRAIN, dim, [v], |r, [v]| {
        let coordinates = r.start * dim..r.end * dim;
        let (x, p) = (&x[coordinates.clone()], &p[coordinates]);
        with_dim!(dim, velocity_in(plan, r, x, v, p))
    })
}

/// Velocity of particles `range` (`x`, `v`, `p`: their coordinates).
fn velocity_in<D: Dim>(
    dim: D,
    plan: &Plan,
    range: Range<usize>,
    x: &[f64],
    v: &mut [f64],
    p: &[f64],
) -> Result<(), usize> {
    let n = dim.n();
    let h = plan.h;
    let first = range.start;
    let particles = v
        .chunks_exact_mut(n)
        .zip(x.chunks_exact(n).zip(p.chunks_exact(n)));
    for (i, ((vi, (xi, pi)), &w)) in particles.zip(&plan.inverse_mass[range]).enumerate() {
        if w == 0.0 {
            continue;
        }
        for a in 0..n {
            vi[a] = (xi[a] - pi[a]) / h;
        }
        if !vi.iter().all(|c| c.is_finite()) {
            return Err(first + i);
        }
    }
    Ok(())
}

/// Exponential damping with the plan's per-substep factor.
pub fn damping(workers: &Workers, plan: &Plan, v: &mut [f64]) {
    let Some((_, factor)) = plan.damping else {
        return;
    };
    let (count, dim) = (plan.particle_count(), plan.dim);
    let _ = workers.try_for_spans(count, PARTICLE_GRAIN, dim, [v], |r, [v]| {
        with_dim!(dim, damping_in(&plan.inverse_mass[r], factor, v));
        Ok(())
    });
}

/// Damping of the particles with inverse masses `w` and velocities `v`.
fn damping_in<D: Dim>(dim: D, w: &[f64], factor: f64, v: &mut [f64]) {
    for (vi, &w) in v.chunks_exact_mut(dim.n()).zip(w) {
        if w > 0.0 {
            for c in vi {
                *c *= factor;
            }
        }
    }
}
