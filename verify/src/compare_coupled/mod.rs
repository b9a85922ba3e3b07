//! The residual-driven bound of the coupled implicit step (docs/implicit.md
//! §12, docs/bounds.md "Coupled implicit step in f32"): how far an iterate
//! `a` (the GPU's f32 step) can be from an iterate `b` (the CPU's f64 step
//! from the same start), from the f64 gradients at both, recomputed on the
//! host by the golden path's gradient code — never the residual a device
//! reports.
//!
//! ```text
//! F(x) = ½‖x − x~‖²_M + h² U(x);  e = a − b;  g_a = ∇F(a), g_b = ∇F(b) in f64 (coupled_gradient)
//! if H(y) ⪰ A for every y on the segment [b, a] (A SPD, block diagonal: A_i per particle),
//!   (g_a − g_b)·e = ∫₀¹ eᵀ H(b + s e) e ds ≥ ‖e‖²_A,   and (g_a − g_b)·e ≤ (‖g_a‖_{A⁻¹} + ‖g_b‖_{A⁻¹}) ‖e‖_A
//!   ⇒ ‖e‖_A ≤ E := ‖g_a‖_{A⁻¹} + ‖g_b‖_{A⁻¹}  ⇒  |e_i| ≤ E / √μ_i   (μ_i ≤ λ_min(A_i))
//! A_i = μ_i I + h² Σ_planes b''(d_max) n nᵀ,   μ_i = m_i − h² D_i           (free particles)
//! ```
//! What each term of U contributes (per term, its curvature on the segment;
//! the step's friction lags are frozen, so friction is a fixed function):
//!
//! ```text
//! inertia ½‖x − x~‖²_M        M: the modulus, always
//! load (gravity, forces)      linear: 0
//! plane barrier b(n·x − c − r) convex (d linear, b'' > 0): b''(d) n nᵀ ⪰ b''(d_max) n nᵀ,
//!                             b'' decreasing in d (b''' < 0), d_max the larger end distance
//! tether max(C, 0)²/(2α)       convex (φ' ≥ 0, φ'' ≥ 0): 0
//! friction (planes, pairs)    μλ f₀(|P w|), w linear, f₀ convex increasing: convex, 0
//! distance spring (i, j)      K = (1/α) nnᵀ + (C/(αℓ))(I − nnᵀ); compressed (ℓ < rest) its
//!                             across eigenvalue is −(rest/ℓ − 1)/α; the block [[K, −K], [−K, K]]
//!                             has eigenvalues 0 and 2λ(K):  D_i, D_j += 2 max(0, rest/ℓ_min − 1)/α
//! ball pair (i, j)            K = b'' nnᵀ + (b'/ℓ)(I − nnᵀ), b' ≤ 0 increasing in d:
//!                             D_i, D_j += 2 |b'(d_min)| / ℓ_min   (pairs with d_min < d^)
//! simplex obstacle            ∇²(b∘d) = b''∇d∇dᵀ + b' ∇²ρ, 0 ⪯ ∇²ρ ⪯ I/ρ (distance to a convex
//!                             set):  D_i += |b'(d_min)| / ρ_min
//! measure springs            ∇²E ⪰ −(sup|C|/α) sup‖∇²V‖ I on the element (measures.rs;
//!                             simplex measures of order ≤ 2, oriented measures)
//! materials                   not bounded here: no bound is stated
//! ℓ_min, ρ_min                over the segment: min of the two ends − half the end points'
//!                             separation (the nearer end is within half of it; ρ at an end
//!                             from the support bound of the returned offset, not trusting
//!                             the closest-point search), × (1 − 1e-12); ℓ_min = 0,
//!                             d_min ≤ 0 or some μ_i ≤ 0: no bound is stated
//! ```
//! The per-particle modulus is what can be certified per particle: the
//! springs' and pairs' curvature along their links is positive but couples
//! two particles (translations are its null space), so it cannot raise any
//! A_i. The gradients are the exact ones up to δg (`rounding.rs`: the
//! f64 evaluation's own rounding, which matters where g is tiny):
//!
//! ```text
//! E = ‖g_a‖_{A⁻¹} + ‖g_b‖_{A⁻¹} + ‖δg_a‖_{μ⁻¹} + ‖δg_b‖_{μ⁻¹}        ‖δ‖²_{μ⁻¹} = Σ_i |δ_i|² / μ_i
//! ```
//! and the bound itself (a few sums and one Cholesky per particle in f64,
//! relative rounding ≲ 1e-13) is scaled by 1 + 1e-9.

