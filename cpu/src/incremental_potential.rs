//! The incremental-potential step (barrier path), f64 golden.
//!
//! ```text
//! x_prev = x;  x~ = x + h v                      (free particles; no forces in x~)
//! F(x)   = Σ_i F_i(x_i),  separable per particle:
//! F_i    = ½ m_i |x_i − x~_i|² − h² (m_i s_i g + f_i)·x_i + h² Σ_o b(d_io(x_i))
//! g_i    = ∇_i F = m_i (x_i − x~_i) − h² (m_i s_i g + f_i) + h² Σ_o b' ∇d
//! H_i    = m_i I + h² Σ_o b'' n nᵀ                (PSD-projected barrier block)
//! residual:  packed_gradient            sqrt(tree_sum_i |g_i|²)     (mass·length)
//!            max_acceleration_residual  max_i |g_i| / (m_i h²)      (length/time²)
//! warm start x = x_prev (feasible; x~ may lie beyond an obstacle)
//! repeat while residual > tolerance, at most max_iterations times:
//!   for every free particle:  Δ = −H_i⁻¹ g_i            (Cholesky)
//!     t = filter fraction (certified, before any evaluation)
//!     while F_i(x_i + tΔ) − F_i(x_i) > c t g_i·Δ:  t /= 2   (Armijo, c = 1e-4;
//!       the change is evaluated in difference form, see ParticleTerms::change)
//!     accept x_i += tΔ (or keep x_i if 60 halvings found no decrease)
//!   no particle moved:  every one at its floor (g = 0, x + Δ == x, or Armijo failed
//!                       with −½ g·Δ below the rounding of F's change) → RoundingFloor
//!                       (accepted); otherwise → refused, NoDescent
//! v = (x − x_prev) / h
//! ```
//! Because F is separable, per-particle Newton is Newton on F. m_i = 1/w_i.
//! The sum of the packed criterion uses [`tree_sum`], a fixed pairwise
//! tree, so a parallel backend can reproduce it exactly.

// Index loops mirror the math (and the WGSL port) line by line.
#![allow(clippy::needless_range_loop)]

use crate::parallel::Workers;
use hyperpbd_core::barrier::{
    BarrierLaw, BarrierObstacles, ParticleBarrier, evaluate_particle_barrier, filter_fraction,
};
use hyperpbd_core::material::solve_factored;
use hyperpbd_core::{
    Convergence, IncrementalPotentialPlan, MinimisationReport, MinimisationStatus, Plan, Refusal,
};

pub use hyperpbd_core::implicit::line_search::{ARMIJO, MAX_HALVINGS};

/// Sum by a fixed pairwise tree: at stride s = 1, 2, 4, …, element i
/// (i a multiple of 2s) adds element i + s. Overwrites `values`.
pub fn tree_sum(values: &mut [f64]) -> f64 {
    tree(values, |a, b| a + b)
}

/// Maximum by the same fixed pairwise tree as [`tree_sum`].
pub fn tree_max(values: &mut [f64]) -> f64 {
    tree(values, f64::max)
}

/// The fixed pairwise tree of [`tree_sum`] with the operation `op`.
fn tree(values: &mut [f64], op: impl Fn(f64, f64) -> f64) -> f64 {
    let n = values.len();
    let mut stride = 1;
    while stride < n {
        let mut i = 0;
        while i + stride < n {
            values[i] = op(values[i], values[i + stride]);
            i += 2 * stride;
        }
        stride *= 2;
    }
    values.first().copied().unwrap_or(0.0)
}

/// Terms per block of [`tree_on`]: a power of two, so that every block's
/// tree is a subtree of the whole one.
const TREE_BLOCK: usize = 4096;

/// [`tree`] over `values` with its blocks of [`TREE_BLOCK`] reduced on
/// `workers`. Strides below the block size pair elements of one block
/// (i and i + s with i a multiple of 2s never straddle a multiple of the
/// block size), so each block reduces to its first element exactly as in
/// the whole tree; the larger strides are then the tree of the blocks'
/// results. Same shape, same rounding, any thread count.
fn tree_on(workers: &Workers, values: &mut [f64], op: fn(f64, f64) -> f64) -> f64 {
    let len = values.len();
    let mut heads = workers.map_spans(len, TREE_BLOCK, 1, [values], |_, [block]| tree(block, op));
    tree(&mut heads, op)
}

