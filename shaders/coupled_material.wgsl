// Material elements (StVK, Neo-Hookean) of the coupled implicit step
// (docs/implicit.md §2, §12; golden: cpu/src/coupled/elements/materials.rs),
// composed after coupled.wgsl with material.wgsl, symmetric_eigen.wgsl and
// material_hessian.wgsl. One invocation per material block m (the m-th
// material element in element order); coupled.wgsl's element passes skip
// these elements (code ELEMENT_MATERIAL), these passes write their records, slots
// and changes in the same layout.
//
// Expression elements (their family's ∇²C spring; golden:
// core/src/implicit/expression_spring.rs) are dense blocks here too: code
// ELEMENT_EXPRESSION, their K⁺ ((arity·N)²) in `frames`, their energy,
// block and family index k from the generated coupled_expression_energy /
// coupled_expression_block (gpu/src/coupled/expression.rs).
//
//   material_words  [frame stride, blocks M, then per block: element e,
//                    rest offset of its family, slot in the family, flags];
//                    an expression block: [e, offset of its per-element
//                    constants in material_rest, slot, its family index k]
//   material_rest   per family, per slot: R (k × k), V_0   (material.wgsl's layout)
//   element_reals   [μ, λ] of a material element
//   frames          H_F⁺ per block, `frame stride` reals ((N k_max)²), written by
//                   cp_material_frames once per Newton iteration (step 6)
//
//   cp_material_elements  W, ∇W at the point buffer; refused (NH: J ≤ 0) → +∞,
//                         ∇W = 0; a non-finite record → status[3]
//   cp_material_changes   W(point) − W(record), +∞ (REAL_MAX) where refused
//   cp_material_frames    H_F⁺ = project_psd(H_F) at the point buffer;
//                         refused or not finite → status[3]
//   cp_material_slots     K_e⁺ p_e (p from R_P) or its diagonal into the slots
//                         (nothing once PCG has stopped, as cp_slots)
//   loops cut short       status[4] = MATERIAL_LOOPS | e (the host names the element)

@group(0) @binding(28) var<storage, read> material_words: array<u32>;
@group(0) @binding(29) var<storage, read> material_rest: array<real>;
@group(0) @binding(30) var<storage, read_write> frames: array<real>;

const MATERIAL_HEADER: u32 = 2u;
const MATERIAL_WORDS: u32 = 4u;
// status[4] of a material element whose loops llvmpipe cut short: the
// element's index with this bit (a particle's index, below it, wins).
const MATERIAL_LOOPS: u32 = 0x80000000u;

// check_loops (barrier.wgsl) for material element e: the Jacobi sweeps of
// an (N k)² frame Hessian reach llvmpipe's loop budget from N k ≈ 20.
fn check_material_loops(e: u32) {
    check_loops(MATERIAL_LOOPS | e);
}

// The fields of material.wgsl's running call.
struct MaterialCall {
    arity: u32,
    slot_map: u32,
    flags: u32,
    friction: real, // Lamé μ
    factor: real,   // Lamé λ
}

var<private> call: MaterialCall;
// The running block's expression family index k (NO_EXPRESSION: a
// material) and the offset of its per-element constants in material_rest.
var<private> block_expression: u32;
var<private> block_constants: u32;
const NO_EXPRESSION: u32 = 0xffffffffu;

// False at run time, unknown to the compiler: the generated tapes' guard
// against regrouping and fusing (core/src/expr/wgsl.rs).
fn coupled_opaque() -> bool {
    return material_words[1] == 0xffffffffu;
}

fn rest_at(s: u32) -> real {
    return material_rest[s];
}

fn material_blocks() -> u32 {
    return material_words[1];
}

