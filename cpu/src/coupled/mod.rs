//! The coupled implicit step (docs/implicit.md §7), f64 golden: one
//! minimisation of F(x) = ½‖x − x~‖²_M + h² U(x) over every particle at
//! once, with springs, ball–ball barriers and lagged friction coupling them.
//!
//! ```text
//! 1  x^t = x, x~ = x^t + h v;  refuse d ≤ 0 (obstacle: InfeasibleStart, pair: OverlappingStart)
//! 2  lags at x^t: planes with μ > 0 and pairs (μ_c > 0) with 0 < d < d^: n, F_max = μ (−b'(d))
//! 3  x_0 = x^t (previous) | x^t + τ (x~ − x^t), τ the certified fraction (inertial)
//! 4  P_0: broadphase over the boxes swept along the segment that produced x_0 (radius + d^/2)
//!    for k = 0, 1, …
//! 5    g = ∇F(x_k) over P_k; residual (authored criterion, block tree) ≤ tol → Converged;
//!      k = max_iterations → BudgetExhausted
//! 6    P⁻¹ = 1/(m + h² diag Σ K⁺)
//! 7    PCG on (M + h² Σ K⁺) Δ = −g until ‖r‖₂ ≤ min(¼, √(r_k/r_0)) r_k in the criterion's
//!      units (see cg_tolerance), at most cg_iterations;
//!      breakdown at its first iteration → Refused(CurvatureBreakdown)
//! 8    P_{k+1}: broadphase over the boxes swept along [x_k, x_k + Δ]
//! 9    t = certified fraction over every obstacle of every free particle and every pair of P_{k+1}
//! 10   Armijo (c = 1e-4, difference form, t /= 2 at most 60 times)
//! 11   no trial accepted: −½ g·Δ ≤ resolution → RoundingFloor (kept), else Refused(NoDescent)
//! 12 v = (x − x^t)/h
//! ```
//! Every sum runs on the implicit path's block tree (core's reduction.rs)
//! over per-particle or per-element terms in index order; elements and
//! particles are evaluated in chunks on the backend's threads, each
//! writing only its own values. The bytes do not depend on the thread
//! count.

// Index loops mirror the math line by line.
#![allow(clippy::needless_range_loop)]

mod contacts;
mod elements;
mod gradient_at;
mod particles;
mod setup;
#[cfg(test)]
mod tests;

use crate::parallel::Workers;
pub(crate) use contacts::contact_impulses;
use elements::{Elements, Terms};
pub use gradient_at::coupled_gradient;
use hyperpbd_core::IncrementalPotentialPlan;
use hyperpbd_core::implicit::line_search::{after_failed_search, armijo, before_search};
use hyperpbd_core::implicit::resolution::{change_resolution, particle_sums};
use hyperpbd_core::implicit::{
    CoupledPlan, PcgSettings, PcgWorkspace, block_tree_max, block_tree_sum, newton_cg_tolerance,
    pcg, tree_dot,
};
use hyperpbd_core::{Convergence, MinimisationReport, MinimisationStatus, Plan, Refusal};
use particles::{Context, Particles};
use std::convert::Infallible;

/// Scratch of the coupled step, reused between steps.
#[derive(Debug, Default)]
pub struct Workspace {
    particles: Particles,
    elements: Elements,
    setup: setup::Setup,
    gradient: Vec<f64>,
    direction: Vec<f64>,
    inverse_diagonal: Vec<f64>,
    trial: Vec<f64>,
    terms: Vec<f64>,
    scratch: Vec<f64>,
    changes: Vec<f64>,
    pcg: PcgWorkspace,
}