/// The per-particle data F_i needs.
#[derive(Debug, Clone, Copy)]
pub struct ParticleTerms<'a> {
    /// Mass m_i.
    pub mass: f64,
    /// Radius r_i.
    pub radius: f64,
    /// x~_i.
    pub prediction: &'a [f64],
    /// m_i s_i g + f_i (constant force of U).
    pub load: &'a [f64],
    /// Substep h.
    pub h: f64,
    /// κ, d^.
    pub law: &'a BarrierLaw,
    /// The obstacles.
    pub obstacles: &'a BarrierObstacles,
}

impl ParticleTerms<'_> {
    /// F_i(y) − F_i(x) for y = x + s, written so that the large terms
    /// cancel analytically instead of in rounding:
    /// m Σ s (x − x~ + s/2) − h² load·s + h² (B(y) − B(x)), with B(x) =
    /// `barrier_at_x` (+∞ where y is infeasible). `barrier` receives the
    /// barrier terms at y.
    pub fn change(
        &self,
        x: &[f64],
        y: &[f64],
        barrier_at_x: f64,
        barrier: &mut ParticleBarrier,
    ) -> f64 {
        evaluate_particle_barrier(self.law, self.obstacles, y, self.radius, barrier);
        let h2 = self.h * self.h;
        let mut inertia = 0.0;
        let mut work = 0.0;
        for a in 0..x.len() {
            let s = y[a] - x[a];
            inertia += s * ((x[a] - self.prediction[a]) + 0.5 * s);
            work += self.load[a] * s;
        }
        self.mass * inertia - h2 * work + h2 * (barrier.energy - barrier_at_x)
    }

    /// g_i at `x` into `gradient`, and the barrier terms into `barrier`.
    pub fn gradient(&self, x: &[f64], barrier: &mut ParticleBarrier, gradient: &mut [f64]) {
        evaluate_particle_barrier(self.law, self.obstacles, x, self.radius, barrier);
        let h2 = self.h * self.h;
        for a in 0..x.len() {
            gradient[a] = self.mass * (x[a] - self.prediction[a]) - h2 * self.load[a]
                + h2 * barrier.gradient[a];
        }
    }

    /// Newton direction Δ = −(m I + h² B)⁻¹ g from the barrier block of the
    /// last evaluation. `matrix` is scratch (dim²). False if the Cholesky
    /// factorisation meets a non-positive pivot (not finite input).
    pub fn newton_direction(
        &self,
        barrier: &ParticleBarrier,
        gradient: &[f64],
        matrix: &mut [f64],
        direction: &mut [f64],
    ) -> bool {
        let n = gradient.len();
        let h2 = self.h * self.h;
        for r in 0..n {
            for c in 0..n {
                let diagonal = if r == c { self.mass } else { 0.0 };
                matrix[r * n + c] = diagonal + h2 * barrier.hessian[r * n + c];
            }
            direction[r] = -gradient[r];
        }
        cholesky_solve(matrix, direction, n)
    }
}

/// Solves A y = b in place (A SPD, row-major, overwritten by its lower
/// Cholesky factor). False on a non-positive or non-finite pivot.
pub fn cholesky_solve(a: &mut [f64], b: &mut [f64], n: usize) -> bool {
    for c in 0..n {
        let mut pivot = a[c * n + c];
        for k in 0..c {
            pivot -= a[c * n + k] * a[c * n + k];
        }
        if !(pivot > 0.0 && pivot.is_finite()) {
            return false;
        }
        let root = pivot.sqrt();
        a[c * n + c] = root;
        for r in c + 1..n {
            let mut value = a[r * n + c];
            for k in 0..c {
                value -= a[r * n + k] * a[c * n + k];
            }
            a[r * n + c] = value / root;
        }
    }
    solve_factored(a, n, b);
    true
}

/// Scratch of the minimisation, reused between steps.
#[derive(Debug, Default)]
pub struct Workspace {
    x_prev: Vec<f64>,
    prediction: Vec<f64>,
    load: Vec<f64>,
    gradient: Vec<f64>,
    terms: Vec<f64>,
}

