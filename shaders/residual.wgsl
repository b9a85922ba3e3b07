// Constraint violation after a step, per family: the largest violation and
// the active contacts (λ > 0). Elements are split into chunks of CHUNK; one
// workgroup per chunk strides over it and reduces in workgroup memory into
// `partials`, then one workgroup per family reduces its chunks into
// `report`. When every family has at most WORKGROUP elements of a kind
// with O(N) loops (distance, tether, plane contact), `residual_lanes`
// instead runs one lane per (family, world) over the family's elements in
// order, in one dispatch without barriers. Maximum and
// integer counts are exact, so the result does not depend on the reduction
// order: both ways give the same report bit for bit.
//
//   equality:  |C(x)|          contact (plane, mesh):  max(0, −C(x)),  active if λ > 0
//   tether:    max(0, |x1 − x0| − rest)
//   material:  C = √(2W) (+∞ for an element the law refuses)

const CHUNK: u32 = 16u * WORKGROUP;

var<workgroup> partial_max: array<real, WORKGROUP>;
var<workgroup> partial_count: array<u32, WORKGROUP>;

// +∞, made at run time (a constant overflow is a WGSL error): REAL_MAX
// doubled, the condition true for every call (as kept() in step.wgsl).
fn infinity() -> real {
    var big = REAL_MAX;
    if (call.call != NONE) {
        big = big * 2.0;
    }
    return big;
}

// Violation of element e of the running residual call.
fn violation(e: u32) -> real {
    let s = call.slot_base + e;
    var pts: array<real, POINTS>;
    var grad: array<real, POINTS>;
    gather(e, &pts);
    let kind = call.kind;
    if (kind == RESIDUAL_DISTANCE) {
        return abs(distance(&pts, &grad) - rest_at(s));
    } else if (kind == RESIDUAL_SIMPLEX) {
        return abs(simplex_squared_measure(&pts, call.arity - 1u, &grad) - rest_at(s));
    } else if (kind == RESIDUAL_ORIENTED) {
        return abs(oriented_measure(&pts, &grad) - rest_at(s));
    } else if (kind == RESIDUAL_TETHER) {
        return max(distance(&pts, &grad) - rest_at(s), 0.0);
    } else if (kind == RESIDUAL_MATERIAL) {
        var refused = false;
        let c = material_constraint(e, &pts, &grad, &refused);
        return select(c, infinity(), refused);
    } else if (kind == RESIDUAL_EXPRESSION) {
        return expression_violation(e);
    } else if (kind == RESIDUAL_MESH) {
        var p: array<real, DIM>;
        for (var a = 0u; a < DIM; a++) {
            p[a] = pts[a];
        }
        return mesh_violation(s, &p);
    } else if (kind != RESIDUAL_CONTACT) {
        // An unknown kind reads as violated without bound, never as another kind.
        return infinity();
    }
    var nx: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        nx += normal(a) * pts[a];
    }
    if ((call.flags & FLAG_MOVING) != 0u) {
        return moving_contact_violation(s, nx);
    }
    return max(rest_at(s) - nx, 0.0);
}

// Element e of the running residual call into the running maximum and
// (for a contact family) the count of active contacts.
fn take_element(e: u32, contact: bool, worst: ptr<function, real>, contacts: ptr<function, u32>) {
    *worst = max(*worst, violation(e));
    if (contact && lambda_at(call.slot_base + e) > 0.0) {
        *contacts += 1u;
    }
}

// Tree reduction of the workgroup's partial_max / partial_count into
// element 0 (every invocation of the workgroup calls it).
fn reduce_workgroup(lid: u32) {
    workgroupBarrier();
    for (var stride = WORKGROUP / 2u; stride > 0u; stride = stride / 2u) {
        if (lid < stride) {
            partial_max[lid] = max(partial_max[lid], partial_max[lid + stride]);
            partial_count[lid] += partial_count[lid + stride];
        }
        workgroupBarrier();
    }
}