// Sets `call` for block m; its element's index.
fn take_material(m: u32) -> u32 {
    let at = MATERIAL_HEADER + m * MATERIAL_WORDS;
    let e = material_words[at];
    call.arity = arity_of(e);
    call.slot_map = material_words[at + 1u];
    call.flags = material_words[at + 3u];
    call.friction = element_reals[e * ELEMENT_REALS];
    call.factor = element_reals[e * ELEMENT_REALS + 1u];
    block_expression = NO_EXPRESSION;
    if (code_of(e) == ELEMENT_EXPRESSION) {
        // [compliance, rest] in `friction`, `factor`.
        block_expression = material_words[at + 3u];
        block_constants = material_words[at + 1u];
    }
    return e;
}

// Slot of block m in its family.
fn material_slot(m: u32) -> u32 {
    return material_words[MATERIAL_HEADER + m * MATERIAL_WORDS + 2u];
}

// Element e's vertices at the point buffer.
fn material_points(e: u32) -> array<real, POINTS> {
    var pts: array<real, POINTS>;
    for (var c = 0u; c < POINTS; c++) {
        pts[c] = 0.0;
    }
    for (var j = 0u; j < call.arity; j++) {
        let i = member(e, j);
        for (var a = 0u; a < DIM; a++) {
            pts[j * DIM + a] = x[i * DIM + a];
        }
    }
    return pts;
}

// W of block m at the point buffer (REAL_MAX where the law refuses), ∇W
// into `grad` (0 there).
fn material_term_at_point(m: u32, e: u32, grad: ptr<function, array<real, POINTS>>) -> real {
    var pts = material_points(e);
    for (var c = 0u; c < POINTS; c++) {
        (*grad)[c] = 0.0;
    }
    if (block_expression != NO_EXPRESSION) {
        return coupled_expression_energy(block_expression, call.friction, call.factor, &pts, grad);
    }
    var refused = false;
    let energy = material_energy(material_slot(m), &pts, grad, &refused);
    if (refused) {
        for (var c = 0u; c < POINTS; c++) {
            (*grad)[c] = 0.0;
        }
        return REAL_MAX;
    }
    return energy;
}

@compute @workgroup_size(WORKGROUP)
fn cp_material_elements(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let m = linear_index(gid, groups);
    if (m >= material_blocks()) {
        return;
    }
    let e = take_material(m);
    var grad: array<real, POINTS>;
    let energy = material_term_at_point(m, e, &grad);
    let base = e * record_len();
    let width = cp.arity_max * DIM;
    records[base] = energy;
    records[base + 1u] = 0.0;
    records[base + 2u] = 0.0;
    var ok = finite(energy) && energy < REAL_MAX;
    for (var k = 0u; k < width; k++) {
        var g: real = 0.0;
        if (k < POINTS) {
            g = grad[k];
        }
        records[base + 3u + k] = g;
        records[base + 3u + width + k] = 0.0;
        ok = ok && finite(g);
    }
    if (!ok) {
        atomicMin(&status[3], e);
    }
    check_material_loops(e);
}

@compute @workgroup_size(WORKGROUP)
fn cp_material_changes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let m = linear_index(gid, groups);
    if (m >= material_blocks()) {
        return;
    }
    let e = take_material(m);
    var grad: array<real, POINTS>;
    let energy = material_term_at_point(m, e, &grad);
    var change = REAL_MAX;
    if (energy < REAL_MAX) {
        change = energy - records[e * record_len()];
    }
    tree[cp.channel_e + e] = change;
    check_material_loops(e);
}

@compute @workgroup_size(WORKGROUP)
fn cp_material_frames(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let m = linear_index(gid, groups);
    if (m >= material_blocks()) {
        return;
    }
    let e = take_material(m);
    var pts = material_points(e);
    var h: array<real, HESS>;
    var size = DIM * (call.arity - 1u);
    var ok = false;
    if (block_expression != NO_EXPRESSION) {
        size = DIM * call.arity;
        ok = coupled_expression_block(block_expression, call.friction, call.factor, &pts, &h);
    } else {
        ok = material_frame_hessian(material_slot(m), &pts, &h);
        if (ok) {
            ok = project_psd(&h, size);
        }
    }
    let block = m * material_words[0];
    for (var t = 0u; t < size * size; t++) {
        frames[block + t] = h[t];
    }
    if (!ok) {
        atomicMin(&status[3], e);
    }
    check_material_loops(e);
}

