//! Particle–particle contact: broadphase per substep, then gather-Jacobi
//! iterations with averaging.
//!
//! ```text
//! Broadphase (after Predict):
//!   boxes  [min(p, x) − (r + m), max(p, x) + (r + m)]      (swept over the substep)
//!   pairs  a uniform grid queried box by box (core's grid.rs; the one-axis
//!          sweep where the grid does not apply)             (canonical (i < j) order)
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
//!     c_e = n s − t_f                                      (relative correction;
//!                                            core's kinds::particle_contact)
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
//! (w = 0) are never written. The same holds across threads: pairs write
//! only their own correction, particles only their own position, so both
//! passes run in chunks on every core (`parallel.rs`).

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use crate::dim::{Dim, with_dim};
use crate::integrate::PARTICLE_GRAIN;
use crate::parallel::{DisjointSlice, Workers};
use crate::residual::RESIDUAL_GRAIN;
use hyperpbd_core::broadphase::{
    Aabbs, BoxGrid, Pair, contact_lists_into, sweep_axis, sweep_pairs, swept_boxes,
};
use hyperpbd_core::geometry::{deepest_overlap, separation};
use hyperpbd_core::kinds::particle_contact::pair_correction;
use hyperpbd_core::{FamilyResidual, Plan};

/// Pairs per chunk of the pair pass.
pub const PAIR_GRAIN: usize = 2048;

/// Boxes per chunk of the broadphase queries.
pub const BOX_GRAIN: usize = 1024;

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

/// Swept boxes from `p` to `x`, the sweep, and the contact lists (on the
/// calling thread).
pub fn broadphase(plan: &Plan, margin: f64, p: &[f64], x: &[f64], contacts: &mut Contacts) {
    let mut boxes = Aabbs::default();
    broadphase_on(&Workers::serial(), plan, margin, p, x, &mut boxes, contacts);
}

/// [`broadphase`] on `workers`: the boxes per particle and the grid's
/// per-box queries in chunks, concatenated in box order (already
/// canonical). `boxes` is scratch kept between substeps.
pub(crate) fn broadphase_on(
    workers: &Workers,
    plan: &Plan,
    margin: f64,
    p: &[f64],
    x: &[f64],
    boxes: &mut Aabbs,
    contacts: &mut Contacts,
) {
    let dim = plan.dim;
    let n = plan.particle_count();
    boxes.dim = dim;
    boxes.min.resize(n * dim, 0.0);
    boxes.max.resize(n * dim, 0.0);
    let radius = &plan.radius;
    let _ = workers.try_for_spans(
        n,
        PARTICLE_GRAIN,
        dim,
        [&mut boxes.min, &mut boxes.max],
        |r, [min, max]| {
            let coordinates = r.start * dim..r.end * dim;
            let (start, end) = (&p[coordinates.clone()], &x[coordinates]);
            swept_boxes(start, end, &radius[r], margin, min, max);
            Ok(())
        },
    );
    let w = &plan.inverse_mass;
    let moving = |&[i, j]: &Pair| w[i as usize] + w[j as usize] > 0.0;
    contacts.pairs.clear();
    match BoxGrid::new(boxes) {
        Some(grid) => {
            let chunks = workers.map_chunks(n, BOX_GRAIN, |r| {
                let mut pairs = Vec::new();
                for i in r {
                    grid.pairs_of(i, &mut pairs);
                }
                pairs.retain(moving);
                pairs
            });
            for chunk in chunks {
                contacts.pairs.extend_from_slice(&chunk);
            }
        }
        None => {
            contacts.pairs = sweep_pairs(boxes, sweep_axis(boxes));
            contacts.pairs.retain(moving);
        }
    }
    let count = contacts.pairs.len();
    contact_lists_into(
        &contacts.pairs,
        n,
        &mut contacts.offsets,
        &mut contacts.entries,
    );
    contacts.corrections.clear();
    contacts.corrections.resize(count * dim, 0.0);
    contacts.active.clear();
    contacts.active.resize(count, false);
}

/// One gather-Jacobi iteration (on the calling thread). Returns the first
/// particle (or the first particle of the first pair) whose update was
/// non-finite.
pub fn collide(
    plan: &Plan,
    friction: f64,
    p: &[f64],
    x: &mut [f64],
    contacts: &mut Contacts,
) -> Result<(), usize> {
    collide_on(&Workers::serial(), plan, friction, p, x, contacts)
}

