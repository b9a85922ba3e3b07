//! Simplex-mesh contact on the XPBD path, compiled from a `simplex_mesh`
//! obstacle: one element per dynamic particle, the inequality
//!
//! ```text
//! C(x) = dist(x, M) − r ≥ 0,   dist(x, M) = min over the simplices s of M of |x − q_s(x)|
//! ∇C   = n = (x − q)/|x − q|   (q the closest point of the closest simplex)
//! ```
//! (λ ≥ 0), projected exactly as a hyperplane contact with n·x − rest
//! replaced by |x − q| − r: Δλ = (−C − α~ λ)/(w + α~), λ' = max(λ + Δλ, 0),
//! x += w n Δλ; static friction in the projection, dynamic friction as a
//! velocity response, both with this n. One constraint per particle and
//! mesh (the distance to the union, not one per simplex): a ball resting
//! on a shared edge or vertex of a flat triangulation has one contact and
//! one normal, as on the plane.
//!
//! Reach. The update moves x only when C ≤ w λ (λ the slot's multiplier
//! before the update): C ≤ 0 pushes out, 0 < C ≤ w λ pulls back what this
//! substep pushed (as the hyperplane does). A simplex that can decide the
//! update is therefore within r + w λ of x, and only simplices whose box
//! meets the candidate box x ± (r + wλ + pad) are visited, through the
//! mesh's hierarchy in index order (`barrier::candidate_box`, pad =
//! 16 N (N + 4) ε (‖x‖∞ + G + r + wλ): rounding of boxes and distances);
//! of those, `mesh_bounds.rs` drops the ones whose box alone shows they
//! can neither win nor tie (the same choice with fewer solves). The golden
//! path keeps each particle's walk between its queries
//! (`mesh_candidates.rs`, [`closest_kept`]): the same list in the same
//! order while its box stays inside a wider one walked before.
//! ```text
//! (C, n) = the smallest |x − q_s| − r over the visited s (the lowest s on a tie;
//!          within a simplex the first face in bitmask order: closest_point.rs)
//! C > w λ (or nothing visited)   → out of reach: no update (the slot keeps λ)
//! |x − q| = 0                    → no direction: no update (∇C undefined)
//! ```
//! Out of reach is the one difference from the hyperplane, which would
//! pull the particle back by w λ towards a contact it has left by more
//! than that within the substep; the mesh leaves it where it is. Visiting
//! in index order and keeping the first minimum gives the exhaustive
//! scan's choice bit for bit (every simplex within reach is visited), on
//! any thread count: a particle's update reads only its own slot.
//!
//! The mesh is unsigned (a distance, no inside): a ball whose centre
//! crosses a simplex within one substep is pushed out on the far side.
//! Substeps must keep |v| h below r, as for particle–particle contact.

use super::ProjectionReal;
use super::mesh_bounds::{BOUNDED, GATHER, deciding};
use super::mesh_candidates::Candidates;
use super::relation::Relation;
use crate::barrier::{BarrierObstacles, candidate_box, distance_margin};

pub(super) const RELATION: Relation = Relation::AtLeast;

/// C and the unit normal n (into `normal`) of the contact of a particle at
/// `x` with radius `radius` against `mesh`, for a slot whose reach is
/// `reach` = w λ (module docs); `None` out of reach or with no direction
/// (`normal` is then unspecified). The candidates are those of
/// `mesh_bounds.rs` (the same choice with fewer closest-point solves).
pub fn closest(
    mesh: &BarrierObstacles,
    x: &[f64],
    radius: f64,
    reach: f64,
    normal: &mut [f64],
) -> Option<f64> {
    closest_with(mesh, x, (radius, reach), normal, None)
}

/// [`closest`] for a particle that keeps its candidates between queries
/// in `kept` (`mesh_candidates.rs`: the same answer, bit for bit, with
/// fewer walks of the hierarchy).
pub fn closest_kept(
    mesh: &BarrierObstacles,
    x: &[f64],
    (radius, reach): (f64, f64),
    normal: &mut [f64],
    kept: &mut Candidates,
) -> Option<f64> {
    closest_with(mesh, x, (radius, reach), normal, Some(kept))
}