@compute @workgroup_size(WORKGROUP)
fn cp_material_slots(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let m = linear_index(gid, groups);
    if (m >= material_blocks() || cg.stopped != 0u) {
        return;
    }
    let e = take_material(m);
    let block = m * material_words[0];
    let slot = material_slot(m);
    var out: array<real, POINTS>;
    var p: array<real, POINTS>;
    if (cp.diagonal != 1u) {
        for (var j = 0u; j < call.arity; j++) {
            let i = member(e, j);
            for (var a = 0u; a < DIM; a++) {
                p[j * DIM + a] = vectors[at(R_P, i * DIM + a)];
            }
        }
    }
    if (block_expression != NO_EXPRESSION) {
        dense_curvature(block, call.arity * DIM, &p, &out);
    } else if (cp.diagonal == 1u) {
        material_curvature_diagonal(slot, block, &out);
    } else {
        material_curvature_product(slot, block, &p, &out);
    }
    let width = cp.arity_max * DIM;
    let count = call.arity * DIM;
    for (var k = 0u; k < count; k++) {
        slots[e * width + k] = out[k];
    }
    check_material_loops(e);
}

// out = K⁺ p (an expression element's dense n × n block at `frames[block ..]`,
// s ascending per row), or its diagonal (cp.diagonal; core's apply_dense).
fn dense_curvature(block: u32, n: u32, p: ptr<function, array<real, POINTS>>,
                   out: ptr<function, array<real, POINTS>>) {
    for (var r = 0u; r < n; r++) {
        if (cp.diagonal == 1u) {
            (*out)[r] = frames[block + r * n + r];
        } else {
            var y: real = 0.0;
            for (var s = 0u; s < n; s++) {
                y += frames[block + r * n + s] * (*p)[s];
            }
            (*out)[r] = y;
        }
    }
}

// out = V_0 Sᵀ(R ⊗ I) H (Rᵀ ⊗ I) S p for the gathered element vector `p`
// and the frame Hessian at `frames[block ..]`.
fn material_curvature_product(e: u32, block: u32, p: ptr<function, array<real, POINTS>>,
                              out: ptr<function, array<real, POINTS>>) {
    let k = call.arity - 1u;
    let size = DIM * k;
    let base = call.slot_map + e * (k * k + 1u);
    let v0 = rest_at(base + k * k);
    var df: array<real, MAT>;
    material_frame_change(base, k, p, &df);
    var yf: array<real, MAT>;
    for (var row = 0u; row < size; row++) {
        var v: real = 0.0;
        for (var q = 0u; q < size; q++) {
            v += frames[block + row * size + q] * df[q];
        }
        yf[row] = v;
    }
    material_point_forces(base, k, v0, &yf, out);
}

// The diagonal of the vertex block of [`material_curvature_product`] into `out`.
fn material_curvature_diagonal(e: u32, block: u32, out: ptr<function, array<real, POINTS>>) {
    let k = call.arity - 1u;
    let size = DIM * k;
    let base = call.slot_map + e * (k * k + 1u);
    let v0 = rest_at(base + k * k);
    var rho: array<real, DIM>;
    for (var vertex = 0u; vertex <= k; vertex++) {
        for (var j = 0u; j < k; j++) {
            if (vertex == 0u) {
                var v: real = 0.0;
                for (var i = 0u; i <= j; i++) {
                    v -= rest_at(base + i * k + j);
                }
                rho[j] = v;
            } else {
                rho[j] = rest_at(base + (vertex - 1u) * k + j);
            }
        }
        for (var a = 0u; a < DIM; a++) {
            var v: real = 0.0;
            for (var j = 0u; j < k; j++) {
                var row: real = 0.0;
                for (var m = 0u; m < k; m++) {
                    row += frames[block + (a * k + j) * size + a * k + m] * rho[m];
                }
                v += rho[j] * row;
            }
            (*out)[vertex * DIM + a] = v0 * v;
        }
    }
}