// Chunk k (of the running residual call, elements start..end) into
// partials[k].
fn residual_chunk(k: u32, start: u32, end: u32, lid: u32) {
    var worst: real = 0.0;
    var contacts = 0u;
    let contact = call.kind == RESIDUAL_CONTACT || call.kind == RESIDUAL_MESH;
    for (var e = start + lid; e < end; e += WORKGROUP) {
        take_element(e, contact, &worst, &contacts);
    }
    partial_max[lid] = worst;
    partial_count[lid] = contacts;
    reduce_workgroup(lid);
    if (lid == 0u) {
        partials[2u * k] = partial_max[0];
        partials[2u * k + 1u] = real(partial_count[0]); // ≤ CHUNK: exact
    }
    workgroupBarrier();
}

// The chunks of residual call c into report[2 family], report[2 family + 1]
// (of the running world: its partials and report follow world-major).
fn reduce_family(c: u32, lid: u32) {
    call = calls[world * WORLD_CALLS + c];
    let first = world * WORLD_CHUNKS + call.chunk;
    let end = first + (call.count + CHUNK - 1u) / CHUNK;
    var worst: real = 0.0;
    var contacts = 0u;
    for (var k = first + lid; k < end; k += WORKGROUP) {
        worst = max(worst, partials[2u * k]);
        contacts += u32(partials[2u * k + 1u]);
    }
    partial_max[lid] = worst;
    partial_count[lid] = contacts;
    reduce_workgroup(lid);
    if (lid == 0u) {
        report[world * WORLD_REPORT + 2u * call.family] = partial_max[0];
        report[world * WORLD_REPORT + 2u * call.family + 1u] = real(partial_count[0]);
    }
    workgroupBarrier();
}

// One workgroup per chunk of every residual call (the chunk table).
@compute @workgroup_size(WORKGROUP)
fn residual(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>,
            @builtin(local_invocation_index) lid: u32) {
    let k = wid.x + wid.y * groups.x;
    if (k >= here.count * WORLDS) {
        return;
    }
    // Chunk k is chunk `local` of its world; partials are world-major, so
    // its slot is k.
    let local = split_world(k, here.count);
    let entry = chunks[local];
    call = calls[world * WORLD_CALLS + entry.x];
    residual_chunk(k, entry.y, min(entry.y + CHUNK, call.count), lid);
}

// One workgroup per residual call (family) of each world.
@compute @workgroup_size(WORKGROUP)
fn reduce(@builtin(workgroup_id) wid: vec3<u32>, @builtin(local_invocation_index) lid: u32) {
    reduce_family(here.first_call + split_world(wid.x, here.end_call - here.first_call), lid);
}

// One lane per (family, world) when every family has at most WORKGROUP
// elements of a kind with O(N) loops per element (distance, tether, plane
// contact: gpu/src/xpbd/schedule.rs): lane t = family · WORLDS + world, so
// the lanes of a SIMD group share a family (and its kind); the family's
// elements in order, its report entries written directly. ≤ 64 elements
// of ~4N loop trips (N ≤ 8: a few thousand) stay far inside llvmpipe's
// loop budget (65 535 per 8 lanes), so this kernel has no loop probe: on
// lavapipe in f64 the probe made the chain's step 30× slower (15 ms against
// 0.49 ms, docs/performance.md).
@compute @workgroup_size(WORKGROUP)
fn residual_lanes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = linear_index(gid, groups);
    if (t >= here.count * WORLDS) {
        return;
    }
    world = t % WORLDS;
    call = calls[world * WORLD_CALLS + here.first_call + t / WORLDS];
    var worst: real = 0.0;
    var contacts = 0u;
    let contact = call.kind == RESIDUAL_CONTACT || call.kind == RESIDUAL_MESH;
    for (var e = 0u; e < call.count; e++) {
        take_element(e, contact, &worst, &contacts);
    }
    report[world * WORLD_REPORT + 2u * call.family] = worst;
    report[world * WORLD_REPORT + 2u * call.family + 1u] = real(contacts);
}