/// One coupled minimisation (one substep). On `Refused` the caller
/// restores the state; otherwise `x` and `v` hold the accepted iterate and
/// its velocity.
#[allow(clippy::too_many_arguments)]
pub(crate) fn minimise(
    workers: &Workers,
    plan: &Plan,
    ip: &IncrementalPotentialPlan,
    coupled: &CoupledPlan,
    x: &mut [f64],
    v: &mut [f64],
    force: &[f64],
    ws: &mut Workspace,
) -> MinimisationReport {
    let (dim, h, count) = (plan.dim, plan.h, plan.particle_count());
    let mut report = MinimisationReport::before_first_iteration(ip.convergence);
    let Workspace {
        particles,
        elements,
        setup,
        gradient,
        direction,
        inverse_diagonal,
        trial,
        terms,
        scratch,
        changes,
        pcg: pcg_workspace,
    } = ws;
    setup::start(plan, x, v, force, particles);
    let slip_length = coupled.slip_velocity * h;
    // 1–2: feasibility and the friction lags at x^t.
    if let Err(refusal) = setup.lags(workers, plan, ip, coupled, particles) {
        report.status = MinimisationStatus::Refused(refusal);
        return report;
    }
    let context = Context {
        plan,
        ip,
        slip_length,
    };
    // 3–4: the warm start and its pair set.
    let pair_lags = std::mem::take(&mut setup.pair_lags);
    setup.warm_start(workers, plan, ip, coupled, particles, x);
    elements.rebuild(plan, &setup.pairs, &pair_lags);
    direction.resize(count * dim, 0.0);
    inverse_diagonal.resize(count * dim, 0.0);
    gradient.resize(count * dim, 0.0);
    trial.resize(count * dim, 0.0);
    let start = particles.start.clone();
    let terms_at = Terms {
        plan,
        law: &ip.law,
        start: &start,
        lags: &pair_lags,
        slip_length,
    };
    let mut iteration = 0;
    let mut first_residual = None;
    loop {
        // 5: gradient and residual.
        if let Err(e) = elements.evaluate(workers, &terms_at, x) {
            if iteration == 0 && x[..] != start[..] {
                // 3: a warm start the law refuses (F = +∞ there) falls back to x^t,
                // which P_0 (swept from x^t) covers.
                x.copy_from_slice(&start);
                continue;
            }
            report.status = MinimisationStatus::Refused(element_refusal(plan, elements, e, x));
            break;
        }
        if let Err(particle) = particles.gradient(workers, &context, elements, x, gradient) {
            report.status = MinimisationStatus::Refused(Refusal::NonFinite { particle });
            break;
        }
        let residual = residual(plan, particles, gradient, ip.convergence, terms, scratch);
        let r0 = *first_residual.get_or_insert(residual);
        if report.record_residual(residual, iteration, ip.max_iterations) {
            break;
        }
        iteration += 1;
        // 6–7: the Newton direction by preconditioned CG.
        if let Err(e) = elements.curvatures(workers, &terms_at, x) {
            report.status = MinimisationStatus::Refused(element_refusal(plan, elements, e, x));
            break;
        }
        elements.fill_slots(workers, &terms_at, &[], true);
        particles.inverse_diagonal(workers, &context, elements, inverse_diagonal);
        for c in 0..count * dim {
            trial[c] = -gradient[c];
        }
        let settings = PcgSettings {
            max_iterations: coupled.cg_iterations,
            relative_tolerance: 0.0,
            absolute_tolerance: newton_cg_tolerance(
                ip.convergence,
                residual,
                r0,
                &particles.mass,
                plan.h,
            ),
        };
        let cg = pcg(
            |p, out| {
                elements.fill_slots(workers, &terms_at, p, false);
                particles.product(workers, &context, elements, p, out);
            },
            inverse_diagonal,
            trial,
            dim,
            settings,
            direction,
            pcg_workspace,
        );
        report.cg_iterations.push(cg.iterations);
        if let Some(refusal) = cg.breakdown(iteration) {
            report.iterations = iteration;
            report.status = MinimisationStatus::Refused(refusal);
            break;
        }
        // 8–9: the pairs any trial can reach, and the certified fraction.
        for c in 0..count * dim {
            trial[c] = x[c] + direction[c];
        }
        setup.sweep_pairs(workers, plan, ip, x, trial);
        elements.rebuild(plan, &setup.pairs, &pair_lags);
        let fraction = setup.filter(workers, plan, ip, particles, x, direction);
        // 10–11: Armijo on the difference form of F's change.
        if let Err(e) = elements.evaluate(workers, &terms_at, x) {
            report.iterations = iteration;
            report.status = MinimisationStatus::Refused(element_refusal(plan, elements, e, x));
            break;
        }
        let slope = tree_dot(gradient, direction, dim, terms, scratch);
        let moved = (0..count * dim).any(|c| x[c] + direction[c] != x[c]);
        if let Some(status) = before_search(moved, slope) {
            report.iterations = iteration;
            report.status = status;
            break;
        }
        let Ok(accepted) = armijo::<Infallible>(fraction, slope, |t| {
            for c in 0..count * dim {
                trial[c] = x[c] + t * direction[c];
            }
            let change = change(
                workers, &context, &terms_at, particles, elements, x, trial, changes, scratch,
            );
            Ok((change, trial[..] != x[..]))
        });
        if accepted.is_none() {
            report.iterations = iteration;
            let resolution = resolution(plan, particles, elements, &terms_at, x, direction);
            report.status = after_failed_search(slope, resolution, residual);
            break;
        }
        x.copy_from_slice(trial);
    }
    setup.pair_lags = pair_lags;
    if matches!(report.status, MinimisationStatus::Refused(_)) {
        return report;
    }
    for i in 0..count {
        if particles.mass[i] > 0.0 {
            for a in 0..dim {
                let k = i * dim + a;
                v[k] = (x[k] - start[k]) / h;
            }
        }
    }
    report
}

