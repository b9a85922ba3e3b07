//! A static bounding-volume hierarchy over the boxes of a simplex mesh
//! (k-simplices in R^N, any k ≤ N), built once, and its box queries.
//!
//! ```text
//! box_s   = [min_j v_j, max_j v_j] per axis (the simplex's vertices; exact)
//! build   node over simplices S (|S| ≥ 1):
//!           |S| = 1  → leaf
//!           else     axis = longest edge of the bounds of the box centres c_s
//!                           (the lowest axis on a tie),
//!                    sort S by (c_s[axis], s) (total order: ties by index),
//!                    left = first ⌈|S|/2⌉, right = the rest          (median split)
//!         depth ≤ ⌈log2 |S|⌉, 2|S| − 1 nodes; node box = union of its children's
//! layout  preorder: the left child of node i is i + 1; words (right, first, last)
//!         per node, first/last the smallest/largest simplex index below it
//!         (a leaf: first = last = its simplex); boxes (lo[N], hi[N]) per node
//! overlap [a, b] ∩ [lo, hi] ≠ ∅ ⇔ for every axis lo ≤ b and a ≤ hi (closed)
//! query(q) = { s : box_s overlaps q } sorted by s
//!          = the exhaustive scan of the simplices in index order, filtered by overlap
//! ```
//! A subtree is skipped only when its box (which contains every box below
//! it) misses q, so no overlapping simplex is lost; the answer is sorted,
//! so candidate identity and order are exactly the exhaustive ones.
//! Non-finite coordinates are ordered by `f64::total_cmp` in the build and
//! fail every overlap test (NaN).
//!
//! [`OrderedWalk`] delivers the same list without allocating, as the GPU
//! kernels do (`shaders/barrier.wgsl`, `hierarchy_refill`): it fills a
//! batch with the K smallest overlapping indices ≥ `floor` (a sorted
//! insertion; subtrees whose `last` < floor, or whose `first` exceeds a
//! full batch's largest, are skipped), hands them out in order, then sets
//! floor = that largest + 1 and refills, until a refill finds fewer than K.
//! Every batch holds the smallest K remaining, so the concatenation is the
//! sorted list. Traversal: an explicit stack, right child pushed before
//! the left; at most depth + 1 ≤ 32 entries (fewer than 2^31 simplices).
//!
//! [`SimplexHierarchy::gather`] is the same traversal in one pass, for a
//! caller that restores the order itself: the query's set in walk order
//! into a fixed slice, or `None` when it holds more than the slice.

/// Simplices per walk batch (`HIERARCHY_BATCH` in `shaders/barrier.wgsl`).
pub const WALK_BATCH: usize = 32;
/// Entries of the traversal stack (depth + 1 for fewer than 2^31 simplices).
pub const WALK_STACK: usize = 32;
/// Words per node in [`SimplexHierarchy::node_words`]: right child, first
/// and last simplex index below the node.
pub const NODE_WORDS: usize = 3;

/// The hierarchy: nodes in preorder, their words and boxes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SimplexHierarchy {
    dim: usize,
    /// (right, first, last) per node.
    words: Vec<u32>,
    /// (`lo[dim]`, `hi[dim]`) per node.
    boxes: Vec<f64>,
    /// The leaf node of each simplex.
    leaf: Vec<u32>,
}

impl SimplexHierarchy {
    /// The hierarchy of one authored mesh (`vertices` each of length `dim`,
    /// `simplices` vertex indices, each index < `vertices.len()`).
    pub fn build(dim: usize, vertices: &[Vec<f64>], simplices: &[Vec<usize>]) -> Self {
        let mut boxes = Vec::with_capacity(simplices.len() * 2 * dim);
        for simplex in simplices {
            let points: Vec<f64> = simplex
                .iter()
                .flat_map(|&v| vertices[v].iter().copied())
                .collect();
            push_box(&mut boxes, &points, dim);
        }
        Self::from_boxes(dim, &boxes)
    }

