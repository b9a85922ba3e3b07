//! The per-particle terms of the coupled implicit step: inertia, the
//! external load, the obstacle barriers and lagged obstacle friction, and
//! the per-particle gathers of gradient, product and diagonal.
//!
//! ```text
//! F_i(x_i)  = ½ m_i |x_i − x~_i|² − h² load_i·x_i + h² (Σ_o b(d_io) + Σ_lags μλ f₀(|P w_i|))
//!             (lags: planes and simplices with μ > 0, P = I − n nᵀ with the lag's n at x^t)
//! g_i       = m_i (x_i − x~_i) − h² load_i + h² (Σ_o b' n + Σ_lags ∇D) + h² Σ_{slots of i} ∇E_e
//! B_i       = Σ_o b'' n nᵀ + Σ_lags K_friction            (N × N, PSD)
//! (H p)_i   = m_i p_i + h² (B_i p_i + Σ_{slots of i} (K_e⁺ p_e))
//! diag_i    = m_i + h² (diag B_i + Σ_{slots of i} diag K_e⁺)
//! ```
//! Fixed particles hold no coordinate: their rows are left 0 and their
//! preconditioner entries are 0 (CG freezes them).

// Index loops mirror the math line by line.
#![allow(clippy::needless_range_loop)]

use super::elements::Elements;
use crate::incremental_potential::PARTICLE_GRAIN;
use crate::parallel::Workers;
use hyperpbd_core::barrier::{ParticleBarrier, evaluate_particle_barrier};
use hyperpbd_core::implicit::obstacle_friction;
use hyperpbd_core::{IncrementalPotentialPlan, Plan};

/// A frozen friction lag of one particle against obstacle slot
/// `obstacle` (a plane or a simplex of `BarrierObstacles`, at x^t); its
/// normal is [`Particles::lag_normal`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObstacleLag {
    /// The particle.
    pub particle: usize,
    /// The obstacle slot (planes first, then simplices).
    pub obstacle: usize,
    /// F_max = μ λ.
    pub force_limit: f64,
}

/// The per-particle data of one step.
#[derive(Debug, Default)]
pub struct Particles {
    /// m_i (0 for fixed particles).
    pub mass: Vec<f64>,
    /// x^t.
    pub start: Vec<f64>,
    /// x~ = x^t + h v.
    pub prediction: Vec<f64>,
    /// m_i s_i g + f_i.
    pub load: Vec<f64>,
    /// Obstacle lags, sorted by particle (then obstacle slot, in the order
    /// `BarrierObstacles::near` visits them at x^t).
    pub lags: Vec<ObstacleLag>,
    /// The unit normal of each lag at x^t (N per lag): a plane's normal,
    /// a simplex's (x^t − q)/|x^t − q|.
    pub lag_normals: Vec<f64>,
    /// Particle i's lags are `lags[lag_offsets[i]..lag_offsets[i + 1]]`.
    pub lag_offsets: Vec<usize>,
    /// Per particle at the last gradient: [B_i (N²), Σ_o b + Σ_lags D,
    /// Σ_o |b'_o| δd_o] (see [`Particles::stride`]).
    pub terms: Vec<f64>,
}

/// What the per-particle passes read.
#[derive(Debug, Clone, Copy)]
pub struct Context<'a> {
    /// The plan.
    pub plan: &'a Plan,
    /// Barrier law and obstacles.
    pub ip: &'a IncrementalPotentialPlan,
    /// ε = ε_v h.
    pub slip_length: f64,
}

impl Particles {
    /// The normal of lag `l` (dimension `dim`).
    pub fn lag_normal(&self, l: usize, dim: usize) -> &[f64] {
        &self.lag_normals[l * dim..(l + 1) * dim]
    }

    /// Values per particle of [`Particles::terms`].
    pub fn stride(dim: usize) -> usize {
        dim * dim + 2
    }

