//! How far the f64 gradient the host computes (`coupled_gradient`) can be
//! from the exact ∇F at the same point: the bound of the parent module
//! uses the exact gradients, so it adds this rounding (per particle,
//! Euclidean, δg_i).
//!
//! ```text
//! g_i = m_i (x_i − x~_i) − h² load_i + h² Σ_terms ∇_i(term),   x~_i = x^t_i + h v_i   (f64)
//! |δg_i| ≤ γ [ m_i (|x_i| + |x^t_i| + 2h |v_i|) + h² |load_i| + h² Σ_terms T ],   γ = 4 (N + 4) ε₆₄
//! T, a term's force magnitude plus its input's rounding through its slope (the value it is a
//! function of is computed from coordinates of size S, relative rounding ∝ ε S):
//!   distance / tether      |C|/α + (ℓ + rest)/α
//!   ball pair              |b'(d)| + b''(d) (ℓ + r_i + r_j)                    (d < d^)
//!   plane                  |b'(d)| + b''(d) (Σ_a |n_a x_a| + |c| + r)         (d < d^)
//!   simplex                |b'(d)| + b''(d) (|x| + max_v |v| + r)              (d < d^)
//!   friction (lag F_max)   F_max (1 + 2 (|x| + |x^t| [+ partner's]) / (ε_v h)) (slope of the
//!                          smoothed static branch 2 F_max/ε times the slip's rounding);
//!                          a simplex lag × (1 + (|x^t| + max_v |v|)/(d + r)), its normal's
//!                          rounding relative to |x^t − q|
//! ```
//! γ is four times the (N + 4) ε the golden path's own floors use, which
//! covers the few sums (at most a particle's terms, in a fixed order) and
//! the second-order terms.

use hyperpbd_core::Plan;

/// Euclidean norm of an N-vector.
fn norm(v: &[f64]) -> f64 {
    v.iter().map(|a| a * a).sum::<f64>().sqrt()
}

/// δg_i at `x` for the step starting from `start` = (x^t, v^t).
pub fn gradient_rounding(plan: &Plan, start: (&[f64], &[f64]), x: &[f64]) -> Vec<f64> {
    let (n, dim, h) = (plan.particle_count(), plan.dim, plan.h);
    let h2 = h * h;
    let gamma = 4.0 * (dim as f64 + 4.0) * f64::EPSILON;
    let mut magnitude = vec![0.0; n];
    let Some(ip) = plan.incremental_potential() else {
        return magnitude;
    };
    let law = &ip.law;
    let slip = ip
        .coupled
        .as_ref()
        .map_or(f64::INFINITY, |c| c.slip_velocity * h);
    let at = |v: &[f64], i: usize| -> Vec<f64> { v[i * dim..(i + 1) * dim].to_vec() };
    let free = |i: usize| plan.inverse_mass[i] > 0.0;
    // Terms of U, added to both members (h² later).
    let mut terms = vec![0.0; n];
    for family in &plan.families {
        for e in 0..family.len() {
            if family.arity != 2 {
                continue;
            }
            let (i, j) = (
                family.elements[2 * e] as usize,
                family.elements[2 * e + 1] as usize,
            );
            let diff: Vec<f64> = (0..dim).map(|a| x[j * dim + a] - x[i * dim + a]).collect();
            let l = norm(&diff);
            let rest = family.rest[e];
            let t = ((l - rest).abs() + l + rest) / family.compliance;
            terms[i] += t;
            terms[j] += t;
        }
    }
    let coupled = ip.coupled.as_ref();
    if coupled.is_some_and(|c| c.collisions) {
        let pair_mu = coupled.map_or(0.0, |c| c.pair_friction);
        for i in 0..n {
            for j in i + 1..n {
                if !free(i) && !free(j) {
                    continue;
                }
                let radii = plan.radius[i] + plan.radius[j];
                let l = norm(
                    &(0..dim)
                        .map(|a| x[j * dim + a] - x[i * dim + a])
                        .collect::<Vec<_>>(),
                );
                let (_, slope, curvature) = law.evaluate(l - radii);
                let mut t = slope.abs() + curvature * (l + radii);
                if pair_mu > 0.0 {
                    let lt = norm(
                        &(0..dim)
                            .map(|a| start.0[j * dim + a] - start.0[i * dim + a])
                            .collect::<Vec<_>>(),
                    );
                    let limit = pair_mu * law.evaluate(lt - radii).1.abs();
                    let sizes = norm(&at(x, i))
                        + norm(&at(x, j))
                        + norm(&at(start.0, i))
                        + norm(&at(start.0, j));
                    t += limit * (1.0 + 2.0 * sizes / slip);
                }
                if t.is_finite() {
                    terms[i] += t;
                    terms[j] += t;
                } else {
                    terms[i] = f64::INFINITY;
                    terms[j] = f64::INFINITY;
                }
            }
        }
    }
    let obstacles = &ip.obstacles;
    let mut normal = vec![0.0; dim];
    for i in (0..n).filter(|&i| free(i)) {
        let (xi, ti) = (at(x, i), at(start.0, i));
        let (size, start_size) = (norm(&xi), norm(&ti));
        for o in 0..obstacles.len() {
            let d = obstacles.distance(o, &xi, plan.radius[i], &mut normal);
            let (_, slope, curvature) = law.evaluate(d);
            let scale = if o < obstacles.plane_count() {
                let nn = &obstacles.plane_normals[o * dim..(o + 1) * dim];
                nn.iter().zip(&xi).map(|(p, q)| (p * q).abs()).sum::<f64>()
                    + obstacles.plane_offsets[o].abs()
                    + plan.radius[i]
            } else {
                let s = o - obstacles.plane_count();
                let vertices = obstacles.simplex(s, dim);
                let far = vertices.chunks_exact(dim).map(norm).fold(0.0f64, f64::max);
                size + far + plan.radius[i]
            };
            terms[i] += slope.abs() + curvature * scale;
            let mu = coupled.map_or(0.0, |c| c.friction(o));
            if mu > 0.0 {
                let dt = obstacles.distance(o, &ti, plan.radius[i], &mut normal);
                let limit = mu * law.evaluate(dt).1.abs();
                // A simplex lag's normal (x^t − q)/|x^t − q| carries the
                // rounding of coordinates of size |x^t| + far relative to
                // |x^t − q| = d + r (a plane's is authored, unit).
                let normal_growth = if o < obstacles.plane_count() {
                    1.0
                } else {
                    let s = o - obstacles.plane_count();
                    let vertices = obstacles.simplex(s, dim);
                    let far = vertices.chunks_exact(dim).map(norm).fold(0.0f64, f64::max);
                    1.0 + (start_size + far) / (dt + plan.radius[i])
                };
                terms[i] += limit * (1.0 + 2.0 * (size + start_size) / slip * normal_growth);
            }
        }
        let m = 1.0 / plan.inverse_mass[i];
        let load: Vec<f64> = (0..dim)
            .map(|a| m * plan.gravity_scale[i] * plan.gravity[a] + plan.force[i * dim + a])
            .collect();
        magnitude[i] = gamma
            * (m * (size + start_size + 2.0 * h * norm(&at(start.1, i)))
                + h2 * norm(&load)
                + h2 * terms[i]);
    }
    magnitude
}