    /// The hierarchy of the boxes `boxes` (`lo[dim]`, `hi[dim]` per simplex).
    /// Panics with 2^31 simplices or more (u32 indices, bounded stack).
    pub fn from_boxes(dim: usize, boxes: &[f64]) -> Self {
        let count = if dim == 0 { 0 } else { boxes.len() / (2 * dim) };
        assert!(
            count < 1 << 31,
            "{count} simplices: at most 2^31 − 1 per hierarchy"
        );
        let mut tree = SimplexHierarchy {
            dim,
            words: Vec::with_capacity(NODE_WORDS * (2 * count).saturating_sub(1)),
            boxes: Vec::with_capacity(2 * dim * (2 * count).saturating_sub(1)),
            leaf: vec![0; count],
        };
        if count == 0 {
            return tree;
        }
        let centres: Vec<f64> = (0..count)
            .flat_map(|s| {
                let b = &boxes[s * 2 * dim..(s + 1) * 2 * dim];
                (0..dim).map(move |a| 0.5 * b[a] + 0.5 * b[dim + a])
            })
            .collect();
        let mut order: Vec<u32> = (0..count as u32).collect();
        tree.node(&mut order, boxes, &centres);
        tree
    }

    /// Appends the subtree over `set` in preorder; returns its node index.
    fn node(&mut self, set: &mut [u32], boxes: &[f64], centres: &[f64]) -> u32 {
        let dim = self.dim;
        let index = (self.words.len() / NODE_WORDS) as u32;
        let first = *set.iter().min().unwrap_or(&0);
        let last = *set.iter().max().unwrap_or(&0);
        self.words.extend([0, first, last]);
        let at = self.boxes.len();
        self.boxes.resize(at + 2 * dim, 0.0);
        if let [s] = set {
            let b = &boxes[*s as usize * 2 * dim..(*s as usize + 1) * 2 * dim];
            self.boxes[at..at + 2 * dim].copy_from_slice(b);
            self.leaf[*s as usize] = index;
            return index;
        }
        let mut axis = 0;
        let mut longest = f64::NEG_INFINITY;
        for a in 0..dim {
            let (lo, hi) = set
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &s| {
                    let c = centres[s as usize * dim + a];
                    (lo.min(c), hi.max(c))
                });
            if hi - lo > longest {
                longest = hi - lo;
                axis = a;
            }
        }
        // The ⌈|S|/2⌉ smallest by (centre, index), a total order: the
        // halves are the same sets whatever order `set` arrived in.
        let half = set.len().div_ceil(2);
        set.select_nth_unstable_by(half - 1, |&s, &t| {
            let (cs, ct) = (
                centres[s as usize * dim + axis],
                centres[t as usize * dim + axis],
            );
            cs.total_cmp(&ct).then(s.cmp(&t))
        });
        let (left, right) = set.split_at_mut(half);
        let l = self.node(left, boxes, centres);
        let r = self.node(right, boxes, centres);
        self.words[index as usize * NODE_WORDS] = r;
        for a in 0..dim {
            let (lb, rb) = (self.node_box(l), self.node_box(r));
            let lo = lb[a].min(rb[a]);
            let hi = lb[dim + a].max(rb[dim + a]);
            self.boxes[at + a] = lo;
            self.boxes[at + dim + a] = hi;
        }
        index
    }

    /// The same tree over moved boxes (one per simplex, as for
    /// [`SimplexHierarchy::from_boxes`]): leaves take the new boxes and
    /// every node the union of its children's. The topology (and so the
    /// work of a query) is the old one; the answers are exact for the new boxes.
    pub fn refit(&self, boxes: &[f64]) -> Self {
        let dim = self.dim;
        let mut out = self.clone();
        for (s, &node) in self.leaf.iter().enumerate() {
            let n = node as usize;
            out.boxes[n * 2 * dim..(n + 1) * 2 * dim]
                .copy_from_slice(&boxes[s * 2 * dim..(s + 1) * 2 * dim]);
        }
        // Children follow their parent in preorder: a reverse sweep sees
        // both children of a node before the node.
        for n in (0..self.node_count()).rev() {
            if self.is_leaf(n) {
                continue;
            }
            let (l, r) = (n + 1, self.words[n * NODE_WORDS] as usize);
            for a in 0..dim {
                let lo = out.boxes[l * 2 * dim + a].min(out.boxes[r * 2 * dim + a]);
                let hi = out.boxes[l * 2 * dim + dim + a].max(out.boxes[r * 2 * dim + dim + a]);
                out.boxes[n * 2 * dim + a] = lo;
                out.boxes[n * 2 * dim + dim + a] = hi;
            }
        }
        out
    }

    /// Dimension N.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Simplices indexed.
    pub fn simplex_count(&self) -> usize {
        self.leaf.len()
    }

    /// Nodes (2 · simplices − 1, or 0).
    pub fn node_count(&self) -> usize {
        self.words.len() / NODE_WORDS
    }

    /// The flattened node words, [`NODE_WORDS`] per node in preorder:
    /// (right child, first simplex, last simplex); the left child of an
    /// inner node i is i + 1; a leaf has first = last (its simplex).
    pub fn node_words(&self) -> &[u32] {
        &self.words
    }

    /// The node boxes, (`lo[dim]`, `hi[dim]`) per node in preorder.
    pub fn node_boxes(&self) -> &[f64] {
        &self.boxes
    }

    /// The box of simplex `s` (`lo[dim]`, `hi[dim]`).
    pub fn simplex_box(&self, s: usize) -> &[f64] {
        self.node_box(self.leaf[s])
    }

    fn node_box(&self, n: u32) -> &[f64] {
        let d2 = 2 * self.dim;
        &self.boxes[n as usize * d2..(n as usize + 1) * d2]
    }

    fn is_leaf(&self, n: usize) -> bool {
        self.words[n * NODE_WORDS + 1] == self.words[n * NODE_WORDS + 2]
    }

    /// The candidates of the box `[lo, hi]`: every simplex whose box
    /// overlaps it, sorted by index, into `out` (cleared first). Returns
    /// the nodes visited (the work; an operation count, not a result).
    pub fn query(&self, lo: &[f64], hi: &[f64], out: &mut Vec<u32>) -> usize {
        out.clear();
        let mut visited = 0;
        let mut stack = Vec::with_capacity(WALK_STACK);
        if self.node_count() > 0 {
            stack.push(0usize);
        }
        while let Some(n) = stack.pop() {
            visited += 1;
            if !overlaps(self.node_box(n as u32), lo, hi) {
                continue;
            }
            if self.is_leaf(n) {
                out.push(self.words[n * NODE_WORDS + 1]);
            } else {
                stack.push(self.words[n * NODE_WORDS] as usize);
                stack.push(n + 1);
            }
        }
        out.sort_unstable();
        visited
    }

    /// The candidates of the box `[lo, hi]` (the set of
    /// [`SimplexHierarchy::query`]) in walk order, not sorted, into `out`:
    /// their count, or `None` when there are more than `out.len()`.
    pub fn gather(&self, lo: &[f64], hi: &[f64], out: &mut [u32]) -> Option<usize> {
        // The same walk with N a constant in R^2–R^4 (unrolled box tests).
        match lo.len() {
            2 => self.gather_in(&lo[..2], &hi[..2], out),
            3 => self.gather_in(&lo[..3], &hi[..3], out),
            4 => self.gather_in(&lo[..4], &hi[..4], out),
            _ => self.gather_in(lo, hi, out),
        }
    }

    #[inline(always)]
    fn gather_in(&self, lo: &[f64], hi: &[f64], out: &mut [u32]) -> Option<usize> {
        let d2 = 2 * lo.len();
        debug_assert_eq!(lo.len(), self.dim);
        let meets = |n: usize| overlaps(&self.boxes[n * d2..(n + 1) * d2], lo, hi);
        let mut count = 0;
        let mut stack = [0u32; WALK_STACK];
        // Only nodes whose boxes meet the query are pushed (each tested as
        // its parent is expanded): the same nodes in the same order as
        // testing them when popped, without the pushes and pops of those
        // that miss.
        let mut depth = usize::from(self.node_count() > 0 && meets(0));
        while depth > 0 {
            depth -= 1;
            let n = stack[depth] as usize;
            let w = &self.words[n * NODE_WORDS..(n + 1) * NODE_WORDS];
            if w[1] == w[2] {
                *out.get_mut(count)? = w[1];
                count += 1;
            } else {
                // depth + 2 ≤ WALK_STACK: see the module docs. The right
                // child is pushed first, so the left one is taken first.
                let (right, left) = (w[0], n as u32 + 1);
                if meets(right as usize) {
                    stack[depth] = right;
                    depth += 1;
                }
                if meets(left as usize) {
                    stack[depth] = left;
                    depth += 1;
                }
            }
        }
        Some(count)
    }

    /// The oracle: every simplex in index order whose box overlaps
    /// `[lo, hi]` (a scan of all of them).
    pub fn exhaustive(&self, lo: &[f64], hi: &[f64], out: &mut Vec<u32>) {
        out.clear();
        for s in 0..self.simplex_count() {
            if overlaps(self.simplex_box(s), lo, hi) {
                out.push(s as u32);
            }
        }
    }

    /// The candidates of `[lo, hi]` one at a time, in index order,
    /// without allocating (see the module docs).
    pub fn walk<'a>(&'a self, lo: &'a [f64], hi: &'a [f64]) -> OrderedWalk<'a, WALK_BATCH> {
        OrderedWalk::new(self, lo, hi)
    }
}

