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
//   moving     (FLAG_MOVING) the query point mapped into the mesh's frame,
//              y = Rᵀ x + e, and n turned back, n = R n_f
//              (core/src/moving_mesh.rs); static friction against
//              q = D(p) + p and dynamic friction on v − D(p)/h
//              (motion.wgsl's carried_start, carried_friction). The values
//              of a substep at rest[F]: Ā (DIM²), Rᵀ (DIM²), e (DIM) with
//              FLAG_ROTATES, e alone without; F = call.chunk on the contact
//              and friction calls, the mesh header's F on the residual call
//              (the last substep's)
//
// Composed only into the step modules of plans with mesh families
// (gpu/src/xpbd/mesh.rs; mesh_off.wgsl stands in elsewhere). The meshes,
// in device coordinates (x − o), laid out by gpu/src/xpbd/mesh.rs:
//   mesh_words[f]          family f's mesh header h (NONE: not a mesh family)
//   mesh_words[h .. h + 4] (reals base b, words base k, simplices S, frame F)
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

// y = Rᵀ p + e into p: p into the frame of the running moving-mesh call's
// mesh, whose values start at rest[frame] (the header above).
fn to_mesh_frame(p: ptr<function, array<real, DIM>>, frame: u32) {
    let x = *p;
    if ((call.flags & FLAG_ROTATES) == 0u) {
        for (var a = 0u; a < DIM; a++) {
            (*p)[a] = x[a] + rest_at(frame + a);
        }
        return;
    }
    let offset = frame + 2u * DIM * DIM;
    for (var a = 0u; a < DIM; a++) {
        var s: real = 0.0;
        for (var b = 0u; b < DIM; b++) {
            s += rest_at(frame + DIM * DIM + a * DIM + b) * x[b];
        }
        (*p)[a] = kept(s) + rest_at(offset + a);
    }
}

// n ← R n: a normal of the frame back to the world (FLAG_ROTATES only).
fn mesh_normal_back(n: ptr<function, array<real, DIM>>, frame: u32) {
    if ((call.flags & FLAG_ROTATES) == 0u) {
        return;
    }
    let f = *n;
    for (var a = 0u; a < DIM; a++) {
        var s: real = 0.0;
        for (var b = 0u; b < DIM; b++) {
            s += rest_at(frame + DIM * DIM + b * DIM + a) * f[b];
        }
        (*n)[a] = kept(s);
    }
}

// Whether the running contact or friction call's mesh moves.
fn mesh_moves() -> bool {
    return (call.flags & FLAG_MOVING) != 0u;
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
    if (mesh_moves()) {
        to_mesh_frame(&p, call.chunk);
    }
    var n: array<real, DIM>;
    use_mesh(call.family);
    let hit = mesh_closest(&p, rest_at(s), w * l, &n);
    if (!hit.found) {
        no_response(s);
        contact_l = l;
        return;
    }
    if (mesh_moves()) {
        mesh_normal_back(&n, call.chunk);
    }
    if (!contact_response(e, hit.c, l, rx, &n)) {
        return;
    }
    let mu = call.friction;
    if (mu > 0.0 && contact_l > 0.0) {
        if (mesh_moves()) {
            var q = carried_start(rp);
            static_friction(rx, &q, &n, mu * w * contact_l);
        } else {
            static_friction(rx, rp, &n, mu * w * contact_l);
        }
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
    if (mesh_moves()) {
        to_mesh_frame(&p, call.chunk);
    }
    var n: array<real, DIM>;
    use_mesh(call.family);
    let hit = mesh_closest(&p, rest_at(call.slot_base + slot.e), inverse_mass_of(rx) * slot.l, &n);
    if (!hit.found) {
        return;
    }
    if (mesh_moves()) {
        mesh_normal_back(&n, call.chunk);
        carried_friction(i, rx, rv, rp, slot.l, &n);
    } else {
        dynamic_friction(i, rx, rv, slot.l, &n);
    }
}

// max(0, −C) of slot s of the running residual call at p (reach 0; a
// moving mesh where the last substep placed it).
fn mesh_violation(s: u32, p: ptr<function, array<real, DIM>>) -> real {
    var n: array<real, DIM>;
    use_mesh(call.family);
    let frame = mesh_words[mesh_words[call.family] + 3u];
    if (frame != NONE) {
        to_mesh_frame(p, frame);
    }
    let hit = mesh_closest(p, rest_at(s), 0.0, &n);
    if (!hit.found) {
        return 0.0;
    }
    return max(-hit.c, 0.0);
}
