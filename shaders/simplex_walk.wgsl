// The ordered walk of a simplex hierarchy, shared by the barrier kernels
// and the XPBD step's mesh contact. The including module defines
// `node_word(n, k)` and `node_bound(n, k)` (the hierarchy's preorder nodes),
// `walk_planes()` (obstacle slots handed out before the simplices),
// `walk_simplices()` and `walk_scale()` (the largest |coordinate| of the
// obstacles: the rounding floor of the pad).
//
// The simplex hierarchy walk (core/src/geometry/simplex_hierarchy.rs,
// OrderedWalk; the candidate box: core/src/barrier.rs candidate_box):
// every plane, then every simplex whose box overlaps x ± (r + reach + pad),
// pad = M (‖x‖∞ + scale + r + reach) with M = 16 N (N + 4) ε where computed
// distances decide (walk_start), 4 √(N (N + 4) ε) for the certified
// filter's support bound (walk_box with support_margin), in index order: batches
// of the HIERARCHY_BATCH smallest indices ≥ floor from a stack traversal
// (preorder nodes: left child n + 1, words (right, first, last)), each
// handed out in order. The traversal costs one trip of llvmpipe's loop
// budget per node visited; the insertion's loop has a constant trip count.
const HIERARCHY_BATCH: u32 = 32u;
const HIERARCHY_STACK: u32 = 32u;
const WALK_END: u32 = 0xffffffffu;

struct Walk {
    lo: array<real, DIM>,
    hi: array<real, DIM>,
    batch: array<u32, HIERARCHY_BATCH>,
    count: u32,
    next: u32,
    floor: u32,
    more: bool,
    plane: u32,
}

// The walk where computed distances decide (evaluation, step filter).
fn walk_start(p: ptr<function, array<real, DIM>>, r: real, reach: real) -> Walk {
    return walk_box(p, r, reach, 16.0 * real(DIM) * (real(DIM) + 4.0) * REAL_EPS);
}

fn walk_box(p: ptr<function, array<real, DIM>>, r: real, reach: real, margin: real) -> Walk {
    var w: Walk;
    var largest: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        largest = max(largest, abs((*p)[a]));
    }
    let extent = r + reach;
    let half = extent + margin * (largest + walk_scale() + extent);
    var finite = half <= REAL_MAX;
    for (var a = 0u; a < DIM; a++) {
        w.lo[a] = (*p)[a] - half;
        w.hi[a] = (*p)[a] + half;
        finite = finite && abs(w.lo[a]) <= REAL_MAX && abs(w.hi[a]) <= REAL_MAX;
    }
    if (!finite) {
        for (var a = 0u; a < DIM; a++) {
            w.lo[a] = -REAL_MAX;
            w.hi[a] = REAL_MAX;
        }
    }
    w.count = 0u;
    w.next = 0u;
    w.floor = 0u;
    w.more = walk_simplices() > 0u;
    w.plane = 0u;
    return w;
}

// Sorted insertion of s into the batch (absent from it, and below its
// largest when full), shifting larger entries up.
fn walk_insert(w: ptr<function, Walk>, s: u32) {
    let top = min((*w).count, HIERARCHY_BATCH - 1u);
    var at = top;
    for (var j = 1u; j < HIERARCHY_BATCH; j++) {
        let k = HIERARCHY_BATCH - j;
        if (k == at && (*w).batch[k - 1u] > s) {
            (*w).batch[k] = (*w).batch[k - 1u];
            at = k - 1u;
        }
    }
    (*w).batch[at] = s;
    (*w).count = min((*w).count + 1u, HIERARCHY_BATCH);
}

// The HIERARCHY_BATCH smallest overlapping simplices ≥ floor, sorted.
fn walk_refill(w: ptr<function, Walk>) {
    (*w).count = 0u;
    (*w).next = 0u;
    var stack: array<u32, HIERARCHY_STACK>;
    stack[0] = 0u;
    var depth = 1u;
    while (depth > 0u) {
        depth--;
        let n = stack[depth];
        let first = node_word(n, 1u);
        let last = node_word(n, 2u);
        if (last < (*w).floor || ((*w).count == HIERARCHY_BATCH && first > (*w).batch[HIERARCHY_BATCH - 1u])) {
            continue;
        }
        var hit = true;
        for (var a = 0u; a < DIM; a++) {
            if (!(node_bound(n, a) <= (*w).hi[a] && (*w).lo[a] <= node_bound(n, DIM + a))) {
                hit = false;
            }
        }
        if (!hit) {
            continue;
        }
        if (first == last) {
            walk_insert(w, first);
        } else if (depth + 2u <= HIERARCHY_STACK) { // always: depth + 1 ≤ 32 (< 2^31 simplices)
            stack[depth] = node_word(n, 0u);
            stack[depth + 1u] = n + 1u;
            depth += 2u;
        }
    }
    (*w).more = (*w).count == HIERARCHY_BATCH;
    if ((*w).more) {
        (*w).floor = (*w).batch[HIERARCHY_BATCH - 1u] + 1u;
    }
}

// The next obstacle slot of the walk (planes first), WALK_END after the last.
fn walk_next(w: ptr<function, Walk>) -> u32 {
    if ((*w).plane < walk_planes()) {
        (*w).plane++;
        return (*w).plane - 1u;
    }
    if ((*w).next == (*w).count) {
        if (!(*w).more) {
            return WALK_END;
        }
        walk_refill(w);
        if ((*w).count == 0u) {
            return WALK_END;
        }
    }
    (*w).next++;
    return walk_planes() + (*w).batch[(*w).next - 1u];
}

