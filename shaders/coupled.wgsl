// The coupled implicit step (docs/implicit.md §7; golden: cpu/src/coupled/):
// its bindings, records and element passes; composed after measure.wgsl
// (distance, simplex measures) and barrier.wgsl (its bindings 0..=10,
// obstacle_distance, barrier_law with ln_real, check_loops);
// coupled_particles.wgsl (the particle passes), coupled_solve.wgsl and the
// material elements' file
// (coupled_material.wgsl, after material.wgsl, symmetric_eigen.wgsl and
// material_hessian.wgsl) follow. Same arithmetic, in the same order, as the
// f64 golden path.
//
//   point  binding 0 (`x`): where the evaluation passes look (x_k or a trial)
//   vectors[R·n·DIM + k]: the step's vectors by region R (R_* below)
//   element e  [energy, c0, c1, ∇E (W), aux (W)],  W = A·DIM, A = arity_max
//     spring  c = (along, across) radial (distance, tether) | (1/α, 0) Gauss–Newton;  aux = ∇C
//     ball    c = (along, across) of K⁺ = b'' n nᵀ;                              aux = ∇d = (−n, n)
//     lag     c = (along, across) of the tangent K (friction.rs);                aux = (û, 0)
//     material  c = 0, aux = 0: its record, slots and change are written by
//             coupled_material.wgsl (the passes here skip the dense-block codes ELEMENT_MATERIAL and
//             ELEMENT_EXPRESSION)
//   gather  particle k adds its slots (element order, member order): no atomics
//   tree    per-item terms written at a channel's offset, reduced by cp_reduce:
//           blocks of 64 halved in place (s[t] ⊕= s[t + stride], 32 … 1), the
//           block tree of core/src/implicit/reduction.rs, level after level
//   ∞       WGSL has no infinity literal: REAL_MAX stands for +∞ (energies
//           at d ≤ 0, times with no approach); the host reads it back as ∞
//   status  [0] a coordinate moved / a trial differs from x (flag)
//           [1] first particle with a non-finite gradient or energy
//           [2] first particle starting at d ≤ 0 from an obstacle
//           [3] first element with a non-finite record
//           [4] first particle whose loops llvmpipe cut short (check_loops)

struct CoupledParams {
    elements: u32,   // E
    arity_max: u32,  // A
    criterion: u32,  // 0 packed gradient, 1 max acceleration residual
    diagonal: u32,   // cp_slots: 1 the diagonal of K⁺, 0 K⁺ p
    first_ball: u32, // elements from here on are ball pairs
    channel_a: u32,  // tree offsets of the channels
    channel_b: u32,
    channel_e: u32,
    channel_t: u32,
    pairs: u32,      // ball pairs (elements first_ball ..)
    mode: u32,       // cp_set_x: 0 warm start, 1 x^t, 2 the trial
    mesh_friction: u32, // 1: some simplex has μ > 0 (simplex lags are walked at x^t)
    h: real,
    h2: real,
    slip: real,      // ε = ε_v h
    step: real,      // τ (warm start), t (trial)
    epsilon: real,   // the filter's ε
}

// PCG's scalar recurrence on the device (coupled_solve.wgsl, cp_cg_alpha
// and cp_cg_beta: core's pcg_on after its start, decision for decision).
// status: 0 running, 1 converged, 2 non-finite, 3 non-positive curvature,
// 4 budget exhausted. While `stopped` is set, the CG passes (cp_slots,
// cp_particle_curvature, cp_cg_residual, cp_cg_turn) do nothing, so a
// submission may record more iterations than run.
struct CgState {
    pq_at: u32,          // tree offsets of p·q, r·r and r·z
    rr_at: u32,
    rz_at: u32,
    iterations: u32,
    max_iterations: u32,
    status: u32,
    stopped: u32,
    pad: u32,
    rho: real,           // r·z of the current residual
    tolerance: real,
    curvature: real,     // the last p·q
    residual: real,      // the last ‖r‖
    alpha: real,
    beta: real,
}

struct Level {
    src: u32,
    dst: u32,
    len: u32,
    op: u32, // 0 sum, 1 max (pad 0), 2 min (pad REAL_MAX)
}

