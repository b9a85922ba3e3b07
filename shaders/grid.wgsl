// Broadphase on a hashed uniform grid: every particle's contact list, the
// particles whose boxes overlap its own, in ascending index order.
//
//   boxes_and_bounds  box i = [min(p_i, x_i) − pad_i, max(p_i, x_i) + pad_i]
//                     (or the boxes given); per-thread partial bounds; clears
//                     the bucket counters
//   grid_frame        grid axes g (up to 3: widest spread first) and per axis
//                     o_g = min over boxes of lo, s_g (cells as wide as the widest box)
//   bin_count         home cell of box i: c_g(i) = cell_g(lo_i[g]); the most
//                     cells any box spans: K_g = max (cell_g(hi_i[g]) − c_g(i));
//                     bucket = hash(c(i)) mod buckets; count it
//   (scan.wgsl)       exclusive prefix of the bucket counts
//   bin_fill          box i → the next slot of its bucket (its two records
//                     copied there: candidates are read in bucket order)
//   neighbours        particle i: every box j ≠ i in the buckets of the cells
//                     c ∈ Π_g [c_g(i) − K_g, cell_g(hi_i[g])] whose box overlaps
//                     (closed intervals, every axis); sort the list ascending
//                     (in registers up to LOCAL entries) and drop repeats (two
//                     cells of one bucket)
//
// cell_g(v) = ⌊(v/2 − o_g/2) · s_g⌋ clamped to [0, 2 · CELLS_MAX] is monotone
// in v, whatever the rounding. If boxes i and j overlap, lo_j ≤ hi_i gives
// c_g(j) ≤ cell_g(hi_i), and lo_i ≤ hi_j gives c_g(i) ≤ cell_g(hi_j) ≤
// c_g(j) + K_g: j's home cell is in i's query range, its bucket is visited
// and the exact test decides. So each list holds exactly the overlapping
// boxes — the exhaustive reference's pairs of i — in ascending order,
// whatever order the bucket slots were filled in (integer atomics; the
// order inside a bucket depends on scheduling, the sorted lists do not).
// K_g is measured, not assumed: cells as wide as the widest box make it 1
// (2 where rounding moves a corner across a cell edge); the grid's scale
// only changes how many boxes are tested, never which pairs come out.
//
// f32: box corners are rounded outward by one ulp, so the device box holds
// the box of the f32 values (the pad is rounded up on the host); f64: the
// golden path's arithmetic exactly.
//
// A batch runs every world's grid in the same dispatches (contact.wgsl):
// BOUND_THREADS invocations and one grid_frame workgroup per world, each
// world its own frame, spans and buckets.

const CELLS_MAX: real = 262144.0; // 2^18 cells per grid axis at most
const CELL_FACTOR: real = 1.0;    // cell edge / widest box edge
const LOCAL: u32 = 32u;           // list entries kept in registers
const GRID: u32 = min(DIM, 3u);

// ---- boxes

// The f32 value just below f (f finite; never a denormal).
fn below_f32(f: f32) -> f32 {
    let bits = bitcast<u32>(f);
    if (f > 0.0) {
        return bitcast<f32>(bits - 1u);
    }
    if (f == 0.0) {
        return -1.1754943508222875e-38;
    }
    return bitcast<f32>(bits + 1u);
}

fn outward_down(v: real) -> real {
    if (REAL_IS_F32) {
        return real(below_f32(f32(v)));
    }
    return v;
}

fn outward_up(v: real) -> real {
    if (REAL_IS_F32) {
        return -real(below_f32(-f32(v)));
    }
    return v;
}

// The swept box of particle i over the substep, as the golden path builds
// it, with the index and the inverse mass in the records' extra lanes.
fn build_box(i: u32) {
    let own = props[particle(i)];
    var start = load_p(i);
    var end = load_x(i);
    var lo: array<real, DIM>;
    var hi: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        let s = lane(&start, a);
        let e = lane(&end, a);
        lo[a] = outward_down(min(s, e) - own.z);
        hi[a] = outward_up(max(s, e) + own.z);
    }
    store_box(i, record(lo, real(i)), record(hi, own.x));
}

