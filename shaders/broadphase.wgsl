// Common prelude of the broadphase kernels (radix_sort.wgsl, sweep.wgsl).
// The host prepends the same header as for the step kernels (real, DIM).
//
// Records are pairs of u32 [word 0, word 1]: a box record is
// [sort key, box index], a pair record is [i, j]. Sorting ping-pongs
// between rec_a and rec_b; `flip` selects the direction of one pass.
// `scan` holds histograms, per-box counts and every scan level, at offsets
// the host chooses (`base`, `next`).

struct SweepParams {
    count: u32,     // records / boxes / scan entries this call works on
    shift: u32,     // radix pass: bit offset of the digit
    word: u32,      // radix pass: which record word holds the key
    flip: u32,      // 0: rec_a → rec_b, 1: rec_b → rec_a
    blocks: u32,    // radix pass: blocks of RADIX_BLOCK records
    base: u32,      // scan offset of this call's array
    next: u32,      // scan offset of the block sums (scan) / of the counts (sweep)
    capacity: u32,  // pair records the pair buffers hold
    axis: u32,      // sweep axis
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<storage, read> params: SweepParams;
@group(0) @binding(1) var<storage, read> box_min: array<real>;
@group(0) @binding(2) var<storage, read> box_max: array<real>;
@group(0) @binding(3) var<storage, read_write> order: array<u32>;
@group(0) @binding(4) var<storage, read_write> rec_a: array<u32>;
@group(0) @binding(5) var<storage, read_write> rec_b: array<u32>;
@group(0) @binding(6) var<storage, read_write> scan: array<u32>;

const RADIX_BLOCK: u32 = 256u;
const RADIX: u32 = 256u;

// Linear workgroup index over a 2D grid (more than 65535 groups spread over y).
fn group_index(wid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return wid.x + wid.y * groups.x;
}

fn read_rec(k: u32) -> u32 {
    if (params.flip == 0u) {
        return rec_a[k];
    }
    return rec_b[k];
}

fn write_rec(k: u32, value: u32) {
    if (params.flip == 0u) {
        rec_b[k] = value;
    } else {
        rec_a[k] = value;
    }
}