/// The box (lo, hi) of the points `points` (flat, `dim` per point) appended
/// to `out`.
pub fn push_box(out: &mut Vec<f64>, points: &[f64], dim: usize) {
    let at = out.len();
    out.extend(std::iter::repeat_n(f64::INFINITY, dim));
    out.extend(std::iter::repeat_n(f64::NEG_INFINITY, dim));
    for p in points.chunks_exact(dim) {
        for a in 0..dim {
            out[at + a] = out[at + a].min(p[a]);
            out[at + dim + a] = out[at + dim + a].max(p[a]);
        }
    }
}

/// Closed-box overlap of `b` = (`lo[N]`, `hi[N]`) with `[lo, hi]`.
#[inline(always)]
pub fn overlaps(b: &[f64], lo: &[f64], hi: &[f64]) -> bool {
    let dim = lo.len();
    (0..dim).all(|a| b[a] <= hi[a] && lo[a] <= b[dim + a])
}

/// The ordered, allocation-free query of [`SimplexHierarchy::walk`], in
/// batches of `K` (the GPU's schedule).
#[derive(Debug, Clone)]
pub struct OrderedWalk<'a, const K: usize> {
    tree: &'a SimplexHierarchy,
    lo: &'a [f64],
    hi: &'a [f64],
    batch: [u32; K],
    count: usize,
    next: usize,
    floor: u32,
    more: bool,
    /// Nodes visited so far (the work).
    pub visited: usize,
}

