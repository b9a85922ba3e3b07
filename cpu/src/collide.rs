//! Particle–particle contact: broadphase per substep, then gather-Jacobi
//! iterations with averaging.
//!
//! ```text
//! Broadphase (after Predict):
//!   boxes  [min(p, x) − (r + m), max(p, x) + (r + m)]      (swept over the substep)
//!   pairs  sort-and-sweep along the axis of widest spread   (canonical (i < j) order)
//!          minus pairs of two fixed particles (W = w_i + w_j = 0)
//!   lists  particle k: the pairs it is in, in pair order    (CSR: offsets, entries)
//!
//! Collide (one Jacobi iteration; every pair reads the same iterate x):
//!   pair e = (i, j):  d = x_j − x_i;  C = |d| − (r_i + r_j)
//!     C ≥ 0 or |d| = 0:  inactive (no overlap, or no direction to push)
//!     n = d / |d|;  s = −C                                  (penetration)
//!     friction μ > 0:  Δr = (x_j − p_j) − (x_i − p_i);  t = Δr − (Δr·n) n
//!                      t_f = t                 if |t| ≤ μ s   (static: cancel all)
//!                          = t · μ s / |t|     otherwise      (dynamic: one clamp
//!                                                             on the tangent norm)
//!     c_e = n s − t_f                                      (relative correction)
//!   particle k (gather over its sorted list, in order):
//!     Σ_k = Σ_{e ∋ k, active} ±(w_k / W_e) c_e     (− if k = i, + if k = j)
//!     x_k += Σ_k / a_k,   a_k = number of active contacts of k
//! ```
//! Why averaged gather-Jacobi: the summed, unaveraged Jacobi update over-
//! corrects a particle with a_k contacts by up to a factor a_k and explodes
//! on deep stacks; dividing by a_k makes every update a convex combination
//! of single-contact projections (a non-expansive step), at the price of
//! slower convergence on long chains of contacts (measured in
//! docs/collisions.md). Both backends read the same iterate and sum each
//! particle's list in the same order, so the result does not depend on
//! scheduling; there are no floating-point atomics. Fixed particles
//! (w = 0) are never written.

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use hyperpbd_core::broadphase::{Aabbs, Pair, contact_lists, sweep_axis, sweep_pairs};
use hyperpbd_core::geometry::deepest_overlap;
use hyperpbd_core::{FamilyResidual, Plan};

/// Candidate pairs and each particle's contact list.
#[derive(Debug, Default, Clone)]
pub struct Contacts {
    /// Candidate pairs (i < j), canonical order.
    pub pairs: Vec<Pair>,
    /// Particle k's entries are `entries[offsets[k]..offsets[k + 1]]`.
    pub offsets: Vec<u32>,
    /// 2 e + side: pair e, side 0 (k = i) or 1 (k = j).
    pub entries: Vec<u32>,
    /// Relative correction c_e per pair (`dim` reals), this iteration.
    pub corrections: Vec<f64>,
    /// Whether pair e pushed in the last iteration.
    pub active: Vec<bool>,
}

impl Contacts {
    /// Pairs that pushed in the last iteration.
    pub fn active_count(&self) -> usize {
        self.active.iter().filter(|&&a| a).count()
    }
}

/// Swept boxes from `p` to `x`, the sweep, and the contact lists.
pub fn broadphase(plan: &Plan, margin: f64, p: &[f64], x: &[f64], contacts: &mut Contacts) {
    let dim = plan.dim;
    let n = plan.particle_count();
    let boxes = Aabbs::swept_particles(dim, p, x, &plan.radius, margin);
    let w = &plan.inverse_mass;
    let mut pairs = sweep_pairs(&boxes, sweep_axis(&boxes));
    pairs.retain(|&[i, j]| w[i as usize] + w[j as usize] > 0.0);
    let (offsets, entries) = contact_lists(&pairs, n);
    contacts.corrections.clear();
    contacts.corrections.resize(pairs.len() * dim, 0.0);
    contacts.active.clear();
    contacts.active.resize(pairs.len(), false);
    contacts.pairs = pairs;
    contacts.offsets = offsets;
    contacts.entries = entries;
}