// Partial index of quantity q (0: min of lo, 1: max of hi, 2: max half
// extent) of axis a for bound thread t.
fn partial_at(q: u32, a: u32, t: u32) -> u32 {
    return (q * DIM + a) * BOUND_THREADS + t;
}

@compute @workgroup_size(WORKGROUP)
fn boxes_and_bounds(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let all = linear_index(gid, groups);
    if (all >= WORLDS * BOUND_THREADS || failed_before()) {
        return;
    }
    enter_world(all / BOUND_THREADS);
    let t = all % BOUND_THREADS;
    let own = world * cparams.buckets;
    for (var b = t; b < cparams.buckets; b += BOUND_THREADS) {
        atomicStore(&counters[bucket_counter(own + b)], 0u);
    }
    if (t < 3u) {
        atomicStore(&counters[counter(SPAN + t)], 0u);
    }
    var lo: array<real, DIM>;
    var hi: array<real, DIM>;
    var ext: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        lo[a] = REAL_MAX;
        hi[a] = -REAL_MAX;
        ext[a] = 0.0;
    }
    let from_state = (cparams.flags & 2u) != 0u;
    for (var i = t; i < cparams.count; i += BOUND_THREADS) {
        if (from_state) {
            build_box(i);
        }
        let l = coords(box_record(i, false));
        let h = coords(box_record(i, true));
        for (var a = 0u; a < DIM; a++) {
            lo[a] = min(lo[a], l[a]);
            hi[a] = max(hi[a], h[a]);
            ext[a] = max(ext[a], 0.5 * h[a] - 0.5 * l[a]);
        }
    }
    for (var a = 0u; a < DIM; a++) {
        scratch[scratch_at(partial_at(0u, a, t))] = lo[a];
        scratch[scratch_at(partial_at(1u, a, t))] = hi[a];
        scratch[scratch_at(partial_at(2u, a, t))] = ext[a];
    }
    check_loops(t);
}

// ---- the grid frame: scratch[FRAME ..] = [axis_g, o_g, s_g] for g < 3

var<workgroup> bounds: array<real, 24>; // 3 quantities × DIM ≤ 8

fn frame_axis(g: u32) -> u32 {
    return u32(scratch[scratch_at(FRAME + g)]);
}

fn frame_origin(g: u32) -> real {
    return scratch[scratch_at(FRAME + 3u + g)];
}

fn frame_scale(g: u32) -> real {
    return scratch[scratch_at(FRAME + 6u + g)];
}

// Cells per unit of (v − o)/2 along grid axis g's data.
fn cell_scale(half_range: real, half_extent: real) -> real {
    if (!(half_range >= CELLS_MAX / REAL_MAX)) {
        return 0.0; // a point: one cell
    }
    let cap = CELLS_MAX / half_range;
    if (half_extent * cap * CELL_FACTOR > 1.0) {
        return (1.0 / half_extent) / CELL_FACTOR;
    }
    return cap;
}

// One workgroup per world.
@compute @workgroup_size(WORKGROUP)
fn grid_frame(@builtin(local_invocation_index) lid: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    enter_world(wid.x + wid.y * groups.x);
    if (lid < 3u * DIM) {
        let q = lid / DIM;
        let a = lid % DIM;
        var value = scratch[scratch_at(partial_at(q, a, 0u))];
        for (var t = 1u; t < BOUND_THREADS; t++) {
            let v = scratch[scratch_at(partial_at(q, a, t))];
            if (q == 0u) {
                value = min(value, v);
            } else {
                value = max(value, v);
            }
        }
        bounds[lid] = value;
    }
    check_loops(lid);
    workgroupBarrier();
    if (lid != 0u || failed_before()) {
        return;
    }
    var used: array<bool, DIM>;
    for (var a = 0u; a < DIM; a++) {
        used[a] = false;
    }
    for (var g = 0u; g < GRID; g++) {
        var best = DIM;
        var spread: real = -1.0;
        if (g == 0u && cparams.axis < DIM) {
            best = cparams.axis;
        } else {
            for (var a = 0u; a < DIM; a++) {
                let s = 0.5 * bounds[DIM + a] - 0.5 * bounds[a];
                if (!used[a] && s > spread) {
                    best = a;
                    spread = s;
                }
            }
        }
        used[best] = true;
        let o = bounds[best];
        scratch[scratch_at(FRAME + g)] = real(best);
        scratch[scratch_at(FRAME + 3u + g)] = o;
        scratch[scratch_at(FRAME + 6u + g)] = cell_scale(0.5 * bounds[DIM + best] - 0.5 * o, bounds[2u * DIM + best]);
    }
}