/// Particles per chunk of the barrier path (a Newton step and its line
/// search each).
pub const PARTICLE_GRAIN: usize = 64;

/// One minimisation (one substep). On `Refused` the caller restores the
/// state; otherwise `x` and `v` hold the accepted iterate and velocity.
/// Particles are independent (F is separable); they run in chunks on
/// `workers`, and whatever is reported is the first particle in index
/// order, as in a serial sweep.
pub(crate) fn minimise(
    workers: &Workers,
    plan: &Plan,
    ip: &IncrementalPotentialPlan,
    x: &mut [f64],
    v: &mut [f64],
    force: &[f64],
    ws: &mut Workspace,
) -> MinimisationReport {
    let n = plan.dim;
    let h = plan.h;
    let count = plan.particle_count();
    let free = |i: usize| plan.inverse_mass[i] > 0.0;
    ws.x_prev.clear();
    ws.x_prev.extend_from_slice(x);
    ws.prediction.clear();
    ws.load.clear();
    for i in 0..count {
        let m = if plan.inverse_mass[i] > 0.0 {
            1.0 / plan.inverse_mass[i]
        } else {
            0.0
        };
        for a in 0..n {
            ws.prediction.push(x[i * n + a] + h * v[i * n + a]);
            ws.load
                .push(m * plan.gravity_scale[i] * plan.gravity[a] + force[i * n + a]);
        }
    }
    let mut report = MinimisationReport::before_first_iteration(ip.convergence);
    let start = &*x;
    let infeasible = workers.try_for_chunks(count, PARTICLE_GRAIN, |r| {
        match r
            .filter(|&i| free(i))
            .find(|&i| infeasible_start(plan, ip, start, i).is_some())
        {
            Some(i) => Err(i),
            None => Ok(()),
        }
    });
    if let Err(particle) = infeasible
        && let Some((obstacle, distance)) = infeasible_start(plan, ip, start, particle)
    {
        report.status = MinimisationStatus::Refused(Refusal::InfeasibleStart {
            particle,
            obstacle: ip.obstacles.source(obstacle) as usize,
            distance,
        });
        return report;
    }
    let Workspace {
        x_prev,
        prediction,
        load,
        gradient,
        terms,
    } = ws;
    let particle = |i: usize| ParticleTerms {
        mass: 1.0 / plan.inverse_mass[i],
        radius: plan.radius[i],
        prediction: &prediction[i * n..(i + 1) * n],
        load: &load[i * n..(i + 1) * n],
        h,
        law: &ip.law,
        obstacles: &ip.obstacles,
    };
    gradient.clear();
    gradient.resize(count * n, 0.0);
    let mut iteration = 0;
    loop {
        // Gradient of every free particle, then the residual.
        let current = &*x;
        let gradients = workers.try_for_spans(count, PARTICLE_GRAIN, n, [gradient], |r, [g]| {
            let mut barrier = ParticleBarrier::new(n);
            for i in r.clone().filter(|&i| free(i)) {
                let gi = &mut g[(i - r.start) * n..(i - r.start + 1) * n];
                particle(i).gradient(&current[i * n..(i + 1) * n], &mut barrier, gi);
                if gi.iter().any(|g| !g.is_finite()) {
                    return Err(i);
                }
            }
            Ok(())
        });
        if let Err(i) = gradients {
            report.status = MinimisationStatus::Refused(Refusal::NonFinite { particle: i });
            return report;
        }
        let residual = residual_on(workers, plan, gradient, ip.convergence, terms);
        if report.record_residual(residual, iteration, ip.max_iterations) {
            break;
        }
        iteration += 1;
        let gradient = &*gradient;
        let sweeps = workers.map_spans(count, PARTICLE_GRAIN, n, [&mut *x], |r, [xs]| {
            let mut barrier = ParticleBarrier::new(n);
            let (mut matrix, mut direction, mut trial) =
                (vec![0.0; n * n], vec![0.0; n], vec![0.0; n]);
            let mut sweep = Sweep::default();
            for i in r.clone().filter(|&i| free(i)) {
                let xi = &mut xs[(i - r.start) * n..(i - r.start + 1) * n];
                let gi = &gradient[i * n..(i + 1) * n];
                match line_search(
                    &particle(i),
                    xi,
                    gi,
                    &mut barrier,
                    &mut matrix,
                    &mut direction,
                    &mut trial,
                ) {
                    LineSearch::Moved => sweep.moved = true,
                    LineSearch::AtFloor => {}
                    LineSearch::Stalled => sweep.stalled = true,
                    LineSearch::NonFinite => {
                        sweep.non_finite = Some(i);
                        break;
                    }
                }
            }
            sweep
        });
        let sweep = sweeps.into_iter().fold(Sweep::default(), Sweep::then);
        if let Some(i) = sweep.non_finite {
            report.status = MinimisationStatus::Refused(Refusal::NonFinite { particle: i });
            return report;
        }
        if !sweep.moved && !sweep.stalled {
            report.iterations = iteration;
            report.status = MinimisationStatus::RoundingFloor;
            break;
        }
        if !sweep.moved {
            report.iterations = iteration;
            report.status = MinimisationStatus::Refused(Refusal::NoDescent { residual });
            return report;
        }
    }
    let (x, x_prev) = (&*x, &*x_prev);
    let _ = workers.try_for_spans(count, PARTICLE_GRAIN, n, [v], |r, [v]| {
        for i in r.clone().filter(|&i| free(i)) {
            for a in 0..n {
                let k = i * n + a;
                v[k - r.start * n] = (x[k] - x_prev[k]) / h;
            }
        }
        Ok(())
    });
    report
}

