// Constraint violation after a step: one invocation per element writes its
// violation, then one workgroup per family reduces to the maximum and
// counts active contacts. Maximum and integer counts are exact, so the
// result does not depend on the reduction order.
//
//   equality:  |C(x)|          contact:  max(0, −C(x)),  active if λ > 0
//   tether:    max(0, |x1 − x0| − rest)

@compute @workgroup_size(WORKGROUP)
fn residual(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let e = linear_index(gid, groups);
    if (e >= params.count) {
        return;
    }
    let s = params.slot_base + e;
    var pts: array<real, POINTS>;
    var grad: array<real, POINTS>;
    gather(e, &pts);
    // params.flags holds the family kind here: 0 distance, 1 simplex
    // measure, 2 oriented measure, 3 hyperplane contact, 4 tether.
    let kind = params.flags;
    var violation: real;
    if (kind == 0u) {
        violation = abs(distance(&pts, &grad) - rest[s]);
    } else if (kind == 1u) {
        violation = abs(simplex_squared_measure(&pts, params.arity - 1u, &grad) - rest[s]);
    } else if (kind == 2u) {
        violation = abs(oriented_measure(&pts, &grad) - rest[s]);
    } else if (kind == 4u) {
        violation = max(distance(&pts, &grad) - rest[s], 0.0);
    } else {
        var nx: real = 0.0;
        for (var a = 0u; a < DIM; a++) {
            nx += params.normal[a] * pts[a];
        }
        violation = max(rest[s] - nx, 0.0);
    }
    resid[s] = violation;
}

var<workgroup> partial_max: array<real, WORKGROUP>;
var<workgroup> partial_count: array<u32, WORKGROUP>;

@compute @workgroup_size(WORKGROUP)
fn reduce(@builtin(local_invocation_id) lid: vec3<u32>) {
    let t = lid.x;
    var worst: real = 0.0;
    var contacts = 0u;
    for (var e = t; e < params.count; e += WORKGROUP) {
        worst = max(worst, resid[params.slot_base + e]);
        if (params.flags == 3u && lambda[params.slot_base + e] > 0.0) {
            contacts += 1u;
        }
    }
    partial_max[t] = worst;
    partial_count[t] = contacts;
    workgroupBarrier();
    for (var stride = WORKGROUP / 2u; stride > 0u; stride = stride / 2u) {
        if (t < stride) {
            partial_max[t] = max(partial_max[t], partial_max[t + stride]);
            partial_count[t] += partial_count[t + stride];
        }
        workgroupBarrier();
    }
    if (t == 0u) {
        report[2u * params.family] = partial_max[0];
        report[2u * params.family + 1u] = real(partial_count[0]);
    }
}