    /// Obstacle barrier and friction of particle i at `xi`: their energy;
    /// with `derivatives`, their gradient into the first N values and their
    /// PSD block into the next N².
    fn obstacle_terms(
        &self,
        c: &Context<'_>,
        i: usize,
        xi: &[f64],
        barrier: &mut ParticleBarrier,
        derivatives: Option<(&mut [f64], &mut [f64])>,
    ) -> f64 {
        let dim = c.plan.dim;
        evaluate_particle_barrier(&c.ip.law, &c.ip.obstacles, xi, c.plan.radius[i], barrier);
        let mut energy = barrier.energy;
        let mut friction_gradient = [0.0f64; hyperpbd_core::MAX_DIM];
        let mut slip = [0.0f64; hyperpbd_core::MAX_DIM];
        let mut derivatives = derivatives;
        let mut lag_block = Vec::new();
        if let Some((g, b)) = derivatives.as_mut() {
            g.copy_from_slice(&barrier.gradient);
            b.copy_from_slice(&barrier.hessian);
            lag_block.resize(dim * dim, 0.0);
        }
        for l in self.lag_offsets[i]..self.lag_offsets[i + 1] {
            let (lag, normal) = (&self.lags[l], self.lag_normal(l, dim));
            let term = obstacle_friction(
                normal,
                lag.force_limit,
                c.slip_length,
                xi,
                &self.start[i * dim..(i + 1) * dim],
                &mut friction_gradient[..dim],
                &mut slip[..dim],
            );
            energy += term.energy;
            if let Some((g, b)) = derivatives.as_mut() {
                for a in 0..dim {
                    g[a] += friction_gradient[a];
                }
                term.curvature.block(normal, &slip[..dim], &mut lag_block);
                for k in 0..dim * dim {
                    b[k] += lag_block[k];
                }
            }
        }
        energy
    }

    /// g at `x` (gathering the element gradients of `elements`' records)
    /// into `gradient`, and [`Particles::terms`]. The first free particle
    /// whose gradient or obstacle energy is not finite.
    pub fn gradient(
        &mut self,
        workers: &Workers,
        c: &Context<'_>,
        elements: &Elements,
        x: &[f64],
        gradient: &mut [f64],
    ) -> Result<(), usize> {
        let (dim, h2, count) = (c.plan.dim, c.plan.h * c.plan.h, c.plan.particle_count());
        let stride = Self::stride(dim);
        let mut terms = std::mem::take(&mut self.terms);
        terms.clear();
        terms.resize(count * stride, 0.0);
        let this = &*self;
        let scale = c.ip.obstacles.scale;
        let gamma = (dim as f64 + 4.0) * f64::EPSILON;
        // One pass per particle writes its gradient (stride N) and its terms
        // (stride N² + 2): two span sets over the same chunks.
        let chunks = workers.map_spans(count, PARTICLE_GRAIN, dim, [gradient], |r, [g]| {
            let mut barrier = ParticleBarrier::new(dim);
            let mut own = vec![0.0; dim];
            let mut local = vec![0.0; r.len() * stride];
            for i in r.clone() {
                let gi = &mut g[(i - r.start) * dim..(i - r.start + 1) * dim];
                gi.fill(0.0);
                if this.mass[i] == 0.0 {
                    continue;
                }
                let ti = &mut local[(i - r.start) * stride..(i - r.start + 1) * stride];
                let xi = &x[i * dim..(i + 1) * dim];
                let (block, tail) = ti.split_at_mut(dim * dim);
                tail[0] = this.obstacle_terms(c, i, xi, &mut barrier, Some((&mut own, block)));
                let largest = xi.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                tail[1] = barrier.force_sum * gamma * (largest + scale + c.plan.radius[i]);
                elements.gather(i, dim, true, &mut own);
                for a in 0..dim {
                    gi[a] = this.mass[i] * (xi[a] - this.prediction[i * dim + a])
                        - h2 * this.load[i * dim + a]
                        + h2 * own[a];
                }
                if gi.iter().any(|v| !v.is_finite()) || !tail[0].is_finite() {
                    return (local, Err(i));
                }
            }
            (local, Ok(()))
        });
        let mut result = Ok(());
        let mut at = 0;
        for (local, chunk) in chunks {
            terms[at..at + local.len()].copy_from_slice(&local);
            at += local.len();
            result = result.and(chunk);
        }
        self.terms = terms;
        result
    }

