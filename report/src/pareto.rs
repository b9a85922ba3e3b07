//! Pareto frontiers and "what does it take to reach ε" answers.
//!
//! ```text
//! frontier of one backend: the points no other point of that backend
//!   beats in both time and error —
//!   sort by time (ties: smaller error first); keep a point iff its error
//!   is below every error kept before it
//! frozen points (nothing moves: f32 at tiny h) are never on a frontier
//!   and never answer a headline
//! cheapest(ε): the fastest measured point with error ≤ ε (a measured
//!   configuration, never an interpolation between two)
//! ```

use crate::point::Point;
use hyperpbd::BackendKind;

/// The undominated candidates among `(index, time, error)`, fastest
/// first: sorted by time (ties: smaller error first), a candidate is kept
/// iff its error is below every error kept before it. Candidates with a
/// non-finite time or error are never kept.
pub fn undominated(candidates: impl IntoIterator<Item = (usize, f64, f64)>) -> Vec<usize> {
    let mut order: Vec<(usize, f64, f64)> = candidates
        .into_iter()
        .filter(|&(_, t, e)| t.is_finite() && e.is_finite())
        .collect();
    order.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.2.total_cmp(&b.2)));
    let mut best = f64::INFINITY;
    let mut kept = Vec::new();
    for (i, _, e) in order {
        if e < best {
            best = e;
            kept.push(i);
        }
    }
    kept
}

/// Indices of the frontier points among `points` of `backend`, fastest
/// first. Points without a finite error are never on it.
pub fn frontier(points: &[Point], backend: BackendKind) -> Vec<usize> {
    undominated(
        points
            .iter()
            .enumerate()
            .filter(|(_, p)| p.backend == backend && !p.frozen)
            .map(|(i, p)| (i, p.ms_per_sim_second, p.error.unwrap_or(f64::NAN))),
    )
}

/// Marks `frontier` on every point, backend by backend.
pub fn mark_frontiers(points: &mut [Point]) {
    for p in points.iter_mut() {
        p.frontier = false;
    }
    for backend in BackendKind::ALL {
        for i in frontier(points, backend) {
            points[i].frontier = true;
        }
    }
}

/// The fastest point of `backend` with error ≤ `target`.
pub fn cheapest(points: &[Point], backend: BackendKind, target: f64) -> Option<&Point> {
    points
        .iter()
        .filter(|p| p.backend == backend && !p.frozen && p.error.is_some_and(|e| e <= target))
        .min_by(|a, b| a.ms_per_sim_second.total_cmp(&b.ms_per_sim_second))
}

/// The point of `backend` with the smallest error.
pub fn most_accurate(points: &[Point], backend: BackendKind) -> Option<&Point> {
    points
        .iter()
        .filter(|p| p.backend == backend && !p.frozen && p.error.is_some_and(f64::is_finite))
        .min_by(|a, b| {
            a.error
                .unwrap_or(f64::INFINITY)
                .total_cmp(&b.error.unwrap_or(f64::INFINITY))
        })
}
