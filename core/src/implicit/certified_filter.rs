//! Certified step filters for every barrier term, certified in floating
//! point: the trial points a line search computes from the returned
//! fraction have exact distance d > 0 (exact arithmetic on the computed
//! f64 values), for ball pairs, hyperplanes and static simplices.
//!
//! ```text
//! per term, from the current x and the step Δ (trial y = fl(x + fl(t Δ)), t ≤ 1):
//!   d(x + sΔ) ≥ d_exact(x) − s·a              a: an upper bound of the approach rate
//!   d_exact(x) ≥ d0 − δd_eval                  d0 computed, δd_eval its stated rounding
//!   |d(y) − d(x + tΔ)| ≤ δd_trial              the rounding of the trial point itself
//!   ⇒ time t* = max(0, d0 − δd) / a,  δd = δd_eval + δd_trial   (∞ when a ≤ 0)
//! fraction = min(1, η · min over every term t*),  η = barrier::FILTER_SAFETY
//! ```
//! so every trial keeps d ≥ (1 − η)(d0 − δd) > 0 exactly, and a term with
//! d0 ≤ δd (within rounding of contact, or infeasible) admits no motion
//! (t* = 0). The bounds below carry ε = `epsilon` (f64::EPSILON on the
//! golden path; the f32 kernel passes its own); γ = (N + 4) ε. Each is at
//! least twice the first-order rounding bound, which absorbs the rounding
//! of evaluating the bound itself and the second-order terms; η < 1 − 8ε
//! absorbs the rounding of t* = low/a and η·t*.
//!
//! ```text
//! trial rounding (any term):  per coordinate |y_c − (x_c + tΔ_c)| ≤ u (|x_c| + 2.001 |Δ_c|),
//!   u = ε/2, so |y − (x + tΔ)| ≤ √N u (‖x‖∞ + 2.001 ‖Δ‖∞) ≤ N ε (‖x‖∞ + 2 ‖Δ‖∞) =: ρ(x, Δ)
//!   (with an fma the error is smaller); d is 1-Lipschitz in each point (|n̂| ≤ 1 + Nu)
//! pair (i, j):  e = x_j − x_i (each component rounded relative to itself), ℓ = |e|,
//!   d0 = ℓ − r_i − r_j;   δd_eval = γ (ℓ + r_i + r_j)      ((N + 3)/2·u from Σe², √, and 2u per subtraction)
//!   |e(s)| ≥ n·e(s) = ℓ + s n·δ for the exact unit n = e/ℓ, δ = Δ_j − Δ_i   (Cauchy–Schwarz)
//!   a = −n̂·δ̂ + γ |δ̂|      (|n̂ − n| ≤ (N/2 + 5) u, the dot product γ_N: ≤ (1.5N + 7) u |δ|)
//!   δd_trial = ρ(x_i, Δ_i) + ρ(x_j, Δ_j)
//! plane (stored n̂, offset c; exactly linear in x):  d0 = n̂·x − c − r
//!   δd_eval = γ (Σ_a |n̂_a x_a| + |c| + r),   a = −n̂·Δ + γ Σ_a |n̂_a Δ_a|,   δd_trial = ρ(x, Δ)
//! simplex (vertices v, computed offset w = x − q̂ from geometry::closest_point_on_simplex):
//!   support bound: for any w ≠ 0, dist(x, conv v) ≥ min_v w·(x − v) / |w|
//!     (w·(x − y) = Σ λ_v w·(x − v) for y = Σ λ_v v, and |x − y| ≥ w·(x − y)/|w|)
//!   d0 = min_v Σ_a w_a (x_a − v_a) / |w| − r;   A = max_v Σ_a |w_a (x_a − v_a)|
//!   δd_eval = γ (A/|w| + r)                        ((N + 1) u A from the dots, (N/2 + 3) u from |w|)
//!   a = |Δ| (1 + γ)                                 (distance is 1-Lipschitz)
//!   δd_trial = ρ(x, Δ);   w = 0 (x on the simplex): t* = 0
//! ```
//! The simplex bound does not trust the closest-point enumeration: it
//! certifies whatever direction w it returned, and is tight (equal to the
//! distance) when q̂ is the true closest point. Both A/|w| ≤ max_v |x − v|
//! and ℓ are local sizes, so far from the origin only ρ grows with |x|.

use crate::barrier::{
    BarrierObstacles, FILTER_SAFETY, candidate_box, filter_reach, support_margin,
};
use crate::geometry::{closest_point_on_simplex, distance};

/// min(1, η · `time`): the admissible step fraction for the smallest time
/// over every barrier term.
pub fn fraction(time: f64) -> f64 {
    (FILTER_SAFETY * time).min(1.0)
}

/// ρ(x, Δ) = N ε (‖x‖∞ + 2‖Δ‖∞): the displacement rounding of one trial
/// point.
pub fn trial_rounding(x: &[f64], delta: &[f64], epsilon: f64) -> f64 {
    let mut largest_x: f64 = 0.0;
    let mut largest_delta: f64 = 0.0;
    for a in 0..x.len() {
        largest_x = largest_x.max(x[a].abs());
        largest_delta = largest_delta.max(delta[a].abs());
    }
    x.len() as f64 * epsilon * (largest_x + 2.0 * largest_delta)
}

/// t* from a certified lower distance `low` = d0 − δd and approach bound
/// `approach`.
fn time(low: f64, approach: f64) -> f64 {
    if low.is_nan() || low <= 0.0 {
        return 0.0;
    }
    if approach > 0.0 {
        low / approach
    } else if approach.is_nan() {
        0.0
    } else {
        f64::INFINITY
    }
}