/// Why element e could not be evaluated at `x`: its law's refusal
/// (material elements), else a non-finite value at its first particle.
fn element_refusal(plan: &Plan, elements: &Elements, e: usize, x: &[f64]) -> Refusal {
    match elements.material_refusal(e, plan, x) {
        Some((family, element, refusal)) => Refusal::Material {
            family,
            family_label: plan.families[family].label.clone(),
            element,
            refusal,
        },
        None => Refusal::NonFinite {
            particle: elements.first_particle(e),
        },
    }
}

/// The authored residual over the free particles on the block tree:
/// per-particle terms |g_i|² (packed) or |g_i| / (m_i h²) (acceleration),
/// 0 for fixed particles.
fn residual(
    plan: &Plan,
    particles: &Particles,
    gradient: &[f64],
    criterion: Convergence,
    terms: &mut Vec<f64>,
    scratch: &mut Vec<f64>,
) -> f64 {
    let (dim, h2) = (plan.dim, plan.h * plan.h);
    terms.clear();
    for i in 0..plan.particle_count() {
        let mass = particles.mass[i];
        if mass == 0.0 {
            terms.push(0.0);
            continue;
        }
        let mut squared = 0.0;
        for a in 0..dim {
            squared += gradient[i * dim + a] * gradient[i * dim + a];
        }
        terms.push(match criterion {
            Convergence::PackedGradient { .. } => squared,
            Convergence::MaxAccelerationResidual { .. } => squared.sqrt() / (mass * h2),
        });
    }
    match criterion {
        Convergence::PackedGradient { .. } => block_tree_sum(terms, scratch).sqrt(),
        Convergence::MaxAccelerationResidual { .. } => block_tree_max(terms, scratch),
    }
}

/// F(y) − F(x): the per-particle changes and h² × the per-element changes,
/// each summed on the block tree (+∞ if any is not finite).
#[allow(clippy::too_many_arguments)]
fn change(
    workers: &Workers,
    context: &Context<'_>,
    terms: &Terms<'_>,
    particles: &Particles,
    elements: &Elements,
    x: &[f64],
    y: &[f64],
    changes: &mut Vec<f64>,
    scratch: &mut Vec<f64>,
) -> f64 {
    let h2 = context.plan.h * context.plan.h;
    particles.changes(workers, context, x, y, changes);
    let own = block_tree_sum(changes, scratch);
    elements.changes(workers, terms, y, changes);
    let coupled = block_tree_sum(changes, scratch);
    let total = own + h2 * coupled;
    if total.is_finite() {
        total
    } else {
        f64::INFINITY
    }
}

/// The rounding bound of [`change`] over the full step Δ (§7 step 11,
/// core's `implicit::resolution`).
fn resolution(
    plan: &Plan,
    particles: &Particles,
    elements: &Elements,
    terms: &Terms<'_>,
    x: &[f64],
    direction: &[f64],
) -> f64 {
    let sums = particle_sums(
        plan.dim,
        &particles.mass,
        x,
        &particles.prediction,
        &particles.load,
        direction,
        &particles.terms,
        Particles::stride(plan.dim),
    );
    let (element_energy, element_force) = elements.energy_scale(terms, x);
    change_resolution(plan.dim, plan.h, sums, element_energy, element_force)
}
