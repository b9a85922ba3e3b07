// Prediction, velocity reconstruction and damping, one invocation per
// particle (prediction also resets one multiplier per invocation).
//
//   predict   λ = 0;  p = x;  for dynamic i: v += h (s g + w f);  x += h v
//   velocity  for dynamic i: v = (x − p) / h
//   damping   for dynamic i: v *= factor          (factor = exp(−rate h))
//
// Same arithmetic, in the same order, as cpu/src/integrate.rs.

@compute @workgroup_size(WORKGROUP)
fn predict(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = linear_index(gid, groups);
    if (failed_before()) {
        return;
    }
    if (t < arrayLength(&lambda)) {
        lambda[t] = 0.0;
    }
    if (t >= params.count) {
        return;
    }
    let i = t;
    for (var a = 0u; a < DIM; a++) {
        p[i * DIM + a] = x[i * DIM + a];
    }
    let w = inv_mass[i];
    if (w == 0.0) {
        return;
    }
    let s = gravity_scale[i];
    var ok = true;
    for (var a = 0u; a < DIM; a++) {
        let k = i * DIM + a;
        var acc: real = 0.0;
        if ((params.flags & 1u) != 0u) {
            acc += s * params.gravity[a];
        }
        if ((params.flags & 2u) != 0u) {
            acc += w * force[k];
        }
        let vk = v[k] + params.h * acc;
        let xk = x[k] + params.h * vk;
        v[k] = vk;
        x[k] = xk;
        ok = ok && finite(vk) && finite(xk);
    }
    if (!ok) {
        fail(i);
    }
}

@compute @workgroup_size(WORKGROUP)
fn velocity(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= params.count || failed_before() || inv_mass[i] == 0.0) {
        return;
    }
    var ok = true;
    for (var a = 0u; a < DIM; a++) {
        let k = i * DIM + a;
        let vk = (x[k] - p[k]) / params.h;
        v[k] = vk;
        ok = ok && finite(vk);
    }
    if (!ok) {
        fail(i);
    }
}

@compute @workgroup_size(WORKGROUP)
fn damping(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = linear_index(gid, groups);
    if (i >= params.count || failed_before() || inv_mass[i] == 0.0) {
        return;
    }
    for (var a = 0u; a < DIM; a++) {
        v[i * DIM + a] *= params.factor;
    }
}
