// Exclusive prefix sum of the hash-bucket counters (every world's, world
// after world), in place, in three dispatches for up to SCAN_BLOCK² buckets:
//
//   scan_reduce   block b (SCAN_BLOCK counters): its total → sums[b]
//   scan_top      one workgroup: sums ← exclusive prefix of sums
//   scan_apply    block b: counter ← sums[b] + exclusive prefix in the block
//                 (the bucket's slot range also kept in `ranges`)
//
// Each of the WORKGROUP (256) invocations of a block owns SCAN_CHUNK consecutive
// counters; the chunk totals are scanned across the workgroup (Hillis–
// Steele, one fixed shape). Integer sums: exact in any order.

const SCAN_CHUNK: u32 = 8u;
const SCAN_BLOCK: u32 = SCAN_CHUNK * WORKGROUP; // 2048 counters

var<workgroup> chunk_sums: array<u32, WORKGROUP>;

// Exclusive prefix of `value` over the invocations of the workgroup; the
// workgroup's total lands in chunk_sums[WORKGROUP − 1] + its value.
fn workgroup_exclusive(lid: u32, value: u32) -> u32 {
    chunk_sums[lid] = value;
    workgroupBarrier();
    for (var offset = 1u; offset < WORKGROUP; offset *= 2u) {
        var add = 0u;
        if (lid >= offset) {
            add = chunk_sums[lid - offset];
        }
        workgroupBarrier();
        chunk_sums[lid] += add;
        workgroupBarrier();
    }
    return chunk_sums[lid] - value;
}

fn bucket_count(e: u32) -> u32 {
    if (e >= all_buckets()) {
        return 0u;
    }
    return atomicLoad(&counters[bucket_counter(e)]);
}

fn chunk_total(first: u32) -> u32 {
    var total = 0u;
    for (var k = 0u; k < SCAN_CHUNK; k++) {
        total += bucket_count(first + k);
    }
    return total;
}

@compute @workgroup_size(WORKGROUP)
fn scan_reduce(@builtin(local_invocation_index) lid: u32, @builtin(workgroup_id) wid: vec3<u32>) {
    let block = wid.x;
    let total = chunk_total(block * SCAN_BLOCK + lid * SCAN_CHUNK);
    let before = workgroup_exclusive(lid, total);
    if (lid == WORKGROUP - 1u && block < cparams.blocks) {
        words[scan_sums_at() + block] = before + total;
    }
}

@compute @workgroup_size(WORKGROUP)
fn scan_top(@builtin(local_invocation_index) lid: u32) {
    let sums = scan_sums_at();
    var values: array<u32, SCAN_CHUNK>;
    var total = 0u;
    for (var k = 0u; k < SCAN_CHUNK; k++) {
        let b = lid * SCAN_CHUNK + k;
        values[k] = 0u;
        if (b < cparams.blocks) {
            values[k] = words[sums + b];
        }
        total += values[k];
    }
    var running = workgroup_exclusive(lid, total);
    for (var k = 0u; k < SCAN_CHUNK; k++) {
        let b = lid * SCAN_CHUNK + k;
        if (b < cparams.blocks) {
            words[sums + b] = running;
        }
        running += values[k];
    }
}

@compute @workgroup_size(WORKGROUP)
fn scan_apply(@builtin(local_invocation_index) lid: u32, @builtin(workgroup_id) wid: vec3<u32>) {
    let block = wid.x;
    let first = block * SCAN_BLOCK + lid * SCAN_CHUNK;
    let total = chunk_total(first);
    var running = workgroup_exclusive(lid, total);
    if (block < cparams.blocks) {
        running += words[scan_sums_at() + block];
    }
    for (var k = 0u; k < SCAN_CHUNK; k++) {
        let e = first + k;
        if (e < all_buckets()) {
            let c = atomicLoad(&counters[bucket_counter(e)]);
            atomicStore(&counters[bucket_counter(e)], running);
            ranges[e] = vec2<u32>(running, running + c);
            running += c;
        }
    }
}
