// Hyperelastic k-simplices (stvk, neo_hookean): the element energy W and
// its gradient (material_energy: the coupled implicit step's term, through
// coupled_material.wgsl) and the XPBD energy constraint C = √(2W) of one
// element and its gradient (material_constraint) — the arithmetic of
// core/src/material (deformation.rs, stvk.rs, neo_hookean.rs, cholesky.rs,
// energy.rs, energy_constraint.rs), in the same order; the projection is
// project.wgsl's measure update, as cpu/src/project.rs runs it.
//
//   rest data   per element, at call.slot_map + e (k² + 1) in `rest`:
//               R (k × k, row-major, upper triangular), then V_0
//   D[a][j]  = x_{j+1}[a] − x_0[a]                     (N × k)
//   F̂[a][j]  = Σ_{i=0..j} D[a][i] R[i][j]
//   C[i][j]  = Σ_a F̂[a][i] F̂[a][j]
//   stvk     E = ½(C − I); Ψ = μ tr(E²) + (λ/2)(tr E)²; S = 2μE + λ tr(E) I
//   neo_h.   J = det F̂ (k = N) or Π L_jj, C = L Lᵀ (k < N); refused unless
//            J > 0 and C = L Lᵀ succeeds; C⁻¹ = Yᵀ Y, Y = L⁻¹;
//            Ψ = ½μ(tr C − k) − μ ln J + ½λ (ln J)²;  S = μ(I − C⁻¹) + λ ln J C⁻¹
//   ∇W       P̂ = F̂ S;  ∇_{i+1}W[a] = V_0 Σ_{j≥i} P̂[a][j] R[i][j];  ∇_0 W = −Σ_i ∇_{i+1} W
//   C        W = V_0 Ψ;  W ≤ 0 → C = 0, ∇C = 0;  else C = √(2W), ∇C = ∇W / C
//
// Call fields of a material call: slot_map = offset of the family's rest
// data in `rest`, friction = Lamé μ, factor = Lamé λ, FLAG_NEO_HOOKEAN
// (the composing file defines `call`, `rest_at` and FLAG_NEO_HOOKEAN).
// ln is ln_real, arithmetic only in both precisions (shaders/ln_f64.wgsl:
// the bits of core::material::ln; shaders/ln_f32.wgsl: the bits of the f32
// reference's ln).

// material_cholesky(a, n, l): shaders/cholesky.wgsl over array<real, MAT>
// (composed after this file, shader.rs).

// C⁻¹ = Yᵀ Y, Y = L⁻¹ (L lower triangular, nonzero diagonal), into `inv`.
fn material_inverse(l: ptr<function, array<real, MAT>>, n: u32, inv: ptr<function, array<real, MAT>>) {
    var y: array<real, MAT>;
    for (var j = 0u; j < n; j++) {
        for (var i = 0u; i < j; i++) {
            y[i * n + j] = 0.0;
        }
        y[j * n + j] = 1.0 / (*l)[j * n + j];
        for (var i = j + 1u; i < n; i++) {
            var s: real = 0.0;
            for (var m = j; m < i; m++) {
                s += (*l)[i * n + m] * y[m * n + j];
            }
            y[i * n + j] = -s / (*l)[i * n + i];
        }
    }
    for (var i = 0u; i < n; i++) {
        for (var j = 0u; j < n; j++) {
            var s: real = 0.0;
            for (var m = max(i, j); m < n; m++) {
                s += y[m * n + i] * y[m * n + j];
            }
            (*inv)[i * n + j] = s;
        }
    }
}

// St. Venant–Kirchhoff: Ψ of C, S into `stress`.
fn material_stvk(k: u32, c: ptr<function, array<real, MAT>>, stress: ptr<function, array<real, MAT>>) -> real {
    let mu = call.friction;
    let lambda_lame = call.factor;
    var trace: real = 0.0;
    var square: real = 0.0;
    for (var i = 0u; i < k; i++) {
        for (var j = 0u; j < k; j++) {
            let delta = select(real(0.0), real(1.0), i == j);
            let e = 0.5 * ((*c)[i * k + j] - delta);
            square += e * e;
            (*stress)[i * k + j] = 2.0 * mu * e;
        }
        trace += 0.5 * ((*c)[i * k + i] - 1.0);
    }
    for (var i = 0u; i < k; i++) {
        (*stress)[i * k + i] += lambda_lame * trace;
    }
    return mu * square + 0.5 * lambda_lame * trace * trace;
}

// The measure ratio J of the element with F̂ `image` and C `c` (k = N: det
// F̂ by elimination; k < N: Π L_jj of C = L Lᵀ, 0 if that fails), the
// Cholesky factor into `factor`; `factored`: whether C = L Lᵀ succeeded
// (core: deformation::ratio_and_factor).
fn material_ratio(k: u32, image: ptr<function, array<real, MAT>>, c: ptr<function, array<real, MAT>>,
                  factor: ptr<function, array<real, MAT>>, factored: ptr<function, bool>) -> real {
    *factored = material_cholesky(c, k, factor);
    var ratio: real = 0.0;
    if (k == DIM) {
        var square: array<real, MAT>;
        for (var t = 0u; t < k * k; t++) {
            square[t] = (*image)[t];
        }
        ratio = determinant(&square, k);
    } else if (*factored) {
        var product: real = 1.0;
        for (var j = 0u; j < k; j++) {
            product *= (*factor)[j * k + j];
        }
        ratio = product;
    }
    return ratio;
}

