//! Prediction, velocity reconstruction and damping.
//!
//! ```text
//! predict    for dynamic i: v_i += h (s_i g + w_i f_i);  p_i = x_i;  x_i += h v_i
//! velocity   for dynamic i: v_i = (x_i − p_i) / h
//! damping    for dynamic i: v_i *= exp(−rate h)        (factor from the plan)
//! ```
//! Fixed particles (w = 0) never move; p = x holds for them too. `p` is
//! scratch of the substep. Each returns the first particle that became
//! non-finite, if any, after updating all particles of its chunk (the
//! step is rolled back anyway).
//! Particles are independent: they run in chunks of [`PARTICLE_GRAIN`]
//! (`parallel.rs`), every particle with the arithmetic above.

use crate::dim::{Dim, with_dim};
use crate::parallel::Workers;
use hyperpbd_core::Plan;
use multiversion::multiversion;
use std::ops::Range;

/// Particles per chunk of a per-particle stage (≈ 8 µs of work: up to
/// this many a stage runs on the calling thread).
pub const PARTICLE_GRAIN: usize = 2048;

/// The particle arrays the prediction updates: positions `x`, velocities
/// `v`, the substep's start positions `p` (written), external forces.
#[derive(Debug)]
pub struct Motion<'a> {
    pub x: &'a mut [f64],
    pub v: &'a mut [f64],
    pub p: &'a mut [f64],
    pub force: &'a [f64],
}

/// Prediction. `p` receives the substep's start positions.
pub fn predict(workers: &Workers, plan: &Plan, motion: Motion<'_>) -> Result<(), usize> {
    let Motion { x, v, p, force } = motion;
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
    let particles = x
        .chunks_exact_mut(n)
        .zip(v.chunks_exact_mut(n))
        .zip(p.chunks_exact_mut(n));
    let parameters = force[range.start * n..range.end * n].chunks_exact(n).zip(
        plan.inverse_mass[range.clone()]
            .iter()
            .zip(&plan.gravity_scale[range.clone()]),
    );
    for (((xi, vi), pi), (fi, (&w, &s))) in particles.zip(parameters) {
        pi.copy_from_slice(xi);
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
    }
    first_non_finite(dim, &plan.inverse_mass[range.clone()], [x, v])
        .map_or(Ok(()), |i| Err(range.start + i))
}

/// The first dynamic particle (index into `w`) with a non-finite value in
/// any of `values` (`dim` per particle). One cheap pass over everything
/// first, the particle search only when it finds something.
fn first_non_finite<D: Dim, const K: usize>(
    dim: D,
    w: &[f64],
    values: [&[f64]; K],
) -> Option<usize> {
    let mut finite = true;
    for values in values {
        for c in values {
            finite &= c.is_finite();
        }
    }
    if finite {
        return None;
    }
    let n = dim.n();
    (0..w.len()).find(|&i| {
        w[i] != 0.0
            && values
                .iter()
                .any(|values| values[i * n..(i + 1) * n].iter().any(|c| !c.is_finite()))
    })
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
/// Particles go in blocks of [`VELOCITY_BLOCK`]: a block of dynamic
/// particles is one flat loop over its coordinates (whole SIMD registers
/// of quotients); a block with a fixed particle (w = 0), and the last
/// particles, go particle by particle, a fixed one keeping its velocity.
/// Every written velocity is the same quotient either way (and with AVX
/// four quotients per instruction: IEEE division is exact-rounded at any
/// width, and Rust never fuses a multiply-add on its own).
#[multiversion(targets("x86_64+avx"))]
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
    let w = &plan.inverse_mass[range.clone()];
    let values = VELOCITY_BLOCK * n;
    let blocks = v.len() / values * values;
    let (v_blocks, v_rest) = v.split_at_mut(blocks);
    let (x_blocks, x_rest) = x.split_at(blocks);
    let (p_blocks, p_rest) = p.split_at(blocks);
    let (w_blocks, w_rest) = w.split_at(blocks / n.max(1));
    let each = v_blocks
        .chunks_exact_mut(values)
        .zip(
            x_blocks
                .chunks_exact(values)
                .zip(p_blocks.chunks_exact(values)),
        )
        .zip(w_blocks.chunks_exact(VELOCITY_BLOCK));
    for ((vb, (xb, pb)), wb) in each {
        if wb.iter().all(|&w| w != 0.0) {
            for ((vi, &xi), &pi) in vb.iter_mut().zip(xb).zip(pb) {
                *vi = (xi - pi) / h;
            }
        } else {
            velocity_each(dim, h, wb, xb, vb, pb);
        }
    }
    velocity_each(dim, h, w_rest, x_rest, v_rest, p_rest);
    first_non_finite(dim, w, [v]).map_or(Ok(()), |i| Err(range.start + i))
}

/// Velocity particle by particle (`w`: their inverse masses); fixed ones
/// keep theirs.
fn velocity_each<D: Dim>(dim: D, h: f64, w: &[f64], x: &[f64], v: &mut [f64], p: &[f64]) {
    let n = dim.n();
    let particles = v
        .chunks_exact_mut(n)
        .zip(x.chunks_exact(n).zip(p.chunks_exact(n)));
    for ((vi, (xi, pi)), &w) in particles.zip(w) {
        if w != 0.0 {
            for a in 0..n {
                vi[a] = (xi[a] - pi[a]) / h;
            }
        }
    }
}

/// Particles per block of [`velocity_in`].
const VELOCITY_BLOCK: usize = 4;

/// Which update of [`velocity_then_predict`] failed, at which particle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Failed {
    /// Velocity reconstruction of the earlier substep.
    Velocity(usize),
    /// Prediction of the later substep.
    Predict(usize),
}

/// Velocity reconstruction (and damping, when the plan damps) of one
/// substep and the prediction of the next in one pass over the particles.
/// Each particle runs the same updates in the same order as with the
/// kernels one after another — they read and write only that particle's
/// values — so the state is the same; the pass saves a trip over memory
/// and a hand-over between threads. A failed velocity wins over any
/// failed prediction, as when the kernels run in turn.
pub fn velocity_then_predict(
    workers: &Workers,
    plan: &Plan,
    motion: Motion<'_>,
) -> Result<(), Failed> {
    let Motion { x, v, p, force } = motion;
    let (count, dim) = (plan.particle_count(), plan.dim);
    // A failure is one index, ordered so that the smallest is the first
    // the kernels in turn would meet: velocities i, then predictions
    // count + i.
    let first = workers.try_for_spans(count, PARTICLE_GRAIN, dim, [x, v, p], |r, [x, v, p]| {
        let velocity = with_dim!(dim, velocity_in(plan, r.clone(), x, v, p));
        if let Some((_, factor)) = plan.damping {
            with_dim!(dim, damping_in(&plan.inverse_mass[r.clone()], factor, v));
        }
        let predicted = with_dim!(dim, predict_in(plan, r, x, v, p, force));
        velocity.and(predicted.map_err(|i| count + i))
    });
    first.map_err(|i| match i.checked_sub(count) {
        Some(i) => Failed::Predict(i),
        None => Failed::Velocity(i),
    })
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