@group(0) @binding(11) var<storage, read_write> v: array<real>;
@group(0) @binding(12) var<storage, read> force: array<real>;
@group(0) @binding(13) var<storage, read> mass: array<real>;
@group(0) @binding(14) var<storage, read> gravity_scale: array<real>;
@group(0) @binding(15) var<storage, read> gravity: array<real>;
@group(0) @binding(16) var<storage, read> obstacle_mu: array<real>; // μ per plane, then per simplex
@group(0) @binding(17) var<storage, read_write> lag_force: array<real>;
// [codes (E) | arities (E) | members (E·A)]: codes 0 distance, 1 tether,
// 2 simplex measure, 3 oriented measure, 4 ball pair, 5 pair friction lag,
// 6 material element
@group(0) @binding(18) var<storage, read> element_words: array<u32>;
// DIM + 1 per element: [compliance, rest] (springs), [F_max, n] (friction lags),
// [μ, λ] (materials)
@group(0) @binding(19) var<storage, read> element_reals: array<real>;
// [offsets (n + 1) | slots]
@group(0) @binding(20) var<storage, read> gather: array<u32>;
@group(0) @binding(21) var<storage, read_write> records: array<real>;
@group(0) @binding(22) var<storage, read_write> slots: array<real>;
@group(0) @binding(23) var<storage, read_write> vectors: array<real>;
// per particle: B_i (DIM²), its energy, its force rounding
@group(0) @binding(24) var<storage, read_write> terms: array<real>;
@group(0) @binding(25) var<storage, read_write> tree: array<real>;
@group(0) @binding(26) var<storage, read> cp: CoupledParams;
@group(0) @binding(27) var<storage, read_write> cg: CgState;
@group(1) @binding(0) var<storage, read> level: Level;

const R_GRADIENT: u32 = 0u;
const R_DIRECTION: u32 = 1u;
const R_INVERSE: u32 = 2u;
const R_TRIAL: u32 = 3u;
const R_R: u32 = 4u;
const R_Z: u32 = 5u;
const R_P: u32 = 6u;
const R_Q: u32 = 7u;
const R_X: u32 = 8u;
const R_START: u32 = 9u;
const R_PREDICTION: u32 = 10u;
const R_LOAD: u32 = 11u;

const TERMS: u32 = DIM * DIM + 2u;
// ELEMENT_* (the element codes) come from the generated header (gpu/src/codes.rs).
// Reals per element in element_reals.
const ELEMENT_REALS: u32 = DIM + 1u;

var<workgroup> block: array<real, WORKGROUP>;

fn at(region: u32, k: u32) -> u32 {
    return region * bp.count * DIM + k;
}

fn record_len() -> u32 {
    return 3u + 2u * cp.arity_max * DIM;
}

fn code_of(e: u32) -> u32 {
    return element_words[e];
}

// Element e is a dense block of coupled_material.wgsl (a material or an
// expression element).
fn dense_block(e: u32) -> bool {
    let code = code_of(e);
    return code == ELEMENT_MATERIAL || code == ELEMENT_EXPRESSION;
}

fn arity_of(e: u32) -> u32 {
    return element_words[cp.elements + e];
}

fn member(e: u32, j: u32) -> u32 {
    return element_words[2u * cp.elements + e * cp.arity_max + j];
}

fn finite(value: real) -> bool {
    return abs(value) <= REAL_MAX;
}

// ---------------------------------------------------------------- elements

struct Element {
    energy: real,
    c0: real,
    c1: real,
    count: u32,
    gradient: array<real, POINTS>,
    aux: array<real, POINTS>,
}

// The radial K⁺ of φ' = first, φ'' = second at length ℓ (radial.rs):
// (max(φ'', 0), max(φ'/ℓ, 0)), zero when ℓ = 0.
fn radial(first: real, second: real, length: real, out: ptr<function, Element>) {
    (*out).c0 = 0.0;
    (*out).c1 = 0.0;
    if (length > 0.0) {
        (*out).c0 = max(second, 0.0);
        (*out).c1 = max(first / length, 0.0);
    }
}

// The lagged friction of slip w against the unit normal n with F_max =
// `limit` (friction.rs tangent_term): u = (I − n nᵀ) w, y = |u|,
// energy F f₀(y), gradient F g(y) u, K along û F f₁'(y), across F g(y).
struct Tangent {
    energy: real,
    along: real,
    across: real,
    gradient: array<real, DIM>,
    direction: array<real, DIM>, // û (0 at y = 0)
}

fn tangent(n: array<real, DIM>, limit: real, w: array<real, DIM>) -> Tangent {
    var out: Tangent;
    var s: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        s += n[a] * w[a];
    }
    var y2: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        let u = w[a] - s * n[a];
        out.direction[a] = u;
        y2 += u * u;
    }
    let y = sqrt(y2);
    let m = mollifier(y, cp.slip);
    var g: real;
    if (y < cp.slip) {
        g = (2.0 - y / cp.slip) / cp.slip;
    } else {
        g = 1.0 / y;
    }
    let scale = limit * g;
    for (var a = 0u; a < DIM; a++) {
        out.gradient[a] = scale * out.direction[a];
    }
    var inverse: real = 0.0;
    if (y > 0.0) {
        inverse = 1.0 / y;
    }
    for (var a = 0u; a < DIM; a++) {
        out.direction[a] *= inverse;
    }
    out.energy = limit * m.x;
    out.along = limit * m.y;
    out.across = scale;
    return out;
}