/// [`collide`] on `workers`.
pub(crate) fn collide_on(
    workers: &Workers,
    plan: &Plan,
    friction: f64,
    p: &[f64],
    x: &mut [f64],
    contacts: &mut Contacts,
) -> Result<(), usize> {
    let dim = plan.dim;
    let Contacts {
        pairs,
        offsets,
        entries,
        corrections,
        active,
    } = contacts;
    let pass = PairPass {
        plan,
        friction,
        p,
        x,
        pairs,
    };
    // SAFETY: chunk r writes the corrections and flags of its own pairs r.
    let (corrections_view, active_view) =
        unsafe { (DisjointSlice::new(corrections), DisjointSlice::new(active)) };
    workers
        .try_for_chunks(pairs.len(), PAIR_GRAIN, |r| {
            // SAFETY: the spans of this chunk's pairs, used only here.
            let (out, flags) = unsafe {
                (
                    corrections_view.range_mut(r.start * dim..r.end * dim),
                    active_view.range_mut(r.clone()),
                )
            };
            with_dim!(dim, pair_corrections(&pass, r, out, flags))
        })
        .map_err(|e| pairs[e][0] as usize)?;
    let gather = Gather {
        plan,
        pairs,
        offsets,
        entries,
        corrections,
        active,
    };
    let count = plan.particle_count();
    workers.try_for_spans(count, PARTICLE_GRAIN, dim, [x], |r, [x]| {
        with_dim!(dim, gather_corrections(&gather, r, x))
    })
}

/// What the pair pass reads.
struct PairPass<'a> {
    plan: &'a Plan,
    friction: f64,
    p: &'a [f64],
    x: &'a [f64],
    pairs: &'a [Pair],
}

/// c_e and the active flag of pairs `range` into `out` (`dim` reals per
/// pair) and `flags`; the first pair whose length is not finite.
fn pair_corrections<D: Dim>(
    dim: D,
    pass: &PairPass,
    range: std::ops::Range<usize>,
    out: &mut [f64],
    flags: &mut [bool],
) -> Result<(), usize> {
    let n = dim.n();
    let (x, p, r) = (pass.x, pass.p, &pass.plan.radius);
    let friction = pass.friction;
    let mut d = dim.zeros();
    let d = d.as_mut();
    let first = range.start;
    for (e, &[i, j]) in pass.pairs[range].iter().enumerate() {
        let (i, j) = (i as usize, j as usize);
        let len = separation(x, i, j, n, d);
        if !len.is_finite() {
            return Err(first + e);
        }
        let out = &mut out[e * n..(e + 1) * n];
        let slip = |a| (x[j * n + a] - p[j * n + a]) - (x[i * n + a] - p[i * n + a]);
        flags[e] = pair_correction(d, (len, r[i] + r[j], friction), slip, out);
    }
    Ok(())
}

/// What the particle pass reads.
struct Gather<'a> {
    plan: &'a Plan,
    pairs: &'a [Pair],
    offsets: &'a [u32],
    entries: &'a [u32],
    corrections: &'a [f64],
    active: &'a [bool],
}

/// Particles `range` (positions `x`) sum their active contacts in list
/// order and move by the average; the first non-finite particle.
fn gather_corrections<D: Dim>(
    dim: D,
    gather: &Gather,
    range: std::ops::Range<usize>,
    x: &mut [f64],
) -> Result<(), usize> {
    let n = dim.n();
    let w = &gather.plan.inverse_mass;
    let mut sum = dim.zeros();
    let sum = sum.as_mut();
    let first = range.start;
    for k in range {
        let wk = w[k];
        if wk == 0.0 {
            continue;
        }
        let list = &gather.entries[gather.offsets[k] as usize..gather.offsets[k + 1] as usize];
        sum.fill(0.0);
        let mut active = 0u32;
        for &entry in list {
            let e = (entry / 2) as usize;
            if !gather.active[e] {
                continue;
            }
            let [i, j] = gather.pairs[e];
            let share = wk / (w[i as usize] + w[j as usize]);
            let sign = if entry % 2 == 0 { -share } else { share };
            for a in 0..n {
                sum[a] += sign * gather.corrections[e * n + a];
            }
            active += 1;
        }
        if active == 0 {
            continue;
        }
        let count = f64::from(active);
        let xk = &mut x[(k - first) * n..(k - first + 1) * n];
        for a in 0..n {
            let value = xk[a] + sum[a] / count;
            if !value.is_finite() {
                return Err(k);
            }
            xk[a] = value;
        }
    }
    Ok(())
}

/// Deepest overlap max(0, r_i + r_j − |x_j − x_i|) over the candidate
/// pairs, labelled `collisions`; per chunk, then over chunks in order.
pub fn residual(workers: &Workers, plan: &Plan, x: &[f64], contacts: &Contacts) -> FamilyResidual {
    let deepest = workers
        .map_chunks(contacts.pairs.len(), RESIDUAL_GRAIN, |r| {
            deepest_overlap(plan.dim, &plan.radius, &contacts.pairs[r], x)
        })
        .into_iter()
        .fold(0.0, f64::max);
    FamilyResidual {
        label: "collisions".into(),
        max_violation: deepest,
    }
}