/// The first obstacle (index into the plan's obstacles) particle `i`
/// touches or penetrates at `x` (distance ≤ 0 or NaN), with its distance.
fn infeasible_start(
    plan: &Plan,
    ip: &IncrementalPotentialPlan,
    x: &[f64],
    i: usize,
) -> Option<(usize, f64)> {
    let n = plan.dim;
    ip.obstacles
        .first_infeasible(&x[i * n..(i + 1) * n], plan.radius[i])
}

/// What the line searches of a run of particles did.
#[derive(Debug, Default, Clone, Copy)]
struct Sweep {
    moved: bool,
    stalled: bool,
    /// The first particle whose direction or slope was not finite (the
    /// run stopped there).
    non_finite: Option<usize>,
}

impl Sweep {
    /// This run followed by `next` (runs in index order).
    fn then(self, next: Sweep) -> Sweep {
        Sweep {
            moved: self.moved || next.moved,
            stalled: self.stalled || next.stalled,
            non_finite: self.non_finite.or(next.non_finite),
        }
    }
}

/// What one particle's line search did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineSearch {
    /// A trial was accepted; `x` moved.
    Moved,
    /// g = 0, the full Newton step x + Δ rounds back to x, or no trial
    /// decreased F_i and the full step's expected decrease is below the
    /// rounding of F's change ([`change_resolution`]): the particle is at
    /// its minimiser to the working precision.
    AtFloor,
    /// No trial decreased F_i although x + Δ ≠ x: `x` is unchanged.
    Stalled,
    /// The Newton direction or slope was not finite.
    NonFinite,
}

/// One filtered, backtracked Newton step of one particle.
#[allow(clippy::too_many_arguments)]
pub fn line_search(
    particle: &ParticleTerms<'_>,
    x: &mut [f64],
    gradient: &[f64],
    barrier: &mut ParticleBarrier,
    matrix: &mut [f64],
    direction: &mut [f64],
    trial: &mut [f64],
) -> LineSearch {
    let n = x.len();
    evaluate_particle_barrier(
        particle.law,
        particle.obstacles,
        x,
        particle.radius,
        barrier,
    );
    let barrier_at_x = barrier.energy;
    if gradient.iter().all(|&g| g == 0.0) {
        return LineSearch::AtFloor;
    }
    if !particle.newton_direction(barrier, gradient, matrix, direction) {
        return LineSearch::NonFinite;
    }
    if (0..n).all(|a| x[a] + direction[a] == x[a]) {
        return LineSearch::AtFloor;
    }
    let slope: f64 = (0..n).map(|a| gradient[a] * direction[a]).sum();
    if !slope.is_finite() {
        return LineSearch::NonFinite;
    }
    let resolution = change_resolution(particle, x, direction, barrier, f64::EPSILON);
    let mut t = filter_fraction(particle.obstacles, x, particle.radius, direction);
    for _ in 0..=MAX_HALVINGS {
        for a in 0..n {
            trial[a] = x[a] + t * direction[a];
        }
        let change = particle.change(x, trial, barrier_at_x, barrier);
        if change <= ARMIJO * t * slope && trial != x {
            x.copy_from_slice(trial);
            return LineSearch::Moved;
        }
        t *= 0.5;
    }
    // No trial decreased F_i: at the rounding floor when even the full
    // step's expected decrease is below the resolution of the change.
    if -0.5 * slope <= resolution {
        LineSearch::AtFloor
    } else {
        LineSearch::Stalled
    }
}