// Mollifier f₀, f₁' of the slip y with slip length ε (friction.rs).
fn mollifier(y: real, epsilon: real) -> vec2<real> {
    if (y < epsilon) {
        let q = y / epsilon;
        let f0 = -y * q * q / 3.0 + y * q + epsilon / 3.0;
        let f1_prime = (2.0 - 2.0 * q) / epsilon;
        return vec2<real>(f0, f1_prime);
    }
    return vec2<real>(y, 0.0);
}

// Element e at the point buffer (springs.rs, ball_barrier.rs, friction.rs).
fn evaluate_element(e: u32) -> Element {
    var out: Element;
    let code = code_of(e);
    let arity = arity_of(e);
    var pts: array<real, POINTS>;
    for (var j = 0u; j < DIM + 1u; j++) {
        if (j < arity) {
            let i = member(e, j);
            for (var a = 0u; a < DIM; a++) {
                pts[j * DIM + a] = x[i * DIM + a];
            }
        }
    }
    // Local arrays: naga's SPIR-V back end cannot pass a pointer to a
    // struct member to a function.
    var aux: array<real, POINTS>;
    for (var c = 0u; c < POINTS; c++) {
        out.gradient[c] = 0.0;
        aux[c] = 0.0;
    }
    out.count = arity * DIM;
    out.c0 = 0.0;
    out.c1 = 0.0;
    if (code == ELEMENT_BALL) {
        let length = distance(&pts, &aux);
        out.aux = aux;
        let d = length - radius[member(e, 0u)] - radius[member(e, 1u)];
        if (d >= bp.activation) {
            out.energy = 0.0;
            return out;
        }
        if (!(d > 0.0)) {
            out.energy = REAL_MAX;
            return out;
        }
        let law = barrier_law(d);
        for (var c = 0u; c < 2u * DIM; c++) {
            out.gradient[c] = law.y * out.aux[c];
        }
        out.energy = law.x;
        radial(law.y, law.z, length, &out);
        return out;
    }
    if (code == ELEMENT_LAG) {
        // w = (x_j − x_j^t) − (x_i − x_i^t); ∇_j = F g u, ∇_i = −∇_j.
        let i = member(e, 0u);
        let j = member(e, 1u);
        var n: array<real, DIM>;
        var w: array<real, DIM>;
        for (var a = 0u; a < DIM; a++) {
            n[a] = element_reals[e * ELEMENT_REALS + 1u + a];
            w[a] = (pts[DIM + a] - vectors[at(R_START, j * DIM + a)])
                - (pts[a] - vectors[at(R_START, i * DIM + a)]);
        }
        let t = tangent(n, element_reals[e * ELEMENT_REALS], w);
        for (var a = 0u; a < DIM; a++) {
            out.gradient[DIM + a] = t.gradient[a];
            out.gradient[a] = -t.gradient[a];
            out.aux[a] = t.direction[a];
        }
        out.energy = t.energy;
        out.c0 = t.along;
        out.c1 = t.across;
        return out;
    }
    let compliance = element_reals[e * ELEMENT_REALS];
    let rest = element_reals[e * ELEMENT_REALS + 1u];
    var value: real;
    if (code == ELEMENT_SIMPLEX) {
        value = simplex_squared_measure(&pts, arity - 1u, &aux);
    } else if (code == ELEMENT_ORIENTED) {
        value = oriented_measure(&pts, &aux);
    } else if (code == ELEMENT_DISTANCE || code == ELEMENT_TETHER) {
        value = distance(&pts, &aux);
    } else {
        // No other code is uploaded (gpu/src/codes.rs); an unknown one is
        // never another kind: its energy refuses every iterate.
        out.energy = REAL_MAX;
        return out;
    }
    out.aux = aux;
    let c = value - rest;
    if (code == ELEMENT_TETHER && c <= 0.0) {
        out.energy = 0.0;
        return out;
    }
    let f = c / compliance;
    for (var k = 0u; k < POINTS; k++) {
        if (k < out.count) {
            out.gradient[k] = f * out.aux[k];
        }
    }
    out.energy = c * c / (2.0 * compliance);
    if (code == ELEMENT_DISTANCE || code == ELEMENT_TETHER) {
        radial(f, 1.0 / compliance, value, &out);
    } else {
        out.c0 = 1.0 / compliance;
    }
    return out;
}