// ---- cells and buckets

fn cell(g: u32, v: real) -> u32 {
    let t = floor((0.5 * v - 0.5 * frame_origin(g)) * frame_scale(g));
    return u32(clamp(t, 0.0, 2.0 * CELLS_MAX));
}

fn mix32(v: u32) -> u32 {
    var h = v;
    h ^= h >> 16u;
    h *= 0x7feb352du;
    h ^= h >> 15u;
    h *= 0x846ca68bu;
    h ^= h >> 16u;
    return h;
}

// The running world's bucket of cell c (of all worlds' buckets).
fn bucket(c: vec3<u32>) -> u32 {
    let b = mix32(c.x ^ mix32(c.y ^ mix32(c.z + 0x9e3779b9u))) & (cparams.buckets - 1u);
    return world * cparams.buckets + b;
}

// The cells of a corner on the grid axes (unused axes: 0).
fn cells_of(corner: array<real, DIM>) -> vec3<u32> {
    var c = vec3<u32>(0u, 0u, 0u);
    for (var g = 0u; g < GRID; g++) {
        c[g] = cell(g, corner[frame_axis(g)]);
    }
    return c;
}

@compute @workgroup_size(WORKGROUP)
fn bin_count(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = linear_index(gid, groups);
    if (t >= all_particles() || failed_before()) {
        return;
    }
    let i = enter(t);
    let home = cells_of(coords(box_record(i, false)));
    let far = cells_of(coords(box_record(i, true)));
    for (var g = 0u; g < GRID; g++) {
        // Most boxes span what is already recorded: read before writing.
        let span = far[g] - home[g];
        if (span > atomicLoad(&counters[counter(SPAN + g)])) {
            atomicMax(&counters[counter(SPAN + g)], span);
        }
    }
    let b = bucket(home);
    words[box_word(0u, i)] = b;
    atomicAdd(&counters[bucket_counter(b)], 1u);
}

@compute @workgroup_size(WORKGROUP)
fn bin_fill(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = linear_index(gid, groups);
    if (t >= all_particles() || failed_before()) {
        return;
    }
    let i = enter(t);
    let slot = atomicAdd(&counters[bucket_counter(bucket_of(i))], 1u);
    let b = particle(i);
    for (var c = 0u; c < 2u * VEC; c++) {
        cands[2u * VEC * slot + c] = boxes[2u * VEC * b + c];
    }
}

// ---- neighbour lists

// Insertion sort of found[0..len) (registers), then drops repeats;
// returns the new length.
fn sort_found(found: ptr<function, array<u32, LOCAL>>, len: u32) -> u32 {
    for (var t = 1u; t < len; t++) {
        let value = (*found)[t];
        var at = t;
        while (at > 0u && (*found)[at - 1u] > value) {
            (*found)[at] = (*found)[at - 1u];
            at--;
        }
        (*found)[at] = value;
    }
    var kept = min(len, 1u);
    for (var t = 1u; t < len; t++) {
        if ((*found)[t] != (*found)[kept - 1u]) {
            (*found)[kept] = (*found)[t];
            kept++;
        }
    }
    return kept;
}

