// Dynamic Coulomb friction against a hyperplane, one invocation per contact
// slot of the family (velocity response after velocity reconstruction).
//
//   for each contact with λ > 0:  v_n = n·v;  v_t = v − v_n n
//   v −= v_t · min(μ w λ / h, |v_t|) / |v_t|
//
// Same arithmetic, in the same order, as cpu/src/friction.rs.

@compute @workgroup_size(WORKGROUP)
fn friction(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let e = linear_index(gid, groups);
    if (e >= params.count || failed_before()) {
        return;
    }
    let l = lambda[params.slot_base + e];
    if (l <= 0.0) {
        return;
    }
    let i = elements[params.elem_base + e];
    var vn: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        vn += params.normal[a] * v[i * DIM + a];
    }
    var t2: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        let t = v[i * DIM + a] - vn * params.normal[a];
        t2 += t * t;
    }
    let vt = sqrt(t2);
    if (vt == 0.0) {
        return;
    }
    let limit = params.friction * inv_mass[i] * l / params.h;
    let scale = min(limit, vt) / vt;
    var ok = true;
    for (var a = 0u; a < DIM; a++) {
        let t = v[i * DIM + a] - vn * params.normal[a];
        let vk = v[i * DIM + a] - t * scale;
        v[i * DIM + a] = vk;
        ok = ok && finite(vk);
    }
    if (!ok) {
        fail(i);
    }
}
