//! The candidates that can decide a mesh contact (`mesh_contact.rs`'s
//! `closest`), found with box bounds: a shorter list with the same first
//! smallest C, bit for bit.
//!
//! ```text
//! A     the simplices whose boxes meet the candidate box, in index order
//! R(A)  first_closest over A: the first smallest computed Ĉ_s, kept when ≤ reach
//! D̂_s   |x − clamp(x, box_s)|, computed (x's distance to the box of s)
//! t     a candidate of A with the smallest D̂ (the first in walk order); Ĉ_t solved
//! T     min(Ĉ_t, reach) + r + pad      (pad = M (‖x‖∞ + G + r + reach), candidate_box's)
//! K     {t} ∪ {s ∈ A : not D̂_s > T}, in index order        R(K) = R(A) bit for bit
//!       (K = ∅ without solving t when every D̂_s > reach + r + pad)
//! ```
//! A dropped s has Ĉ_s > min(Ĉ_t, reach):
//! ```text
//! Ĉ_s ≥ dist(x, s) − r − e         e  ≤ a few N ε (‖x‖∞ + G): q̂ is a point of s
//!                                      up to rounding (barrier.rs)
//! dist(x, s) ≥ dist(x, box_s) ≥ D̂_s − e'    e' ≤ (N + 4) √N ε (‖x‖∞ + G)  (D̂ ≤ √N (‖x‖∞ + G))
//! T is computed within e'' ≤ 2 ε (|Ĉ_t| + r + pad)
//! e + e' + e'' < pad (M = 16 N (N + 4) ε)  ⇒  D̂_s > T gives Ĉ_s > min(Ĉ_t, reach)
//!                                              (and D̂_s > reach + r + pad gives Ĉ_s > reach)
//! ```
//! If the first smallest s* of A has Ĉ_s* ≤ reach, then Ĉ_s* ≤ Ĉ_t (t ∈ A)
//! and Ĉ_s* ≤ reach, so s* ∈ K; K ⊆ A, so s* is also K's first smallest,
//! with the same n. Otherwise every Ĉ over A exceeds reach, and so every
//! Ĉ over K ∋ t: no update either way (the normal is then not read). The
//! bounds hold only where nothing overflows: with x finite and ‖x‖∞ + G +
//! r + reach < 10^100 every computed distance is finite (a NaN, which first_closest
//! would keep, cannot occur); beyond that, with more than [`GATHER`]
//! candidates, or with a set not indexed, the caller scans A whole.

use crate::geometry::SimplexHierarchy;

/// Candidates gathered at most (more: the caller scans them all).
pub const GATHER: usize = 32;

/// Largest ‖x‖∞ + G + r + reach the bounds are used for (module docs).
pub const BOUNDED: f64 = 1e100;

/// K (module docs) into `kept`, in index order, and its length, for the
/// particle at `x` with radius `radius`, `reach` and `pad`; `gather`
/// writes A (the simplices whose boxes meet the candidate box, in walk
/// order) into `kept` and returns its length, `None` when A holds more
/// than [`GATHER`] simplices (then so does this). `solve(t)` returns Ĉ_t
/// (once, for t in K).
pub fn deciding(
    tree: &SimplexHierarchy,
    x: &[f64],
    (radius, reach, pad): (f64, f64, f64),
    (kept, gather): (
        &mut [u32; GATHER],
        impl FnOnce(&mut [u32; GATHER]) -> Option<usize>,
    ),
    solve: impl FnOnce(usize) -> f64,
) -> Option<usize> {
    let dim = x.len();
    let count = gather(kept)?;
    if count == 0 {
        return Some(0);
    }
    let mut bound = [0.0f64; GATHER];
    let mut nearest = 0;
    for (k, &s) in kept[..count].iter().enumerate() {
        let b = tree.simplex_box(s as usize);
        let mut squared = 0.0;
        for a in 0..dim {
            let gap = (b[a] - x[a]).max(x[a] - b[dim + a]).max(0.0);
            squared += gap * gap;
        }
        bound[k] = squared.sqrt();
        if bound[k] < bound[nearest] {
            nearest = k;
        }
    }
    if bound[nearest] > reach + radius + pad {
        // Every Ĉ_s > reach: no update, and nothing to solve.
        return Some(0);
    }
    let t = kept[nearest];
    let threshold = solve(t as usize).min(reach) + radius + pad;
    let mut len = 0;
    for k in 0..count {
        let s = kept[k];
        if s == t || bound[k] <= threshold {
            // Sorted insertion: K in index order.
            let mut at = len;
            while at > 0 && kept[at - 1] > s {
                kept[at] = kept[at - 1];
                at -= 1;
            }
            kept[at] = s;
            len += 1;
        }
    }
    Some(len)
}