/// Rounding bound of [`ParticleTerms::change`] over the full step Δ at
/// machine epsilon ε, from the barrier terms at x:
///
/// ```text
/// (N + 4) ε/2 (m Σ |Δ|(|x − x~| + |Δ|) + h² Σ |load Δ| + 2 h² |B(x)|)
///   + 2 h² Σ_o |b'_o| δd,     δd = (N + 4) ε (‖x‖∞ + G + r)
/// ```
/// (G: the obstacles' coordinate scale; δd the rounding of a computed
/// distance, which an energy difference inherits at rate |b'|.) When the
/// full step's expected decrease −½ g·Δ is below it, no line search can
/// certify a decrease: the particle is at its rounding floor.
pub fn change_resolution(
    particle: &ParticleTerms<'_>,
    x: &[f64],
    direction: &[f64],
    barrier_at_x: &ParticleBarrier,
    epsilon: f64,
) -> f64 {
    let n = x.len();
    let h2 = particle.h * particle.h;
    let mut inertia = 0.0;
    let mut work = 0.0;
    let mut largest: f64 = 0.0;
    for a in 0..n {
        let s = direction[a].abs();
        inertia += s * ((x[a] - particle.prediction[a]).abs() + s);
        work += (particle.load[a] * direction[a]).abs();
        largest = largest.max(x[a].abs());
    }
    let terms = n as f64 + 4.0;
    let distance_error = terms * epsilon * (largest + particle.obstacles.scale + particle.radius);
    terms
        * 0.5
        * epsilon
        * (particle.mass * inertia + h2 * work + 2.0 * h2 * barrier_at_x.energy.abs())
        + 2.0 * h2 * barrier_at_x.force_sum * distance_error
}

/// The authored residual over the free particles. The terms run over all
/// particles in index order, 0 for fixed ones (they hold no coordinate and
/// their gradient is identically zero), so the packed sum's tree has the
/// same shape on every backend.
pub fn residual(
    plan: &Plan,
    gradient: &[f64],
    criterion: Convergence,
    terms: &mut Vec<f64>,
) -> f64 {
    residual_on(&Workers::serial(), plan, gradient, criterion, terms)
}

/// [`residual`] on `workers`: terms per particle in chunks, the tree in
/// blocks ([`tree_on`]).
fn residual_on(
    workers: &Workers,
    plan: &Plan,
    gradient: &[f64],
    criterion: Convergence,
    terms: &mut Vec<f64>,
) -> f64 {
    let n = plan.dim;
    let h2 = plan.h * plan.h;
    let count = plan.particle_count();
    terms.clear();
    terms.resize(count, 0.0);
    let _ = workers.try_for_spans(count, PARTICLE_GRAIN, 1, [terms], |r, [t]| {
        for i in r.clone().filter(|&i| plan.inverse_mass[i] > 0.0) {
            let g = &gradient[i * n..(i + 1) * n];
            let mut squared = 0.0;
            for c in g {
                squared += c * c;
            }
            t[i - r.start] = match criterion {
                Convergence::PackedGradient { .. } => squared,
                Convergence::MaxAccelerationResidual { .. } => {
                    squared.sqrt() * plan.inverse_mass[i] / h2
                }
            };
        }
        Ok(())
    });
    match criterion {
        Convergence::PackedGradient { .. } => tree_on(workers, terms, |a, b| a + b).sqrt(),
        Convergence::MaxAccelerationResidual { .. } => tree_on(workers, terms, f64::max),
    }
}
