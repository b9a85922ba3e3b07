//! Contact forces out: what a step reports when asked
//! ([`Backend::request_contact_forces`](crate::Backend::request_contact_forces)).
//!
//! ```text
//! particle i   F_i = (Σ over the step's substeps of the contact impulse J_i,s) / dt
//!              J = every obstacle contact and particle–particle contact, normal and friction
//! obstacle o   F_o = Σ_i (obstacle o's part of J_i,s) / dt
//!              obstacle o's total contact force on the particles (issue 31):
//!              a mass m at rest on a plane gives F_o = F_i = −m g (up; the
//!              particles press on the obstacle with −F_o)
//! XPBD         hyperplane contact, per substep:  J = ∇C λ / h = n λ / h   (λ the substep's
//!              accumulated multiplier: x moved by w n λ, so m Δx / h = n λ / h)
//!              static friction (position solve) J += m Δx_t / h (the tangential move it made)
//!              dynamic friction (velocity)      J += m Δv
//!              particle contact (Jacobi moves)  J_i += m_i Δx_i / h
//! barrier      per substep at the accepted iterate x:  J = −∇E(x) h, E the barriers'
//!              and the lagged friction's energy (U's contact part; F = ½‖x − x~‖²_M + h² U)
//! ```
//! Where only obstacle contacts act, Σ_i F_i = Σ_o F_o (every impulse is
//! counted once on each side).
//!
//! ```text
//! power        P_o = Σ_substeps Σ_i J_oi · u_o(p_i) / dt      (W; the work over the step is P_o dt)
//!              u_o(p) = D_o(p) / h: the velocity over the substep of obstacle o's material
//!              point under the particle's start position p (motion.rs's carry, the point
//!              friction measures slip against); 0 for an obstacle without motion
//! ```
//! The power is the energy a moving obstacle puts into the particles:
//! over a run, Σ_o ∫ P_o dt = ΔE + D with E the particles' kinetic plus
//! gravitational energy and D ≥ 0 what friction, inelastic contact and
//! damping dissipate (tests/cpu/drum_energy.rs measures both sides).

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use crate::barrier::{BarrierLaw, BarrierObstacles, candidate_box, distance_margin};

/// The contact forces of one step (each the step's impulse over dt).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ContactForces {
    /// Dimension N.
    pub dim: usize,
    /// Obstacle o's force on the particles at `o·N..(o + 1)·N`, one per
    /// authored obstacle (the particles push on it with the opposite).
    pub obstacles: Vec<f64>,
    /// Particle i's total contact force at `i·N..(i + 1)·N`.
    pub particles: Vec<f64>,
    /// Obstacle o's mean power into the particles over the step (module
    /// docs), one per authored obstacle; 0 for an obstacle that does not move.
    pub obstacle_power: Vec<f64>,
}

impl ContactForces {
    /// Zeros for `obstacles` obstacles and `particles` particles.
    pub fn zeros(dim: usize, obstacles: usize, particles: usize) -> Self {
        ContactForces {
            dim,
            obstacles: vec![0.0; obstacles * dim],
            particles: vec![0.0; particles * dim],
            obstacle_power: vec![0.0; obstacles],
        }
    }

    /// Number of obstacles.
    pub fn obstacle_count(&self) -> usize {
        self.obstacles.len().checked_div(self.dim).unwrap_or(0)
    }

    /// Obstacle o's force.
    pub fn obstacle(&self, o: usize) -> &[f64] {
        &self.obstacles[o * self.dim..(o + 1) * self.dim]
    }

    /// Particle i's force.
    pub fn particle(&self, i: usize) -> &[f64] {
        &self.particles[i * self.dim..(i + 1) * self.dim]
    }

    /// Adds impulse `j` of obstacle o on particle i to both.
    pub fn add_obstacle_impulse(&mut self, o: usize, i: usize, j: &[f64]) {
        let n = self.dim;
        for a in 0..n {
            self.particles[i * n + a] += j[a];
            self.obstacles[o * n + a] += j[a];
        }
    }

    /// Adds the work `w` = J·u of an impulse of obstacle o (module docs).
    pub fn add_obstacle_work(&mut self, o: usize, w: f64) {
        self.obstacle_power[o] += w;
    }

    /// Adds impulse `j` to particle i alone (a particle–particle contact).
    pub fn add_particle_impulse(&mut self, i: usize, j: &[f64]) {
        let n = self.dim;
        for a in 0..n {
            self.particles[i * n + a] += j[a];
        }
    }

    /// Sets every value to 0.
    pub fn clear(&mut self) {
        self.obstacles.fill(0.0);
        self.particles.fill(0.0);
        self.obstacle_power.fill(0.0);
    }

    /// Divides every accumulated impulse by `dt` (the step's end).
    pub fn per_time(&mut self, dt: f64) {
        let all = self.obstacles.iter_mut().chain(self.particles.iter_mut());
        for c in all.chain(self.obstacle_power.iter_mut()) {
            *c /= dt;
        }
    }
}

/// Every active barrier of a particle at `x` (radius `radius`): `each`
/// receives the authored obstacle index and the force −b'(d) ∇d it puts on
/// the particle, in the order `evaluate_particle_barrier` sums them.
pub fn barrier_forces(
    law: &BarrierLaw,
    obstacles: &BarrierObstacles,
    x: &[f64],
    radius: f64,
    mut each: impl FnMut(usize, &[f64]),
) {
    let dim = x.len();
    let mut n = [0.0f64; crate::MAX_DIM];
    let mut force = [0.0f64; crate::MAX_DIM];
    let (mut lo, mut hi) = ([0.0f64; crate::MAX_DIM], [0.0f64; crate::MAX_DIM]);
    let (lo, hi) = (&mut lo[..dim], &mut hi[..dim]);
    let margin = distance_margin(dim, f64::EPSILON);
    candidate_box(
        x,
        radius,
        law.activation_distance,
        obstacles.scale,
        margin,
        lo,
        hi,
    );
    for o in obstacles.near(lo, hi) {
        let d = obstacles.distance(o, x, radius, &mut n[..dim]);
        if d >= law.activation_distance {
            continue;
        }
        let (_, b1, _) = law.evaluate(d);
        for a in 0..dim {
            force[a] = -b1 * n[a];
        }
        each(obstacles.source(o) as usize, &force[..dim]);
    }
}
