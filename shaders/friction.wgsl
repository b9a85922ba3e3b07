// Dynamic Coulomb friction against a hyperplane, one particle (velocity
// response after velocity reconstruction; its records in registers).
//
//   for a contact with λ > 0:  v_n = n·v;  v_t = v − v_n n
//   v −= v_t · min(μ w λ / h, |v_t|) / |v_t|
//
// Same arithmetic, in the same order, as cpu/src/friction.rs.

fn friction_particle(i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>, rp: ptr<function, Record>) {
    // A world of a batch whose own μ is 0 has no friction call: skipped
    // (run with μ = 0 it would compute v − t·0, and −0 − (−0) is +0).
    if (skipped()) {
        return;
    }
    let slot = friction_slot(i);
    if (slot.e == NONE) {
        return;
    }
    if (slot.l <= 0.0) {
        return;
    }
    var n: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        n[a] = normal(a);
    }
    dynamic_friction(i, rx, rv, slot.l, &n);
}

// Slot and λ of particle i in the running friction call's family (NONE:
// none): as the contact of this family just left them on this particle
// (project.wgsl), else from memory — on lavapipe a load some lane takes
// costs ~10× one every lane skips (docs/performance.md).
struct FrictionSlot {
    e: u32,
    l: real,
}

fn friction_slot(i: u32) -> FrictionSlot {
    var slot = FrictionSlot(contact_e, contact_l);
    if (contact_family != call.family || contact_particle_index != i) {
        slot.e = contact_slot[call.slot_map + i];
        if (slot.e != NONE) {
            slot.l = lambda_at(call.slot_base + slot.e);
        }
    }
    return slot;
}

// v −= v_t · min(μ w λ / h, |v_t|) / |v_t| of particle i with multiplier
// `l` > 0 against a resting obstacle with unit normal n (a plane's, or a
// mesh's at x: mesh_contact.wgsl).
fn dynamic_friction(i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>, l: real,
                    n: ptr<function, array<real, DIM>>) {
    var u = *rv;
    relative_friction(i, rx, rv, &u, l, n);
}

// v −= u_t · min(μ w λ / h, |u_t|) / |u_t|, u_t = u − (n·u) n: dynamic
// friction of particle i (multiplier `l` > 0, unit normal n) on its
// velocity `u` relative to the obstacle (v itself against a resting one;
// motion.wgsl's carried_friction against a moving one).
fn relative_friction(i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>,
                     u: ptr<function, Record>, l: real, n: ptr<function, array<real, DIM>>) {
    var vn: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        vn += (*n)[a] * lane(u, a);
    }
    var t2: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        let t = lane(u, a) - vn * (*n)[a];
        t2 += t * t;
    }
    let vt = sqrt(t2);
    if (vt == 0.0) {
        return;
    }
    let limit = call.friction * inverse_mass_of(rx) * l / call.h;
    let scale = min(limit, vt) / vt;
    var ok = true;
    for (var a = 0u; a < DIM; a++) {
        let t = lane(u, a) - vn * (*n)[a];
        let vk = lane(rv, a) - t * scale;
        set_lane(rv, a, vk);
        ok = ok && finite(vk);
    }
    if (!ok) {
        fail(i);
    }
}
