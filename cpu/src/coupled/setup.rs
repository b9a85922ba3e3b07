//! The parts of the coupled step around its Newton iteration: the step's
//! per-particle data, feasibility of the start, the friction lags, the
//! warm start, the pair sets and the certified step fraction.
//!
//! ```text
//! pairs over the swept boxes [a, b]:  box_i = [min(a_i, b_i), max(a_i, b_i)] ± (r_i + d^/2)
//!   (the collide broadphase): a pair within d^ anywhere on the segment has overlapping boxes
//!   (the ∞-norm gap is at most the Euclidean one)
//! lags at x^t:  plane p (μ_p > 0), 0 < d < d^:  n_p,                      F_max = μ_p (−b'(d))
//!               simplex s (μ_s > 0), 0 < d < d^: (x − q)/|x − q|,         F_max = μ_s (−b'(d))
//!               (every plane; simplices within reach d^ of the candidate box, barrier.rs;
//!               in the order `near` visits them)
//!               pair (μ_c > 0),    0 < d < d^:  n = (x_j − x_i)/|x_j − x_i|, F_max = μ_c (−b'(d))
//! fraction(x, Δ) = min(1, η · min(obstacle_time over free particles, pair_time over the pairs))
//! ```

// Index loops mirror the math line by line.
#![allow(clippy::needless_range_loop)]

use super::particles::{ObstacleLag, Particles};
use crate::collide::{Contacts, broadphase_on};
use crate::incremental_potential::PARTICLE_GRAIN;
use crate::parallel::Workers;
use hyperpbd_core::IncrementalPotentialPlan;
use hyperpbd_core::barrier::{candidate_box, distance_margin};
use hyperpbd_core::broadphase::{Aabbs, Pair};
use hyperpbd_core::implicit::certified_filter::{TrialMove, fraction, obstacle_time, pair_time};
use hyperpbd_core::implicit::{CoupledPlan, PairLag, normal_force, pair_lags};
use hyperpbd_core::{Plan, Refusal, WarmStart};

/// Pair sets, lags and broadphase scratch of one step.
#[derive(Debug, Default)]
pub struct Setup {
    /// The current pair set (ball–ball barriers).
    pub pairs: Vec<Pair>,
    /// Pair friction lags at x^t.
    pub pair_lags: Vec<PairLag>,
    contacts: Contacts,
    boxes: Aabbs,
}

/// x^t, x~, the masses and the loads of the step into `particles`.
pub fn start(plan: &Plan, x: &[f64], v: &[f64], force: &[f64], particles: &mut Particles) {
    let (dim, h) = (plan.dim, plan.h);
    particles.mass.clear();
    particles.start.clear();
    particles.prediction.clear();
    particles.load.clear();
    particles.start.extend_from_slice(x);
    for i in 0..plan.particle_count() {
        let free = plan.inverse_mass[i] > 0.0;
        let m = if free {
            1.0 / plan.inverse_mass[i]
        } else {
            0.0
        };
        particles.mass.push(m);
        for a in 0..dim {
            let k = i * dim + a;
            particles
                .prediction
                .push(if free { x[k] + h * v[k] } else { x[k] });
            particles
                .load
                .push(m * plan.gravity_scale[i] * plan.gravity[a] + force[k]);
        }
    }
}

impl Setup {
    /// Broadphase over the boxes swept from `from` to `to` into `pairs`
    /// (empty without `collisions`).
    pub fn sweep_pairs(
        &mut self,
        workers: &Workers,
        plan: &Plan,
        ip: &IncrementalPotentialPlan,
        from: &[f64],
        to: &[f64],
    ) {
        self.pairs.clear();
        if !ip.coupled.as_ref().is_some_and(|c| c.collisions) {
            return;
        }
        let margin = 0.5 * ip.law.activation_distance;
        broadphase_on(
            workers,
            plan,
            margin,
            from,
            to,
            &mut self.boxes,
            &mut self.contacts,
        );
        self.pairs.extend_from_slice(&self.contacts.pairs);
    }

