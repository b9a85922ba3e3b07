// Portable stable LSD radix sort of u32-pair records by one 8-bit digit per
// pass, and the exclusive prefix scan it (and the sweep) uses.
//
//   histogram   per block of 256 records: count of each digit value
//               (workgroup integer atomics: the counts do not depend on
//               scheduling), stored digit-major: scan[base + d·blocks + b]
//   scan        exclusive prefix sum of the histogram → first output slot
//               of (digit d, block b); all of digit d before digit d + 1,
//               block b before block b + 1: a stable order
//   scatter     rank of a record among equal digits of its block = number
//               of earlier records of the block with that digit (a plain
//               loop over shared memory: no subgroup operations, no
//               assumption about subgroup size); out[slot + rank] = record
//
// The scan of n entries: scan_blocks scans each block of 256 in shared
// memory (Hillis–Steele, one fixed shape) and writes the block total to
// scan[next + b]; the host scans those totals the same way (recursively)
// and scan_add adds them back. Integer sums: exact, any tree shape.

var<workgroup> hist: array<atomic<u32>, RADIX>;
var<workgroup> digits: array<u32, RADIX_BLOCK>;
var<workgroup> partial: array<u32, RADIX_BLOCK>;

fn digit_of(k: u32) -> u32 {
    return (read_rec(2u * k + params.word) >> params.shift) & (RADIX - 1u);
}

@compute @workgroup_size(256)
fn histogram(@builtin(local_invocation_index) lid: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let block = group_index(wid, groups);
    atomicStore(&hist[lid], 0u);
    workgroupBarrier();
    let k = block * RADIX_BLOCK + lid;
    if (block < params.blocks && k < params.count) {
        atomicAdd(&hist[digit_of(k)], 1u);
    }
    workgroupBarrier();
    if (block < params.blocks) {
        scan[params.base + lid * params.blocks + block] = atomicLoad(&hist[lid]);
    }
}

@compute @workgroup_size(256)
fn scatter(@builtin(local_invocation_index) lid: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let block = group_index(wid, groups);
    let k = block * RADIX_BLOCK + lid;
    let valid = block < params.blocks && k < params.count;
    var d = RADIX; // no digit: never equal to a real one
    if (valid) {
        d = digit_of(k);
    }
    digits[lid] = d;
    workgroupBarrier();
    if (valid) {
        var rank = 0u;
        for (var t = 0u; t < lid; t++) {
            if (digits[t] == d) {
                rank++;
            }
        }
        let slot = scan[params.base + d * params.blocks + block] + rank;
        let w0 = read_rec(2u * k);
        let w1 = read_rec(2u * k + 1u);
        write_rec(2u * slot, w0);
        write_rec(2u * slot + 1u, w1);
    }
}

@compute @workgroup_size(256)
fn scan_blocks(@builtin(local_invocation_index) lid: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let block = group_index(wid, groups);
    let k = block * RADIX_BLOCK + lid;
    var value = 0u;
    if (k < params.count) {
        value = scan[params.base + k];
    }
    partial[lid] = value;
    workgroupBarrier();
    for (var offset = 1u; offset < RADIX_BLOCK; offset *= 2u) {
        var add = 0u;
        if (lid >= offset) {
            add = partial[lid - offset];
        }
        workgroupBarrier();
        partial[lid] += add;
        workgroupBarrier();
    }
    if (k < params.count) {
        scan[params.base + k] = partial[lid] - value;
    }
    if (lid == RADIX_BLOCK - 1u && block * RADIX_BLOCK < params.count) {
        scan[params.next + block] = partial[lid];
    }
}

@compute @workgroup_size(256)
fn scan_add(@builtin(local_invocation_index) lid: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let block = group_index(wid, groups);
    let k = block * RADIX_BLOCK + lid;
    if (k < params.count) {
        scan[params.base + k] += scan[params.next + block];
    }
}