/// One gather-Jacobi iteration. Returns the first particle (or the first
/// particle of the first pair) whose update was non-finite.
pub fn collide(
    plan: &Plan,
    friction: f64,
    p: &[f64],
    x: &mut [f64],
    contacts: &mut Contacts,
) -> Result<(), usize> {
    let dim = plan.dim;
    let w = &plan.inverse_mass;
    let r = &plan.radius;
    let mut d = vec![0.0; dim];
    for (e, &[i, j]) in contacts.pairs.iter().enumerate() {
        let (i, j) = (i as usize, j as usize);
        let mut len2 = 0.0;
        for a in 0..dim {
            d[a] = x[j * dim + a] - x[i * dim + a];
            len2 += d[a] * d[a];
        }
        let len = len2.sqrt();
        if !len.is_finite() {
            return Err(i);
        }
        let c = len - (r[i] + r[j]);
        let out = &mut contacts.corrections[e * dim..(e + 1) * dim];
        contacts.active[e] = c < 0.0 && len > 0.0;
        if !contacts.active[e] {
            continue;
        }
        let s = -c;
        let inv = 1.0 / len;
        for a in 0..dim {
            d[a] *= inv;
        }
        for a in 0..dim {
            out[a] = d[a] * s;
        }
        if friction > 0.0 {
            let mut dn = 0.0;
            for a in 0..dim {
                let dr = (x[j * dim + a] - p[j * dim + a]) - (x[i * dim + a] - p[i * dim + a]);
                dn += dr * d[a];
            }
            let mut t2 = 0.0;
            for a in 0..dim {
                let dr = (x[j * dim + a] - p[j * dim + a]) - (x[i * dim + a] - p[i * dim + a]);
                let t = dr - dn * d[a];
                t2 += t * t;
            }
            let t_norm = t2.sqrt();
            let bound = friction * s;
            let scale = if t_norm <= bound { 1.0 } else { bound / t_norm };
            for a in 0..dim {
                let dr = (x[j * dim + a] - p[j * dim + a]) - (x[i * dim + a] - p[i * dim + a]);
                let t = dr - dn * d[a];
                out[a] -= t * scale;
            }
        }
    }
    let mut sum = vec![0.0; dim];
    for k in 0..plan.particle_count() {
        let wk = w[k];
        if wk == 0.0 {
            continue;
        }
        let list =
            &contacts.entries[contacts.offsets[k] as usize..contacts.offsets[k + 1] as usize];
        sum.fill(0.0);
        let mut active = 0u32;
        for &entry in list {
            let e = (entry / 2) as usize;
            if !contacts.active[e] {
                continue;
            }
            let [i, j] = contacts.pairs[e];
            let share = wk / (w[i as usize] + w[j as usize]);
            let sign = if entry % 2 == 0 { -share } else { share };
            for a in 0..dim {
                sum[a] += sign * contacts.corrections[e * dim + a];
            }
            active += 1;
        }
        if active == 0 {
            continue;
        }
        let count = f64::from(active);
        for a in 0..dim {
            let xk = x[k * dim + a] + sum[a] / count;
            if !xk.is_finite() {
                return Err(k);
            }
            x[k * dim + a] = xk;
        }
    }
    Ok(())
}

/// Deepest overlap max(0, r_i + r_j − |x_j − x_i|) over the candidate
/// pairs, labelled `collisions`.
pub fn residual(plan: &Plan, x: &[f64], contacts: &Contacts) -> FamilyResidual {
    FamilyResidual {
        label: "collisions".into(),
        max_violation: deepest_overlap(plan.dim, &plan.radius, &contacts.pairs, x),
    }
}