    /// Steps 1–2: refuses a start with d ≤ 0 and freezes the friction
    /// lags at x^t = `particles.start`. Leaves the pairs at x^t in `pairs`.
    pub fn lags(
        &mut self,
        workers: &Workers,
        plan: &Plan,
        ip: &IncrementalPotentialPlan,
        coupled: &CoupledPlan,
        particles: &mut Particles,
    ) -> Result<(), Refusal> {
        let dim = plan.dim;
        let x = &particles.start;
        let mut normal = vec![0.0; dim];
        let (mut lo, mut hi) = (vec![0.0; dim], vec![0.0; dim]);
        particles.lags.clear();
        particles.lag_normals.clear();
        particles.lag_offsets.clear();
        particles.lag_offsets.push(0);
        for i in 0..plan.particle_count() {
            if particles.mass[i] > 0.0 {
                let xi = &x[i * dim..(i + 1) * dim];
                let (r, reach) = (plan.radius[i], ip.law.activation_distance);
                candidate_box(
                    xi,
                    r,
                    reach,
                    ip.obstacles.scale,
                    distance_margin(dim, f64::EPSILON),
                    &mut lo,
                    &mut hi,
                );
                for o in ip.obstacles.near(&lo, &hi) {
                    let d = ip.obstacles.distance(o, xi, r, &mut normal);
                    if d.is_nan() || d <= 0.0 {
                        return Err(Refusal::InfeasibleStart {
                            particle: i,
                            obstacle: ip.obstacles.source(o) as usize,
                            distance: d,
                        });
                    }
                    let force = normal_force(&ip.law, d);
                    let mu = coupled.friction(o);
                    if force > 0.0 && mu > 0.0 {
                        particles.lags.push(ObstacleLag {
                            particle: i,
                            obstacle: o,
                            force_limit: mu * force,
                        });
                        particles.lag_normals.extend_from_slice(&normal);
                    }
                }
            }
            particles.lag_offsets.push(particles.lags.len());
        }
        let start = particles.start.clone();
        self.sweep_pairs(workers, plan, ip, &start, &start);
        let friction = coupled.pair_friction;
        self.pair_lags = pair_lags(&ip.law, friction, &start, &plan.radius, dim, &self.pairs)?;
        Ok(())
    }

    /// Step 3–4: x_0 into `x` and P_0 into `pairs` (`lags` left the pairs
    /// at x^t there, which is P_0 for the "previous" warm start).
    pub fn warm_start(
        &mut self,
        workers: &Workers,
        plan: &Plan,
        ip: &IncrementalPotentialPlan,
        coupled: &CoupledPlan,
        particles: &Particles,
        x: &mut [f64],
    ) {
        if coupled.warm_start == WarmStart::Previous {
            return;
        }
        let step: Vec<f64> = (0..x.len())
            .map(|k| particles.prediction[k] - particles.start[k])
            .collect();
        self.sweep_pairs(workers, plan, ip, &particles.start, &particles.prediction);
        let tau = self.filter(workers, plan, ip, particles, &particles.start, &step);
        for k in 0..x.len() {
            x[k] = particles.start[k] + tau * step[k];
        }
    }

    /// The certified fraction of the step `delta` from `x` over every
    /// obstacle of every free particle and every pair of `pairs`.
    pub fn filter(
        &self,
        workers: &Workers,
        plan: &Plan,
        ip: &IncrementalPotentialPlan,
        particles: &Particles,
        x: &[f64],
        delta: &[f64],
    ) -> f64 {
        let dim = plan.dim;
        let epsilon = f64::EPSILON;
        let times = workers.map_chunks(plan.particle_count(), PARTICLE_GRAIN, |r| {
            let mut t = f64::INFINITY;
            for i in r.filter(|&i| particles.mass[i] > 0.0) {
                let span = i * dim..(i + 1) * dim;
                let trial = TrialMove {
                    x: &x[span.clone()],
                    radius: plan.radius[i],
                    delta: &delta[span],
                };
                let time = obstacle_time(&ip.obstacles, trial, epsilon);
                t = t.min(time);
            }
            t
        });
        let mut t = times.into_iter().fold(f64::INFINITY, f64::min);
        let mut points = vec![0.0; 2 * dim];
        let mut steps = vec![0.0; 2 * dim];
        for &[i, j] in &self.pairs {
            for (side, k) in [(0, i as usize), (1, j as usize)] {
                points[side * dim..(side + 1) * dim].copy_from_slice(&x[k * dim..(k + 1) * dim]);
                steps[side * dim..(side + 1) * dim].copy_from_slice(&delta[k * dim..(k + 1) * dim]);
            }
            let radii = (plan.radius[i as usize], plan.radius[j as usize]);
            t = t.min(pair_time(&points, radii, &steps, dim, epsilon));
        }
        fraction(t)
    }
}
