//! A particle's mesh candidates kept between its queries: the hierarchy
//! walk of `mesh_contact.rs`'s `closest` done once for a larger box and
//! reused while the query box stays inside it.
//!
//! ```text
//! query box Q = [lo, hi];  kept: box K ⊇ Q, list L_K = the walk of K (simplices whose
//!                          boxes meet K, in walk order)
//! Q ⊆ K (every axis: K.lo ≤ lo, hi ≤ K.hi)  → A = L_K filtered by "box_s meets Q", in order
//! otherwise                                 → K = Q widened by its half-width on every axis,
//!                                             L_K walked anew; more than GATHER there:
//!                                             K = Q (its own walk; more there too: None)
//! ```
//! Why A is the walk of Q, in its order: a simplex whose box meets Q meets
//! K ⊇ Q (the test compares the same stored numbers), so it is in L_K;
//! the walk visits leaves in one fixed order (preorder of the tree, left
//! before right) and only skips subtrees whose boxes miss the box, so the
//! walk of Q is the subsequence of that order of the leaves meeting Q —
//! the filter of L_K. The choice `mesh_bounds.rs` makes from A (its first
//! smallest box distance in walk order) is therefore the same, and so is
//! every bit of the contact. A resting or slowly moving particle walks
//! the tree once in many substeps instead of three times in each.

use crate::geometry::SimplexHierarchy;
use crate::geometry::simplex_hierarchy::overlaps;

/// Candidates a query holds at most (more: the caller walks the whole box).
pub use super::mesh_bounds::GATHER;

/// Dimensions up to which a particle keeps candidates (above: every
/// query walks the tree).
pub const KEPT_UP_TO: usize = 4;

/// One particle's kept box and list (a slot per element of a mesh
/// family, [`Candidates::EMPTY`] before its first query).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidates {
    /// Entries of `list` in use; `u32::MAX`: nothing kept.
    count: u32,
    list: [u32; GATHER],
    lo: [f64; KEPT_UP_TO],
    hi: [f64; KEPT_UP_TO],
}

impl Candidates {
    /// Nothing kept.
    pub const EMPTY: Candidates = Candidates {
        count: u32::MAX,
        list: [0; GATHER],
        lo: [0.0; KEPT_UP_TO],
        hi: [0.0; KEPT_UP_TO],
    };

    /// The simplices of `tree` whose boxes meet `[lo, hi]`, in walk order,
    /// into `out`: their count, or `None` when there are more than
    /// [`GATHER`] (as [`SimplexHierarchy::gather`], whose answer it is).
    pub fn gather(
        &mut self,
        tree: &SimplexHierarchy,
        (lo, hi): (&[f64], &[f64]),
        out: &mut [u32; GATHER],
    ) -> Option<usize> {
        let dim = lo.len();
        if dim > KEPT_UP_TO {
            return tree.gather(lo, hi, out);
        }
        let inside = (0..dim).all(|a| self.lo[a] <= lo[a] && hi[a] <= self.hi[a]);
        if self.count == u32::MAX || !inside {
            for a in 0..dim {
                let half = 0.5 * (hi[a] - lo[a]);
                self.lo[a] = lo[a] - half;
                self.hi[a] = hi[a] + half;
            }
            let widened = (0..dim).all(|a| self.lo[a] <= lo[a] && hi[a] <= self.hi[a]);
            let kept = tree.gather(&self.lo[..dim], &self.hi[..dim], &mut self.list);
            if let (true, Some(count)) = (widened, kept) {
                self.count = count as u32;
            } else {
                // More than GATHER in the widened box (or a box that did
                // not widen): keep the box's own walk, one walk either way.
                self.lo[..dim].copy_from_slice(lo);
                self.hi[..dim].copy_from_slice(hi);
                let count = tree.gather(lo, hi, &mut self.list);
                self.count = count.map_or(u32::MAX, |c| c as u32);
                count?;
            }
        }
        let mut count = 0;
        for &s in &self.list[..self.count as usize] {
            if overlaps(tree.simplex_box(s as usize), lo, hi) {
                out[count] = s;
                count += 1;
            }
        }
        Some(count)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A particle wandering over a random triangle soup in R^2–R^4 (and a
    /// 5D one, which keeps nothing), its box growing and shrinking, one
    /// slot kept over all its queries: every answer is the walk's, in the
    /// walk's order, and the kept list is used (not every query walks).
    #[test]
    fn kept_candidates_are_the_walk_in_its_order() {
        let mut rng = crate::expr::tests::random::Rng(0x2545_f491_4f6c_dd1d);
        let mut next = || rng.uniform(0.0, 1.0);
        for dim in 2..=5 {
            // 600 small triangles (edges ≲ 0.3) scattered over [0, 4]^N.
            let mut vertices: Vec<Vec<f64>> = Vec::new();
            for _ in 0..600 {
                let base: Vec<f64> = (0..dim).map(|_| 4.0 * next()).collect();
                for _ in 0..3 {
                    vertices.push(base.iter().map(|c| c + 0.3 * next()).collect());
                }
            }
            let simplices: Vec<Vec<usize>> = (0..600)
                .map(|k| vec![3 * k, 3 * k + 1, 3 * k + 2])
                .collect();
            let tree = SimplexHierarchy::build(dim, &vertices, &simplices);
            let mut kept = Candidates::EMPTY;
            let mut x: Vec<f64> = (0..dim).map(|_| 4.0 * next()).collect();
            let (mut hits, mut walks) = (0, 0);
            for query in 0..2000 {
                for c in &mut x {
                    *c += 0.05 * (next() - 0.5);
                }
                let half = 0.1 + if query % 97 == 0 { 3.0 } else { 0.2 * next() };
                let lo: Vec<f64> = x.iter().map(|c| c - half).collect();
                let hi: Vec<f64> = x.iter().map(|c| c + half).collect();
                let before = kept;
                let (mut got, mut walked) = ([0u32; GATHER], [0u32; GATHER]);
                let answer = kept.gather(&tree, (&lo, &hi), &mut got);
                let expected = tree.gather(&lo, &hi, &mut walked);
                assert_eq!(answer, expected, "dim {dim}, query {query}");
                if let Some(count) = answer {
                    assert_eq!(got[..count], walked[..count], "dim {dim}, query {query}");
                }
                if dim <= KEPT_UP_TO && before.count != u32::MAX && before == kept {
                    hits += 1;
                } else {
                    walks += 1;
                }
            }
            if dim <= KEPT_UP_TO {
                assert!(hits > walks, "dim {dim}: {hits} kept, {walks} walked");
            }
        }
    }
}