mod measures;
mod rounding;

pub use rounding::gradient_rounding;

use hyperpbd_core::barrier::BarrierLaw;
use hyperpbd_core::geometry::closest_point_on_simplex;
use hyperpbd_core::material::cholesky;
use hyperpbd_core::{FamilyKind, Plan};

/// The bound of one step from a common start, per free particle.
#[derive(Debug, Clone, PartialEq)]
pub struct CoupledStepBound {
    /// |a_i − b_i| per particle (0 for fixed ones).
    pub measured: Vec<f64>,
    /// The stated bound E / √μ_i per particle (0 for fixed ones).
    pub bound: Vec<f64>,
    /// ‖g_a‖_{A⁻¹} and ‖g_b‖_{A⁻¹}.
    pub gradient_norms: (f64, f64),
    /// ‖δg_a‖_{μ⁻¹} + ‖δg_b‖_{μ⁻¹}: the gradients' own rounding.
    pub rounding: f64,
    /// Smallest μ_i / m_i over the free particles (1: inertia only).
    pub modulus_fraction: f64,
}

impl CoupledStepBound {
    /// The particle with the largest measured / bound, and that ratio.
    pub fn worst(&self) -> (usize, f64) {
        let mut worst = (0, 0.0);
        for i in 0..self.bound.len() {
            if self.bound[i] > 0.0 {
                let ratio = self.measured[i] / self.bound[i];
                if ratio > worst.1 {
                    worst = (i, ratio);
                }
            }
        }
        worst
    }
}

/// A lower bound of the distance of `x` to the simplex `vertices` that
/// does not trust the closest-point search (certified_filter.rs's support
/// bound): for the returned offset w = x − q̂ ≠ 0,
/// dist(x, conv v) ≥ min_v w·(x − v) / |w|; 0 when w = 0.
fn simplex_distance(plan_dim: usize, vertices: &[f64], x: &[f64], offset: &mut [f64]) -> f64 {
    closest_point_on_simplex(x, vertices, plan_dim, offset);
    let length = offset.iter().map(|w| w * w).sum::<f64>().sqrt();
    if length.is_nan() || length <= 0.0 {
        return 0.0;
    }
    let support = vertices
        .chunks_exact(plan_dim)
        .map(|v| {
            (0..plan_dim)
                .map(|a| offset[a] * (x[a] - v[a]))
                .sum::<f64>()
        })
        .fold(f64::INFINITY, f64::min);
    (support / length) * (1.0 - 1e-12)
}

/// |u − v| of two N-vectors.
fn norm_of_difference(u: &[f64], v: &[f64]) -> f64 {
    u.iter()
        .zip(v)
        .map(|(p, q)| (p - q) * (p - q))
        .sum::<f64>()
        .sqrt()
}

