// Sort-and-sweep over boxes, the rule of core/src/broadphase/sweep.rs:
//
//   box_keys     rec_a[k] = [sortable(key_down(min_k[axis])), k]
//   (radix sort of the box records → `order`, stable: ties by index)
//   sweep_count  for sorted position s, box i = order[s]:
//                  count j = order[t], t > s, while key_t ≤ sortable(key_up(max_i[axis])),
//                  with closed-interval overlap on every axis
//                scan[next + s] = count  (scan[next + n] = 0: total after the scan)
//   sweep_emit   the same loop; pair number scan[next + s] + c goes to
//                rec_a[2·slot..] = [min(i, j), max(i, j)] if slot < capacity
//   (radix sort of the pairs by j then i → canonical order)
//
// The keys round outward to f32 without bitcasting a real (naga rejects
// f64 bitcast): f = f32(x), stepped down by one f32 ulp while f > x.
// Denormals are never produced: |x| < 2^-126 maps to ±2^-126 or ∓0.

const F32_MAX: f32 = 3.4028234663852886e38;
const F32_MIN_NORMAL: f32 = 1.1754943508222875e-38;

fn sortable(f: f32) -> u32 {
    let bits = bitcast<u32>(f);
    if ((bits & 0x80000000u) != 0u) {
        return ~bits;
    }
    return bits | 0x80000000u;
}

// The largest f32 ≤ x, as sortable bits (never +0, never denormal).
fn key_down(x: real) -> u32 {
    if (abs(x) < real(F32_MIN_NORMAL)) {
        if (x < 0.0) {
            return 0x7f7fffffu; // sortable(−2^−126)
        }
        return 0x7fffffffu; // sortable(−0)
    }
    if (x > real(F32_MAX)) {
        return sortable(F32_MAX);
    }
    if (x < -real(F32_MAX)) {
        return 0x007fffffu; // sortable(−∞)
    }
    var f = f32(x);
    var bits = bitcast<u32>(f);
    // At most two ulps off for any rounding of the conversion.
    for (var step = 0u; step < 2u; step++) {
        if (real(f) > x) {
            if (f > 0.0) {
                bits -= 1u;
            } else {
                bits += 1u;
            }
            f = bitcast<f32>(bits);
        }
    }
    return sortable(f);
}

// The smallest f32 ≥ x, as sortable bits: −key_down(−x).
fn key_up(x: real) -> u32 {
    // sortable(−f) = ~sortable(f) for every f except that it maps
    // sortable(−0) ↔ sortable(+0) consistently, which is what −(·) does.
    return ~key_down(-x);
}

fn overlap(i: u32, j: u32) -> bool {
    var ok = true;
    for (var a = 0u; a < DIM; a++) {
        ok = ok && box_min[i * DIM + a] <= box_max[j * DIM + a] && box_min[j * DIM + a] <= box_max[i * DIM + a];
    }
    return ok;
}

@compute @workgroup_size(256)
fn box_keys(@builtin(local_invocation_index) lid: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = group_index(wid, groups) * 256u + lid;
    if (k >= params.count) {
        return;
    }
    rec_a[2u * k] = key_down(box_min[k * DIM + params.axis]);
    rec_a[2u * k + 1u] = k;
}

// Number of partners of sorted position s (loop shared by count and emit).
fn partners(s: u32, emit: bool, first: u32) -> u32 {
    let n = params.count;
    let i = order[2u * s + 1u];
    let up = key_up(box_max[i * DIM + params.axis]);
    var c = 0u;
    for (var t = s + 1u; t < n; t++) {
        if (order[2u * t] > up) {
            break;
        }
        let j = order[2u * t + 1u];
        if (overlap(i, j)) {
            if (emit) {
                let slot = first + c;
                if (slot < params.capacity) {
                    rec_a[2u * slot] = min(i, j);
                    rec_a[2u * slot + 1u] = max(i, j);
                }
            }
            c++;
        }
    }
    return c;
}

@compute @workgroup_size(256)
fn sweep_count(@builtin(local_invocation_index) lid: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let s = group_index(wid, groups) * 256u + lid;
    if (s < params.count) {
        scan[params.next + s] = partners(s, false, 0u);
    } else if (s == params.count) {
        scan[params.next + s] = 0u;
    }
}

@compute @workgroup_size(256)
fn sweep_emit(@builtin(local_invocation_index) lid: u32, @builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let s = group_index(wid, groups) * 256u + lid;
    if (s < params.count) {
        partners(s, true, scan[params.next + s]);
    }
}