    /// out = (M + h² Σ K⁺) p over the free particles (fixed rows 0), from
    /// the blocks of the last gradient and the slots `elements` filled for p.
    pub fn product(
        &self,
        workers: &Workers,
        c: &Context<'_>,
        elements: &Elements,
        p: &[f64],
        out: &mut [f64],
    ) {
        let dim = c.plan.dim;
        let stride = Self::stride(dim);
        // own_i = B_i p_i, the particle's own block times its p.
        let own = |i: usize, own: &mut [f64]| {
            let block = &self.terms[i * stride..i * stride + dim * dim];
            let pi = &p[i * dim..(i + 1) * dim];
            for a in 0..dim {
                let mut s = 0.0;
                for b in 0..dim {
                    s += block[a * dim + b] * pi[b];
                }
                own[a] = s;
            }
        };
        let combine = |i: usize, a: usize, h2_sum: f64| self.mass[i] * p[i * dim + a] + h2_sum;
        self.per_free_particle(workers, c, elements, out, own, combine);
    }

    /// P⁻¹ = 1/(m + h² diag) per free coordinate (0 for fixed particles)
    /// into `out`, from the slots `elements` filled with the diagonals.
    pub fn inverse_diagonal(
        &self,
        workers: &Workers,
        c: &Context<'_>,
        elements: &Elements,
        out: &mut [f64],
    ) {
        let dim = c.plan.dim;
        let stride = Self::stride(dim);
        // own_i = diag(B_i), the particle's own block's diagonal.
        let own = |i: usize, own: &mut [f64]| {
            for a in 0..dim {
                own[a] = self.terms[i * stride + a * dim + a];
            }
        };
        let combine = |i: usize, _: usize, h2_sum: f64| 1.0 / (self.mass[i] + h2_sum);
        self.per_free_particle(workers, c, elements, out, own, combine);
    }

    /// out_ia = combine(i, a, h² s_a) per free particle i (fixed rows 0),
    /// where s = the particle's own term (written by `own`) plus its
    /// elements' slots.
    fn per_free_particle(
        &self,
        workers: &Workers,
        c: &Context<'_>,
        elements: &Elements,
        out: &mut [f64],
        own: impl Fn(usize, &mut [f64]) + Sync,
        combine: impl Fn(usize, usize, f64) -> f64 + Sync,
    ) {
        let (dim, h2, count) = (c.plan.dim, c.plan.h * c.plan.h, c.plan.particle_count());
        let _ = workers.try_for_spans(count, PARTICLE_GRAIN, dim, [out], |r, [o]| {
            let mut sum = vec![0.0; dim];
            for i in r.clone() {
                let oi = &mut o[(i - r.start) * dim..(i - r.start + 1) * dim];
                oi.fill(0.0);
                if self.mass[i] == 0.0 {
                    continue;
                }
                own(i, &mut sum);
                elements.gather(i, dim, false, &mut sum);
                for a in 0..dim {
                    oi[a] = combine(i, a, h2 * sum[a]);
                }
            }
            Ok(())
        });
    }

    /// F_i(y_i) − F_i(x_i) per particle into `changes`, in difference form:
    /// m Σ s (x − x~ + s/2) − h² load·s + h² (E_o(y) − E_o(x)), s = y − x.
    pub fn changes(
        &self,
        workers: &Workers,
        c: &Context<'_>,
        x: &[f64],
        y: &[f64],
        changes: &mut Vec<f64>,
    ) {
        let (dim, h2, count) = (c.plan.dim, c.plan.h * c.plan.h, c.plan.particle_count());
        let stride = Self::stride(dim);
        changes.clear();
        changes.resize(count, 0.0);
        let _ = workers.try_for_spans(count, PARTICLE_GRAIN, 1, [changes], |r, [out]| {
            let mut barrier = ParticleBarrier::new(dim);
            for i in r.clone().filter(|&i| self.mass[i] > 0.0) {
                let (xi, yi) = (&x[i * dim..(i + 1) * dim], &y[i * dim..(i + 1) * dim]);
                let obstacles = self.obstacle_terms(c, i, yi, &mut barrier, None);
                let (mut inertia, mut work) = (0.0, 0.0);
                for a in 0..dim {
                    let s = yi[a] - xi[a];
                    inertia += s * ((xi[a] - self.prediction[i * dim + a]) + 0.5 * s);
                    work += self.load[i * dim + a] * s;
                }
                out[i - r.start] = self.mass[i] * inertia - h2 * work
                    + h2 * (obstacles - self.terms[i * stride + dim * dim]);
            }
            Ok(())
        });
    }
}