// Compressible Neo-Hookean: Ψ of the element with F̂ `image` and C `c`,
// S into `stress`; `refused` when J ≤ 0, NaN or C is not positive definite.
fn material_neo_hookean(k: u32, image: ptr<function, array<real, MAT>>, c: ptr<function, array<real, MAT>>,
                        stress: ptr<function, array<real, MAT>>, refused: ptr<function, bool>) -> real {
    var factor: array<real, MAT>;
    var factored = false;
    let ratio = material_ratio(k, image, c, &factor, &factored);
    if (!(ratio > 0.0) || !factored) {
        *refused = true;
        return 0.0;
    }
    let mu = call.friction;
    let lambda_lame = call.factor;
    var inv: array<real, MAT>;
    material_inverse(&factor, k, &inv);
    let log_ratio = ln_real(ratio);
    var trace: real = 0.0;
    for (var i = 0u; i < k; i++) {
        trace += (*c)[i * k + i];
    }
    for (var i = 0u; i < k; i++) {
        for (var j = 0u; j < k; j++) {
            let delta = select(real(0.0), real(1.0), i == j);
            let cinv = inv[i * k + j];
            (*stress)[i * k + j] = mu * (delta - cinv) + lambda_lame * log_ratio * cinv;
        }
    }
    return 0.5 * mu * (trace - real(k)) - mu * log_ratio + 0.5 * lambda_lame * log_ratio * log_ratio;
}

// D, F̂ = D R and C = F̂ᵀF̂ of element e of the running material call at
// the gathered `pts` (core: deformation::deform).
fn material_deform(e: u32, pts: ptr<function, array<real, POINTS>>, edges: ptr<function, array<real, MAT>>,
                   image: ptr<function, array<real, MAT>>, c: ptr<function, array<real, MAT>>) {
    let k = call.arity - 1u;
    let base = call.slot_map + e * (k * k + 1u);
    for (var j = 0u; j < k; j++) {
        for (var a = 0u; a < DIM; a++) {
            (*edges)[a * k + j] = (*pts)[(j + 1u) * DIM + a] - (*pts)[a];
        }
    }
    for (var a = 0u; a < DIM; a++) {
        for (var j = 0u; j < k; j++) {
            var f: real = 0.0;
            for (var i = 0u; i <= j; i++) {
                f += (*edges)[a * k + i] * rest_at(base + i * k + j);
            }
            (*image)[a * k + j] = f;
        }
    }
    for (var i = 0u; i < k; i++) {
        for (var j = 0u; j < k; j++) {
            var s: real = 0.0;
            for (var a = 0u; a < DIM; a++) {
                s += (*image)[a * k + i] * (*image)[a * k + j];
            }
            (*c)[i * k + j] = s;
        }
    }
}

// The measure ratio J of element e of the running material call at the
// gathered `pts` (core: material::measure_ratio; the guards).
fn material_measure_ratio(e: u32, pts: ptr<function, array<real, POINTS>>) -> real {
    var edges: array<real, MAT>;
    var image: array<real, MAT>;
    var c: array<real, MAT>;
    material_deform(e, pts, &edges, &image, &c);
    var factor: array<real, MAT>;
    var factored = false;
    return material_ratio(call.arity - 1u, &image, &c, &factor, &factored);
}

// W = V_0 Ψ of element e of the running material call at the gathered
// `pts`, ∇W into `grad`; `refused` when the law refuses the element
// (core: material::element_energy; the coupled implicit step's energy).
fn material_energy(e: u32, pts: ptr<function, array<real, POINTS>>, grad: ptr<function, array<real, POINTS>>,
                   refused: ptr<function, bool>) -> real {
    let k = call.arity - 1u;
    let base = call.slot_map + e * (k * k + 1u);
    let v0 = rest_at(base + k * k);
    var edges: array<real, MAT>;
    var image: array<real, MAT>;
    var c: array<real, MAT>;
    material_deform(e, pts, &edges, &image, &c);
    var stress: array<real, MAT>;
    var psi: real;
    if ((call.flags & FLAG_NEO_HOOKEAN) != 0u) {
        psi = material_neo_hookean(k, &image, &c, &stress, refused);
        if (*refused) {
            return 0.0;
        }
    } else {
        psi = material_stvk(k, &c, &stress);
    }
    // Pull-back: P̂ = F̂ S (into `edges`, no longer needed), then ∇W.
    for (var a = 0u; a < DIM; a++) {
        for (var j = 0u; j < k; j++) {
            var p: real = 0.0;
            for (var m = 0u; m < k; m++) {
                p += image[a * k + m] * stress[m * k + j];
            }
            edges[a * k + j] = p;
        }
    }
    for (var a = 0u; a < DIM; a++) {
        var first: real = 0.0;
        for (var i = 0u; i < k; i++) {
            var h: real = 0.0;
            for (var j = i; j < k; j++) {
                h += edges[a * k + j] * rest_at(base + i * k + j);
            }
            let hv = v0 * h;
            (*grad)[(i + 1u) * DIM + a] = hv;
            first -= hv;
        }
        (*grad)[a] = first;
    }
    return v0 * psi;
}

// C = √(2W) of element e of the running material call at the gathered
// `pts`, ∇C into `grad`; `refused` when the law refuses the element.
fn material_constraint(e: u32, pts: ptr<function, array<real, POINTS>>, grad: ptr<function, array<real, POINTS>>,
                       refused: ptr<function, bool>) -> real {
    let energy = material_energy(e, pts, grad, refused);
    if (*refused) {
        return 0.0;
    }
    let count = call.arity * DIM;
    if (energy <= 0.0) {
        for (var t = 0u; t < count; t++) {
            (*grad)[t] = 0.0;
        }
        return 0.0;
    }
    let cval = sqrt(2.0 * energy);
    for (var t = 0u; t < count; t++) {
        (*grad)[t] = (*grad)[t] / cval;
    }
    return cval;
}
