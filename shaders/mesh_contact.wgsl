// Simplex-mesh contact on the XPBD step (core/src/kinds/mesh_contact.rs;
// the golden path's projection is cpu/src/project.rs `mesh_contact_in`,
// its friction and residual cpu/src/mesh_contact.rs). A mesh family holds
// one slot per dynamic particle in one colour, so it runs per particle,
// its records in registers, as a hyperplane family does (FLAG_MESH on the
// contact and friction calls, RESIDUAL_MESH on its residual call).
//
//   reach = w λ;  (C, n) = the first smallest |x − q_s| − r over the
//           simplices s whose boxes meet x ± (r + reach + pad), in index
//           order (simplex_walk.wgsl, closest_point.wgsl)
//   none visited, C > reach or n = 0 → no update (the slot keeps λ)
//   Δλ = (−C − α~ λ)/(w + α~);  λ' = max(λ + Δλ, 0);  x += w n (λ' − λ)
//   static friction (μ > 0, λ' > 0) with this n (project.wgsl)
//   friction   λ > 0: n at the substep's final x within reach w λ, then
//              friction.wgsl's dynamic friction with that n
//   residual   max(0, −C) with reach 0
//
// Composed only into the step modules of plans with mesh families
// (gpu/src/xpbd/mesh.rs; mesh_off.wgsl stands in elsewhere). The meshes,
// in device coordinates (x − o), laid out by gpu/src/xpbd/mesh.rs:
//   mesh_words[f]          family f's mesh header h (NONE: not a mesh family)
//   mesh_words[h .. h + 3] (reals base b, words base k, simplices S)
//   mesh_reals[b]          the rounding scale (largest |coordinate|)
//   mesh_reals[b + 1 ..]   vertices (S · SLOTS · DIM), then node boxes
//                          ((2S − 1) · 2 · DIM: lo then hi per node)
//   mesh_words[k ..]       arity of each simplex, then node words
//                          (right, first, last per node)

@group(0) @binding(16) var<storage, read> mesh_reals: array<real>;
@group(0) @binding(17) var<storage, read> mesh_words: array<u32>;

const SLOTS: u32 = 4u;

// The mesh the running call reads (use_mesh).
var<private> mesh_real_base: u32;
var<private> mesh_word_base: u32;
var<private> mesh_simplices: u32;

fn use_mesh(family: u32) {
    let h = mesh_words[family];
    mesh_real_base = mesh_words[h];
    mesh_word_base = mesh_words[h + 1u];
    mesh_simplices = mesh_words[h + 2u];
}

// The accessors closest_point.wgsl and simplex_walk.wgsl read (no planes).
fn vertex(s: u32, j: u32, a: u32) -> real {
    return mesh_reals[mesh_real_base + 1u + (s * SLOTS + j) * DIM + a];
}

fn simplex_arity(s: u32) -> u32 {
    return mesh_words[mesh_word_base + s];
}

fn walk_planes() -> u32 {
    return 0u;
}

fn walk_simplices() -> u32 {
    return mesh_simplices;
}

fn walk_scale() -> real {
    return mesh_reals[mesh_real_base];
}

fn node_word(n: u32, k: u32) -> u32 {
    return mesh_words[mesh_word_base + mesh_simplices + n * 3u + k];
}

fn node_bound(n: u32, k: u32) -> real {
    return mesh_reals[mesh_real_base + 1u + mesh_simplices * SLOTS * DIM + n * 2u * DIM + k];
}

// C (and n) of the contact of a particle at p with radius r against the
// running call's mesh, for reach `reach` (the header above); `found`
// false out of reach or without a direction. A NaN distance is kept
// (kinds::mesh_contact::first_closest) and fails the update.
struct MeshHit {
    c: real,
    found: bool,
}

fn mesh_closest(p: ptr<function, array<real, DIM>>, r: real, reach: real,
                normal: ptr<function, array<real, DIM>>) -> MeshHit {
    var walk = walk_start(p, r, reach);
    var best: real = 0.0;
    var visited = false;
    var n: array<real, DIM>;
    for (var s = walk_next(&walk); s != WALK_END; s = walk_next(&walk)) {
        let c = simplex_distance(s, p, r, &n);
        if (!visited || c < best || (!(c == c) && best == best)) {
            visited = true;
            best = c;
            for (var a = 0u; a < DIM; a++) {
                (*normal)[a] = n[a];
            }
        }
    }
    var hit: MeshHit;
    hit.c = best;
    hit.found = false;
    if (!visited || best > reach) {
        return hit;
    }
    for (var a = 0u; a < DIM; a++) {
        if ((*normal)[a] != 0.0) {
            hit.found = true;
        }
    }
    return hit;
}

// Coordinates of a record.
fn record_point(r: ptr<function, Record>) -> array<real, DIM> {
    var p: array<real, DIM>;
    for (var a = 0u; a < DIM; a++) {
        p[a] = lane(r, a);
    }
    return p;
}

// The mesh contact of particle i (its records in registers); leaves the
// slot and λ for friction as contact_particle does (project.wgsl).
fn mesh_contact_particle(i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>, rp: ptr<function, Record>) {
    let e = enter_contact(i);
    if (e == NONE) {
        return;
    }
    let s = call.slot_base + e;
    let w = inverse_mass_of(rx);
    let l = lambda_before(s);
    var p = record_point(rx);
    var n: array<real, DIM>;
    use_mesh(call.family);
    let hit = mesh_closest(&p, rest_at(s), w * l, &n);
    if (!hit.found) {
        no_response(s);
        contact_l = l;
        return;
    }
    if (!contact_response(e, hit.c, l, rx, &n)) {
        return;
    }
    let mu = call.friction;
    if (mu > 0.0 && contact_l > 0.0) {
        static_friction(rx, rp, &n, mu * w * contact_l);
    }
}

// Dynamic friction of a mesh family on particle i (friction.wgsl's slot
// and λ lookup), with the mesh's n at the final x.
fn mesh_friction_particle(i: u32, rx: ptr<function, Record>, rv: ptr<function, Record>, rp: ptr<function, Record>) {
    if (skipped()) {
        return;
    }
    let slot = friction_slot(i);
    if (slot.e == NONE || slot.l <= 0.0) {
        return;
    }
    var p = record_point(rx);
    var n: array<real, DIM>;
    use_mesh(call.family);
    let hit = mesh_closest(&p, rest_at(call.slot_base + slot.e), inverse_mass_of(rx) * slot.l, &n);
    if (hit.found) {
        dynamic_friction(i, rx, rv, slot.l, &n);
    }
}

// max(0, −C) of slot s of the running residual call at p (reach 0).
fn mesh_violation(s: u32, p: ptr<function, array<real, DIM>>) -> real {
    var n: array<real, DIM>;
    use_mesh(call.family);
    let hit = mesh_closest(p, rest_at(s), 0.0, &n);
    if (!hit.found) {
        return 0.0;
    }
    return max(-hit.c, 0.0);
}