impl<'a, const K: usize> OrderedWalk<'a, K> {
    /// A walk over the candidates of `[lo, hi]`.
    pub fn new(tree: &'a SimplexHierarchy, lo: &'a [f64], hi: &'a [f64]) -> Self {
        OrderedWalk {
            tree,
            lo,
            hi,
            batch: [0; K],
            count: 0,
            next: 0,
            floor: 0,
            more: tree.node_count() > 0,
            visited: 0,
        }
    }

    /// The K smallest candidates ≥ floor into the batch, sorted.
    fn refill(&mut self) {
        let tree = self.tree;
        self.count = 0;
        self.next = 0;
        let mut stack = [0u32; WALK_STACK];
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            let n = stack[depth] as usize;
            self.visited += 1;
            let w = &tree.words[n * NODE_WORDS..(n + 1) * NODE_WORDS];
            if w[2] < self.floor || (self.count == K && w[1] > self.batch[K - 1]) {
                continue;
            }
            if !overlaps(tree.node_box(n as u32), self.lo, self.hi) {
                continue;
            }
            if w[1] == w[2] {
                self.insert(w[1]);
            } else {
                // depth + 2 ≤ WALK_STACK: see the module docs.
                stack[depth] = w[0];
                stack[depth + 1] = n as u32 + 1;
                depth += 2;
            }
        }
        self.more = self.count == K;
        if self.more {
            self.floor = self.batch[K - 1] + 1;
        }
    }

    /// Sorted insertion of `s` (absent from the batch, and below its
    /// largest when full: the refill's pruning guarantees both).
    fn insert(&mut self, s: u32) {
        let mut at = self.count.min(K - 1);
        while at > 0 && self.batch[at - 1] > s {
            self.batch[at] = self.batch[at - 1];
            at -= 1;
        }
        self.batch[at] = s;
        self.count = (self.count + 1).min(K);
    }
}

impl<const K: usize> Iterator for OrderedWalk<'_, K> {
    type Item = u32;

    fn next(&mut self) -> Option<u32> {
        if self.next == self.count {
            if !self.more {
                return None;
            }
            self.refill();
            if self.count == 0 {
                return None;
            }
        }
        self.next += 1;
        Some(self.batch[self.next - 1])
    }
}