/// The negative-curvature sums D_i over the segment [b, a] (see the
/// module docs), or why none is stated.
fn negative_curvature(plan: &Plan, a: &[f64], b: &[f64]) -> Result<Vec<f64>, String> {
    let (n, dim) = (plan.particle_count(), plan.dim);
    let ip = plan
        .incremental_potential()
        .ok_or("not an incremental-potential plan")?;
    let law: &BarrierLaw = &ip.law;
    let free = |i: usize| plan.inverse_mass[i] > 0.0;
    let point = |x: &[f64], i: usize| x[i * dim..(i + 1) * dim].to_vec();
    // min over the segment of |x_j − x_i|.
    let link_min = |i: usize, j: usize| {
        let ea: Vec<f64> = (0..dim).map(|k| a[j * dim + k] - a[i * dim + k]).collect();
        let eb: Vec<f64> = (0..dim).map(|k| b[j * dim + k] - b[i * dim + k]).collect();
        let la = ea.iter().map(|v| v * v).sum::<f64>().sqrt();
        let lb = eb.iter().map(|v| v * v).sum::<f64>().sqrt();
        // (1 − 1e-12: the f64 rounding of these few operations.)
        ((la.min(lb) - 0.5 * norm_of_difference(&ea, &eb)) * (1.0 - 1e-12)).max(0.0)
    };
    let mut d = vec![0.0; n];
    for family in &plan.families {
        match family.kind {
            FamilyKind::Distance => {
                for e in 0..family.len() {
                    let (i, j) = (
                        family.elements[2 * e] as usize,
                        family.elements[2 * e + 1] as usize,
                    );
                    let rest = family.rest[e];
                    let l = link_min(i, j);
                    if l >= rest {
                        continue;
                    }
                    if l <= 0.0 {
                        return Err(format!("{} element {e}: ℓ_min = 0", family.label));
                    }
                    let c = 2.0 * (rest / l - 1.0) / family.compliance;
                    d[i] += c;
                    d[j] += c;
                }
            }
            FamilyKind::Tether => {}
            FamilyKind::SimplexMeasure { .. } | FamilyKind::OrientedMeasure => {
                let oriented = family.kind == FamilyKind::OrientedMeasure;
                let arity = family.arity;
                for e in 0..family.len() {
                    let members = &family.elements[e * arity..(e + 1) * arity];
                    let gather = |x: &[f64]| -> Vec<f64> {
                        members
                            .iter()
                            .flat_map(|&i| x[i as usize * dim..(i as usize + 1) * dim].to_vec())
                            .collect()
                    };
                    let c = measures::measure_curvature(
                        oriented,
                        family.compliance,
                        family.rest[e],
                        &gather(a),
                        &gather(b),
                        dim,
                    )
                    .ok_or_else(|| {
                        format!(
                            "{} element {e}: no curvature bound for its order",
                            family.label
                        )
                    })?;
                    for &i in members {
                        d[i as usize] += c;
                    }
                }
            }
            _ => {
                return Err(format!(
                    "{} ({:?}): its curvature is not bounded here",
                    family.label, family.kind
                ));
            }
        }
    }
    let activation = law.activation_distance;
    if ip.coupled.as_ref().is_some_and(|c| c.collisions) {
        for i in 0..n {
            for j in i + 1..n {
                if !free(i) && !free(j) {
                    continue;
                }
                let l = link_min(i, j);
                let gap = l - plan.radius[i] - plan.radius[j];
                if gap >= activation {
                    continue;
                }
                if gap <= 0.0 {
                    return Err(format!("balls {i} and {j}: d_min = {gap:e} ≤ 0"));
                }
                let c = 2.0 * law.evaluate(gap).1.abs() / l;
                d[i] += c;
                d[j] += c;
            }
        }
    }
    let obstacles = &ip.obstacles;
    let mut offset = vec![0.0; dim];
    for i in (0..n).filter(|&i| free(i)) {
        let (pa, pb) = (point(a, i), point(b, i));
        let half = 0.5 * norm_of_difference(&pa, &pb);
        for s in 0..obstacles.simplex_count() {
            let vertices = obstacles.simplex(s, dim);
            let near = simplex_distance(dim, vertices, &pa, &mut offset).min(simplex_distance(
                dim,
                vertices,
                &pb,
                &mut offset,
            ));
            let rho = (near - half) * (1.0 - 1e-12);
            let gap = rho - plan.radius[i];
            if gap >= activation {
                continue;
            }
            if gap <= 0.0 {
                return Err(format!("particle {i}, simplex {s}: d_min ≤ 0"));
            }
            d[i] += law.evaluate(gap).1.abs() / rho;
        }
    }
    Ok(d)
}

/// Solves the SPD system `a` y = `g` (N × N, core's Cholesky) and returns
/// gᵀy.
fn inverse_quadratic(a: &[f64], g: &[f64]) -> Option<f64> {
    let n = g.len();
    let mut l = vec![0.0; n * n];
    cholesky(a, n, &mut l).ok()?;
    // gᵀ A⁻¹ g = |L⁻¹ g|².
    let mut y = g.to_vec();
    for i in 0..n {
        for k in 0..i {
            y[i] -= l[i * n + k] * y[k];
        }
        y[i] /= l[i * n + i];
    }
    Some(y.iter().map(|v| v * v).sum())
}