// Heapsort of particle k's list entries [0, len), ascending, in place
// (O(len log len) steps: few loop iterations for long lists), then drops
// repeats. Returns the new length.
fn sort_list(k: u32, len: u32) -> u32 {
    for (var root = len / 2u; root > 0u; root--) {
        sift_down(k, root - 1u, len);
    }
    for (var end = len - min(len, 1u); end > 0u; end--) {
        let top = entry_at(k, 0u);
        set_entry(k, 0u, entry_at(k, end));
        set_entry(k, end, top);
        sift_down(k, 0u, end);
    }
    var kept = min(len, 1u);
    for (var t = 1u; t < len; t++) {
        let value = entry_at(k, t);
        if (value != entry_at(k, kept - 1u)) {
            set_entry(k, kept, value);
            kept++;
        }
    }
    return kept;
}

// Restores the max-heap below `first` within [0, len).
fn sift_down(k: u32, first: u32, len: u32) {
    var root = first;
    let value = entry_at(k, root);
    loop {
        var child = 2u * root + 1u;
        if (child >= len) {
            break;
        }
        var larger = entry_at(k, child);
        if (child + 1u < len) {
            let right = entry_at(k, child + 1u);
            if (right > larger) {
                child += 1u;
                larger = right;
            }
        }
        if (value >= larger) {
            break;
        }
        set_entry(k, root, larger);
        root = child;
    }
    set_entry(k, root, value);
}

@compute @workgroup_size(WORKGROUP)
fn neighbours(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = linear_index(gid, groups);
    if (t >= all_particles() || failed_before()) {
        return;
    }
    let i = enter(t);
    let skip_fixed = (cparams.flags & 1u) != 0u;
    let own_hi = box_record(i, true);
    let lo = coords(box_record(i, false));
    let hi = coords(own_hi);
    let wi = extra(own_hi);
    let home = cells_of(lo);
    let far = cells_of(hi);
    var first = vec3<u32>(0u, 0u, 0u);
    var count = vec3<u32>(1u, 1u, 1u);
    for (var g = 0u; g < GRID; g++) {
        let reach = atomicLoad(&counters[counter(SPAN + g)]);
        first[g] = max(home[g], reach) - reach;
        count[g] = far[g] - first[g] + 1u;
    }
    // The first LOCAL partners stay in registers; longer lists spill to
    // the list buffer and are sorted there.
    var found: array<u32, LOCAL>;
    var len = 0u;
    for (var c0 = 0u; c0 < count.x; c0++) {
        for (var c1 = 0u; c1 < count.y; c1++) {
            for (var c2 = 0u; c2 < count.z; c2++) {
                let range = ranges[bucket(first + vec3<u32>(c0, c1, c2))];
                for (var slot = range.x; slot < range.y; slot++) {
                    let cand_lo = cand_record(slot, false);
                    let cand_hi = cand_record(slot, true);
                    let lj = coords(cand_lo);
                    let hj = coords(cand_hi);
                    let j = u32(extra(cand_lo));
                    var overlap = j != i;
                    for (var a = 0u; a < DIM; a++) {
                        overlap = overlap && lo[a] <= hj[a] && lj[a] <= hi[a];
                    }
                    if (!overlap || (skip_fixed && wi + extra(cand_hi) == 0.0)) {
                        continue;
                    }
                    if (len < LOCAL) {
                        found[len] = j;
                    } else {
                        if (len == LOCAL) {
                            for (var t = 0u; t < min(LOCAL, list_slots); t++) {
                                set_entry(i, t, found[t]);
                            }
                        }
                        if (len < list_slots) {
                            set_entry(i, len, j);
                        }
                    }
                    len++;
                }
            }
        }
    }
    atomicMax(&counters[counter(MAX_DEGREE)], len);
    if (len <= LOCAL) {
        len = sort_found(&found, len);
        if (len <= list_slots) {
            for (var q = 0u; q < (len + 3u) / 4u; q++) {
                set_list_quad(i, q, vec4<u32>(found[4u * q], found[4u * q + 1u], found[4u * q + 2u], found[4u * q + 3u]));
            }
        }
    } else if (len <= list_slots) {
        len = sort_list(i, len);
    }
    words[box_word(1u, i)] = len;
    check_loops(t);
}