fn closest_with(
    mesh: &BarrierObstacles,
    x: &[f64],
    (radius, reach): (f64, f64),
    normal: &mut [f64],
    kept: Option<&mut Candidates>,
) -> Option<f64> {
    // Scratch of a few coordinates in low dimensions (no 2 KiB to clear).
    if x.len() <= 4 {
        closest_in::<4>(mesh, x, (radius, reach), normal, kept)
    } else {
        closest_in::<{ crate::MAX_DIM }>(mesh, x, (radius, reach), normal, kept)
    }
}

/// [`closest`] with scratch arrays of `D` ≥ N coordinates.
fn closest_in<const D: usize>(
    mesh: &BarrierObstacles,
    x: &[f64],
    (radius, reach): (f64, f64),
    normal: &mut [f64],
    candidates: Option<&mut Candidates>,
) -> Option<f64> {
    let dim = x.len();
    let mut lo = [0.0f64; D];
    let mut hi = [0.0f64; D];
    let mut n = [0.0f64; D];
    let mut nt = [0.0f64; D];
    let (lo, hi, n, nt) = (
        &mut lo[..dim],
        &mut hi[..dim],
        &mut n[..dim],
        &mut nt[..dim],
    );
    let margin = distance_margin(dim, f64::EPSILON);
    candidate_box(x, radius, reach, mesh.scale, margin, lo, hi);
    let largest = x.iter().fold(0.0f64, |m, c| m.max(c.abs()));
    let size = largest + mesh.scale + radius + reach;
    let mut kept = [0u32; GATHER];
    let (mut t, mut ct) = (usize::MAX, 0.0);
    let finite = x.iter().all(|c| c.is_finite());
    let bounded = finite && size < BOUNDED && mesh.plane_count() == 0 && mesh.is_indexed();
    let found = bounded.then(|| {
        let (tree, bounds) = (&mesh.hierarchy, (&*lo, &*hi));
        let gather = |out: &mut [u32; GATHER]| match candidates {
            Some(c) => c.gather(tree, bounds, out),
            None => tree.gather(lo, hi, out),
        };
        let pad = (radius, reach, margin * size);
        deciding(tree, x, pad, (&mut kept, gather), |s| {
            t = s;
            ct = mesh.distance(s, x, radius, nt);
            ct
        })
    });
    let solve = |s: usize, n: &mut [f64]| {
        if s == t {
            n.copy_from_slice(nt);
            return ct;
        }
        mesh.distance(s, x, radius, n)
    };
    match found.flatten() {
        Some(len) => first_closest(
            kept[..len].iter().map(|&s| s as usize),
            reach,
            (n, normal),
            solve,
        ),
        None => first_closest(mesh.near(lo, hi), reach, (n, normal), |o, n| {
            mesh.distance(o, x, radius, n)
        }),
    }
}

/// The first smallest C = `distance(s, n)` over the `candidates` in their
/// order, its n into `normal` (`n`: scratch); `None` when nothing was
/// visited, C > `reach` or n = 0 (module docs). One code for both
/// precisions: the f32 reference runs it on its f32 distances.
pub fn first_closest<R: ProjectionReal>(
    candidates: impl Iterator<Item = usize>,
    reach: R,
    (n, normal): (&mut [R], &mut [R]),
    mut distance: impl FnMut(usize, &mut [R]) -> R,
) -> Option<R> {
    let mut best: Option<R> = None;
    for s in candidates {
        let c = distance(s, n);
        // `!(c >= best)`: a NaN distance is kept (and fails the update).
        if best.is_none_or(|b| c < b || c.is_nan() && !b.is_nan()) {
            best = Some(c);
            normal.copy_from_slice(n);
        }
    }
    let c = best?;
    if c > reach || normal.iter().all(|&a| a == R::constant(0.0)) {
        return None;
    }
    Some(c)
}
