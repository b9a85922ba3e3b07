// Guards: read-only checks of a completed substep (core/src/guards.rs,
// the same arithmetic in the same order). One invocation per element of
// a guarded family (OP_GUARD_MEASURE) or per particle (OP_GUARD_SPEED);
// a violation is noted (`fail`) and put in the status block once per
// invocation (`record_failure`: smallest call, then smallest slot /
// particle), so the first violation in the CPU's order wins.
//
//   J = V(x) / V_rest,  V = det([x1−x0 … xN−x0])/N!    (oriented_measure)
//   J = det F̂ or √(det G / det G_0)   (material families, FLAG_MATERIAL:
//                                       material.wgsl's measure ratio)
//   orientation (FLAG_ORIENTATION)   J ≤ 0 (or NaN)  → violation
//   ratio       (FLAG_RATIO)         J < r (or NaN)  → violation
//   speed       Σ_a v_a² in axis order > v²          → violation
//
// Guard call blocks: `alpha_tilde` holds r, `factor` holds v² (computed
// on the host; per world in a batch, step.wgsl's `world_reals`); nothing
// is written but the status word.

// OP_GUARD_*, FLAG_* come from the generated header (gpu/src/codes.rs).

fn guard_element(e: u32) {
    var pts: array<real, POINTS>;
    var grad: array<real, POINTS>;
    gather(e, &pts);
    let flags = call.flags;
    var j: real;
    if ((flags & FLAG_MATERIAL) != 0u) {
        j = material_measure_ratio(e, &pts);
    } else {
        j = oriented_measure(&pts, &grad) / rest_at(call.slot_base + e);
    }
    let inverted = (flags & FLAG_ORIENTATION) != 0u && !(j > 0.0);
    let below = (flags & FLAG_RATIO) != 0u && !(j >= call.alpha_tilde);
    if (inverted || below) {
        fail(e);
    }
}

fn guard_particle(i: u32) {
    var rv = load_v(i);
    var rx = load_x(i);
    if (inverse_mass_of(&rx) == 0.0) {
        return;
    }
    var s2: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        let va = lane(&rv, a);
        s2 = kept(s2 + kept(va * va));
    }
    if (!(s2 <= call.factor)) {
        fail(i);
    }
}

@compute @workgroup_size(WORKGROUP)
fn guard(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let t = linear_index(gid, groups);
    if (t >= here.count * WORLDS) {
        return;
    }
    // A batch: element / particle i of its world, with its world's limit.
    let i = split_world(t, here.count);
    take_call(0u, FLAGS);
    world_reals(OP0, here.first_call);
    if (OP0 == OP_GUARD_MEASURE) {
        guard_element(i);
    } else {
        guard_particle(i);
    }
    record_failure();
}