// Records at the point buffer; the first element whose record is not
// finite into status[3].
@compute @workgroup_size(WORKGROUP)
fn cp_elements(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let e = linear_index(gid, groups);
    if (e >= cp.elements || dense_block(e)) {
        return;
    }
    let value = evaluate_element(e);
    let base = e * record_len();
    let width = cp.arity_max * DIM;
    records[base] = value.energy;
    records[base + 1u] = value.c0;
    records[base + 2u] = value.c1;
    var ok = finite(value.energy) && value.energy < REAL_MAX && finite(value.c0) && finite(value.c1);
    for (var k = 0u; k < POINTS; k++) {
        if (k < width) {
            records[base + 3u + k] = value.gradient[k];
            records[base + 3u + width + k] = value.aux[k];
            ok = ok && finite(value.gradient[k]) && finite(value.aux[k]);
        }
    }
    if (!ok) {
        atomicMin(&status[3], e);
    }
}

// E_e(point) − E_e(records) into channel E.
@compute @workgroup_size(WORKGROUP)
fn cp_element_changes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let e = linear_index(gid, groups);
    if (e >= cp.elements || dense_block(e)) {
        return;
    }
    let value = evaluate_element(e);
    var change = REAL_MAX;
    if (value.energy < REAL_MAX) {
        change = value.energy - records[e * record_len()];
    }
    tree[cp.channel_e + e] = change;
}

// K⁺ p_e (p from R_P) or the diagonal of K⁺ into element e's slots
// (nothing once PCG has stopped).
@compute @workgroup_size(WORKGROUP)
fn cp_slots(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let e = linear_index(gid, groups);
    if (e >= cp.elements || cg.stopped != 0u || dense_block(e)) {
        return;
    }
    let code = code_of(e);
    let arity = arity_of(e);
    let base = e * record_len();
    let width = cp.arity_max * DIM;
    let aux = base + 3u + width;
    let slot = e * width;
    var p: array<real, POINTS>;
    for (var j = 0u; j < DIM + 1u; j++) {
        if (j < arity) {
            let i = member(e, j);
            for (var a = 0u; a < DIM; a++) {
                p[j * DIM + a] = vectors[at(R_P, i * DIM + a)];
            }
        }
    }
    let along = records[base + 1u];
    let across = records[base + 2u];
    if (code == ELEMENT_SIMPLEX || code == ELEMENT_ORIENTED) {
        // Gauss–Newton: weight ∇C ∇Cᵀ.
        let count = arity * DIM;
        if (cp.diagonal == 1u) {
            for (var k = 0u; k < POINTS; k++) {
                if (k < count) {
                    slots[slot + k] = along * records[aux + k] * records[aux + k];
                }
            }
            return;
        }
        var s: real = 0.0;
        for (var k = 0u; k < POINTS; k++) {
            if (k < count) {
                s += records[aux + k] * p[k];
            }
        }
        let scale = along * s;
        for (var k = 0u; k < POINTS; k++) {
            if (k < count) {
                slots[slot + k] = scale * records[aux + k];
            }
        }
        return;
    }
    if (code == ELEMENT_LAG) {
        // Tangent K of the lag (friction.rs apply_pair, diagonal): n the
        // lag's normal, û = aux[0..DIM].
        let base_n = e * ELEMENT_REALS + 1u;
        if (cp.diagonal == 1u) {
            for (var a = 0u; a < DIM; a++) {
                let n = element_reals[base_n + a];
                let u = records[aux + a];
                let d = across * (1.0 - n * n) + (along - across) * u * u;
                slots[slot + a] = d;
                slots[slot + DIM + a] = d;
            }
            return;
        }
        var v: array<real, DIM>;
        var s_n: real = 0.0;
        var s_u: real = 0.0;
        for (var a = 0u; a < DIM; a++) {
            v[a] = p[DIM + a] - p[a];
        }
        for (var a = 0u; a < DIM; a++) {
            s_n += element_reals[base_n + a] * v[a];
            s_u += records[aux + a] * v[a];
        }
        let extra = (along - across) * s_u;
        for (var a = 0u; a < DIM; a++) {
            let y = across * (v[a] - s_n * element_reals[base_n + a]) + extra * records[aux + a];
            slots[slot + DIM + a] = y;
            slots[slot + a] = -y;
        }
        return;
    }
    // Radial: normal n = aux[DIM..2DIM] (radial.rs).
    if (cp.diagonal == 1u) {
        for (var a = 0u; a < DIM; a++) {
            let n = records[aux + DIM + a];
            let nn = n * n;
            let d = along * nn + across * (1.0 - nn);
            slots[slot + a] = d;
            slots[slot + DIM + a] = d;
        }
        return;
    }
    var s: real = 0.0;
    for (var a = 0u; a < DIM; a++) {
        s += records[aux + DIM + a] * (p[DIM + a] - p[a]);
    }
    for (var a = 0u; a < DIM; a++) {
        let w = p[DIM + a] - p[a];
        let r = s * records[aux + DIM + a];
        let y = along * r + across * (w - r);
        slots[slot + a] = -y;
        slots[slot + DIM + a] = y;
    }
}
