// Prediction, velocity reconstruction and damping of one particle, on its
// records held in registers by the step's runner (step.wgsl).
//
//   predict   p = x;  for dynamic i: v += h (s g + w f);  x += h v
//   velocity  for dynamic i: v = (x − p) / h
//   damping   for dynamic i: v *= factor          (factor = exp(−rate h))
//
// Same arithmetic, in the same order, as cpu/src/integrate.rs. The
// multipliers are not reset here: the first projection of each family in a
// substep reads λ as 0 and writes it (FLAG_FIRST, project.wgsl).

fn predict_particle(i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>, rp: ptr<function, Record>) {
    *rp = *rx;
    let w = inverse_mass_of(rx);
    if (w == 0.0) {
        return;
    }
    let flags = call.flags;
    let h = call.h;
    var f: Record;
    if ((flags & FLAG_FORCE) != 0u) {
        f = load_force(i);
    }
    // s g: with every dynamic particle's scale 1 (FLAG_UNIT_SCALE) the
    // load is skipped; 1 · g is g exactly.
    var s: real = 1.0;
    if ((flags & (FLAG_GRAVITY | FLAG_UNIT_SCALE)) == FLAG_GRAVITY) {
        s = gravity_scale[particle(i)];
    }
    var ok = true;
    for (var a = 0u; a < DIM; a++) {
        var acc: real = 0.0;
        if ((flags & FLAG_GRAVITY) != 0u) {
            acc += s * gravity(a);
        }
        if ((flags & FLAG_FORCE) != 0u) {
            acc += w * lane(&f, a);
        }
        let vk = lane(rv, a) + h * acc;
        let xk = lane(rx, a) + h * vk;
        set_lane(rv, a, vk);
        set_lane(rx, a, xk);
        ok = ok && finite(vk) && finite(xk);
    }
    if (!ok) {
        fail(i);
    }
}

fn velocity_particle(i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>, rp: ptr<function, Record>) {
    if (inverse_mass_of(rx) == 0.0) {
        return;
    }
    let h = call.h;
    var ok = true;
    for (var a = 0u; a < DIM; a++) {
        let vk = (lane(rx, a) - lane(rp, a)) / h;
        set_lane(rv, a, vk);
        ok = ok && finite(vk);
    }
    if (!ok) {
        fail(i);
    }
}

fn damping_particle(i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>, rp: ptr<function, Record>) {
    // A world of a batch without damping has no damping call: skipped.
    if (skipped() || inverse_mass_of(rx) == 0.0) {
        return;
    }
    let factor = call.factor;
    for (var a = 0u; a < DIM; a++) {
        set_lane(rv, a, lane(rv, a) * factor);
    }
}