/// Certified time t* of the ball pair `points` = (x_i, x_j) with radii
/// `radii` and steps `steps` = (Δ_i, Δ_j) (each 2 × `dim`).
pub fn pair_time(
    points: &[f64],
    radii: (f64, f64),
    steps: &[f64],
    dim: usize,
    epsilon: f64,
) -> f64 {
    let (xi, xj) = points.split_at(dim);
    let (di, dj) = steps.split_at(dim);
    let mut gradient = [0.0f64; 2 * crate::MAX_DIM];
    let length = distance(points, dim, &mut gradient);
    if length.is_nan() || length <= 0.0 {
        return 0.0;
    }
    let d0 = length - radii.0 - radii.1;
    let gamma = (dim as f64 + 4.0) * epsilon;
    let mut closing = 0.0;
    let mut step_squared = 0.0;
    for a in 0..dim {
        let delta = dj[a] - di[a];
        closing -= gradient[dim + a] * delta;
        step_squared += delta * delta;
    }
    let approach = closing + gamma * step_squared.sqrt();
    let rounding = gamma * (length + radii.0 + radii.1)
        + trial_rounding(xi, &di[..dim], epsilon)
        + trial_rounding(xj, &dj[..dim], epsilon);
    time(d0 - rounding, approach)
}

/// One particle's trial move against the obstacles: the ball at `x` of
/// radius `radius`, moved by `delta` (the trial y = fl(x + fl(t Δ))).
#[derive(Clone, Copy, Debug)]
pub struct TrialMove<'a> {
    pub x: &'a [f64],
    pub radius: f64,
    pub delta: &'a [f64],
}

/// Certified time t* of plane `p` of `obstacles` for `trial`.
pub fn plane_time(obstacles: &BarrierObstacles, p: usize, trial: TrialMove, epsilon: f64) -> f64 {
    let TrialMove { x, radius, delta } = trial;
    let dim = x.len();
    let n = &obstacles.plane_normals[p * dim..(p + 1) * dim];
    let offset = obstacles.plane_offsets[p];
    let gamma = (dim as f64 + 4.0) * epsilon;
    let mut dot = 0.0;
    let mut size = 0.0;
    let mut closing = 0.0;
    let mut closing_size = 0.0;
    for a in 0..dim {
        dot += n[a] * x[a];
        size += (n[a] * x[a]).abs();
        closing -= n[a] * delta[a];
        closing_size += (n[a] * delta[a]).abs();
    }
    let d0 = dot - offset - radius;
    let rounding = gamma * (size + offset.abs() + radius) + trial_rounding(x, delta, epsilon);
    time(d0 - rounding, closing + gamma * closing_size)
}

/// Certified time t* of simplex `s` of `obstacles` for `trial` (see the
/// module docs: the support bound of the computed offset). `offset` is
/// scratch of length `dim`.
pub fn simplex_time(
    obstacles: &BarrierObstacles,
    s: usize,
    trial: TrialMove,
    epsilon: f64,
    offset: &mut [f64],
) -> f64 {
    let TrialMove { x, radius, delta } = trial;
    let dim = x.len();
    let vertices = obstacles.simplex(s, dim);
    closest_point_on_simplex(x, vertices, dim, offset);
    let mut w_squared = 0.0;
    let mut step_squared = 0.0;
    for a in 0..dim {
        w_squared += offset[a] * offset[a];
        step_squared += delta[a] * delta[a];
    }
    let w_length = w_squared.sqrt();
    if w_length.is_nan() || w_length <= 0.0 {
        return 0.0;
    }
    let mut support = f64::INFINITY;
    let mut size: f64 = 0.0;
    for v in 0..vertices.len() / dim {
        let mut s_v = 0.0;
        let mut a_v = 0.0;
        for a in 0..dim {
            let term = offset[a] * (x[a] - vertices[v * dim + a]);
            s_v += term;
            a_v += term.abs();
        }
        support = support.min(s_v);
        size = size.max(a_v);
    }
    let gamma = (dim as f64 + 4.0) * epsilon;
    let d0 = support / w_length - radius;
    let rounding = gamma * (size / w_length + radius) + trial_rounding(x, delta, epsilon);
    time(d0 - rounding, step_squared.sqrt() * (1.0 + gamma))
}

/// The smallest certified time over every obstacle (planes, then the
/// simplices within the filter's reach: barrier.rs, the candidate box;
/// those beyond it have η t* ≥ 1) for `trial`; ∞ with none.
/// `fraction(obstacle_time(…))` is the certified replacement of
/// `barrier::filter_fraction`.
pub fn obstacle_time(obstacles: &BarrierObstacles, trial: TrialMove, epsilon: f64) -> f64 {
    let TrialMove { x, radius, delta } = trial;
    let dim = x.len();
    let mut offset = [0.0f64; crate::MAX_DIM];
    let offset = &mut offset[..dim];
    let (mut lo, mut hi) = ([0.0f64; crate::MAX_DIM], [0.0f64; crate::MAX_DIM]);
    let (lo, hi) = (&mut lo[..dim], &mut hi[..dim]);
    let length = delta.iter().map(|c| c * c).sum::<f64>().sqrt();
    let reach = filter_reach(length, dim, epsilon);
    let margin = support_margin(dim, epsilon);
    candidate_box(x, radius, reach, obstacles.scale, margin, lo, hi);
    let planes = obstacles.plane_count();
    let mut t = f64::INFINITY;
    for o in obstacles.near(lo, hi) {
        t = t.min(if o < planes {
            plane_time(obstacles, o, trial, epsilon)
        } else {
            simplex_time(obstacles, o - planes, trial, epsilon, offset)
        });
    }
    t
}