/// The bound of `a` against `b`, two iterates of the coupled step that
/// starts from `start` = (x^t, v^t), from their f64 gradients
/// `gradient_a`, `gradient_b` (from `hyperpbd_cpu::coupled_gradient`).
/// `Err` says why no bound is stated.
pub fn coupled_step_bound(
    plan: &Plan,
    start: (&[f64], &[f64]),
    a: &[f64],
    b: &[f64],
    gradient_a: &[f64],
    gradient_b: &[f64],
) -> Result<CoupledStepBound, String> {
    let (n, dim) = (plan.particle_count(), plan.dim);
    let ip = plan
        .incremental_potential()
        .ok_or("not an incremental-potential plan")?;
    let h2 = plan.h * plan.h;
    let d = negative_curvature(plan, a, b)?;
    let law = &ip.law;
    let obstacles = &ip.obstacles;
    let mut mu = vec![0.0; n];
    let (mut norm_a, mut norm_b) = (0.0, 0.0);
    let mut fraction = f64::INFINITY;
    let mut block = vec![0.0; dim * dim];
    for i in (0..n).filter(|&i| plan.inverse_mass[i] > 0.0) {
        let m = 1.0 / plan.inverse_mass[i];
        mu[i] = m - h2 * d[i];
        if mu[i].is_nan() || mu[i] <= 0.0 {
            return Err(format!(
                "particle {i}: μ_i = m_i − h² D_i = {:e} ≤ 0 (m_i = {m:e}, h² D_i = {:e})",
                mu[i],
                h2 * d[i]
            ));
        }
        fraction = fraction.min(mu[i] / m);
        let (xa, xb) = (&a[i * dim..(i + 1) * dim], &b[i * dim..(i + 1) * dim]);
        let assemble = |block: &mut [f64]| -> Result<(), String> {
            block.fill(0.0);
            for k in 0..dim {
                block[k * dim + k] = mu[i];
            }
            for p in 0..obstacles.plane_count() {
                let normal = &obstacles.plane_normals[p * dim..(p + 1) * dim];
                let offset = obstacles.plane_offsets[p] + plan.radius[i];
                let distance =
                    |x: &[f64]| normal.iter().zip(x).map(|(n, x)| n * x).sum::<f64>() - offset;
                // The larger end distance, raised by its f64 rounding
                // (relative to the terms of n·x − c − r).
                let size = |x: &[f64]| {
                    normal
                        .iter()
                        .zip(x)
                        .map(|(n, x)| (n * x).abs())
                        .sum::<f64>()
                        + offset.abs()
                };
                let far = distance(xa).max(distance(xb)) + 1e-12 * size(xa).max(size(xb));
                let curvature = law.evaluate(far).2.max(0.0);
                if !curvature.is_finite() {
                    return Err(format!("particle {i}, plane {p}: d ≤ 0"));
                }
                for r in 0..dim {
                    for c in 0..dim {
                        block[r * dim + c] += h2 * curvature * normal[r] * normal[c];
                    }
                }
            }
            Ok(())
        };
        for (gradient, norm) in [(gradient_a, &mut norm_a), (gradient_b, &mut norm_b)] {
            assemble(&mut block)?;
            let g = &gradient[i * dim..(i + 1) * dim];
            *norm += inverse_quadratic(&block, g).ok_or("a block is not SPD")?;
        }
    }
    let (norm_a, norm_b) = (norm_a.sqrt(), norm_b.sqrt());
    let (delta_a, delta_b) = (
        gradient_rounding(plan, start, a),
        gradient_rounding(plan, start, b),
    );
    let weighted = |delta: &[f64]| {
        (0..n)
            .filter(|&i| plan.inverse_mass[i] > 0.0)
            .map(|i| delta[i] * delta[i] / mu[i])
            .sum::<f64>()
            .sqrt()
    };
    let rounding = weighted(&delta_a) + weighted(&delta_b);
    if !rounding.is_finite() {
        return Err("the gradients' rounding is not finite".into());
    }
    let total = (norm_a + norm_b + rounding) * (1.0 + 1e-9);
    let mut measured = vec![0.0; n];
    let mut bound = vec![0.0; n];
    for i in (0..n).filter(|&i| plan.inverse_mass[i] > 0.0) {
        measured[i] = norm_of_difference(&a[i * dim..(i + 1) * dim], &b[i * dim..(i + 1) * dim]);
        bound[i] = total / mu[i].sqrt();
    }
    Ok(CoupledStepBound {
        measured,
        bound,
        gradient_norms: (norm_a, norm_b),
        rounding,
        modulus_fraction: fraction,
    })
}
