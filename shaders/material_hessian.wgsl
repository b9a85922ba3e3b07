// The frame Hessian of a hyperelastic simplex — the arithmetic of
// core/src/implicit/material_hessian.rs (material_term), in the same
// order, on material.wgsl's deformation and laws, and the two ends of its
// vertex product (frame change, point forces; the product itself reads
// the coupled step's stored frames in coupled_material.wgsl and one in
// registers in primal_material.wgsl, which builds a vertex block).
//
//   F̂ = D R, C = F̂ᵀF̂, S (the law), for column (b, m) of H_F (dF̂ = e_b e_mᵀ):
//     StVK  dC_ij = δ_im F̂[b][j] + δ_jm F̂[b][i];  dS = μ dC + ½λ (2 F̂[b][m]) I
//     NH    w = C⁻¹ f_b;  dS = (μ − λ ln J)(c_m wᵀ + w c_mᵀ) + λ w_m C⁻¹
//     H_F[(a, j), (b, m)] = δ_ab S[m][j] + Σ_i F̂[a][i] dS[i][j];  H_F ← ½(H_F + H_Fᵀ)
//   product   dF̂ = dD R;  y = H_F⁺ dF̂;  Y[a][i] = V_0 Σ_{j≥i} y[a][j] R[i][j];
//             out_{i+1} = Y[:, i],  out_0 = −Σ_i Y[:, i]
//   diagonal  ρ_J[j] = R[J−1][j] (J ≥ 1), −Σ_{i≤j} R[i][j] (J = 0);
//             V_0 Σ_j ρ_J[j] Σ_m H_F⁺[(a,j),(a,m)] ρ_J[m]
//
// Element `e` is the running material call's (slot `e` of its family);
// H_F is (N k)² reals, row-major, index a·k + j.

// H_F of element e at the gathered `pts` into `h`; false when the law
// refuses the element.
fn material_frame_hessian(e: u32, pts: ptr<function, array<real, POINTS>>, h: ptr<function, array<real, HESS>>) -> bool {
    let k = call.arity - 1u;
    let size = DIM * k;
    var edges: array<real, MAT>;
    var f: array<real, MAT>;
    var c: array<real, MAT>;
    material_deform(e, pts, &edges, &f, &c);
    var s: array<real, MAT>;
    let neo_hookean = (call.flags & FLAG_NEO_HOOKEAN) != 0u;
    var c_inv: array<real, MAT>;
    var log_ratio: real = 0.0;
    if (neo_hookean) {
        var refused = false;
        material_neo_hookean(k, &f, &c, &s, &refused);
        if (refused) {
            return false;
        }
        // The same J and C⁻¹ again (core recomputes them: the same bits).
        var factor: array<real, MAT>;
        var factored = false;
        let ratio = material_ratio(k, &f, &c, &factor, &factored);
        material_inverse(&factor, k, &c_inv);
        log_ratio = ln_real(ratio);
    } else {
        material_stvk(k, &c, &s);
    }
    let mu = call.friction;
    let lambda_lame = call.factor;
    var dc: array<real, MAT>;
    var ds: array<real, MAT>;
    var w: array<real, DIM>;
    for (var b = 0u; b < DIM; b++) {
        for (var m = 0u; m < k; m++) {
            if (neo_hookean) {
                for (var i = 0u; i < k; i++) {
                    var v: real = 0.0;
                    for (var j = 0u; j < k; j++) {
                        v += c_inv[i * k + j] * f[b * k + j];
                    }
                    w[i] = v;
                }
                let shear = mu - lambda_lame * log_ratio;
                let volume = lambda_lame * w[m];
                for (var i = 0u; i < k; i++) {
                    for (var j = 0u; j < k; j++) {
                        let rank_two = c_inv[i * k + m] * w[j] + w[i] * c_inv[j * k + m];
                        ds[i * k + j] = shear * rank_two + volume * c_inv[i * k + j];
                    }
                }
            } else {
                for (var i = 0u; i < k; i++) {
                    for (var j = 0u; j < k; j++) {
                        var v: real = 0.0;
                        if (i == m) {
                            v += f[b * k + j];
                        }
                        if (j == m) {
                            v += f[b * k + i];
                        }
                        dc[i * k + j] = v;
                    }
                }
                let trace = 2.0 * f[b * k + m];
                for (var i = 0u; i < k; i++) {
                    for (var j = 0u; j < k; j++) {
                        var identity: real = 0.0;
                        if (i == j) {
                            identity = 0.5 * lambda_lame * trace;
                        }
                        ds[i * k + j] = mu * dc[i * k + j] + identity;
                    }
                }
            }
            let column = b * k + m;
            for (var a = 0u; a < DIM; a++) {
                for (var j = 0u; j < k; j++) {
                    var v: real = 0.0;
                    if (a == b) {
                        v = s[m * k + j];
                    }
                    for (var i = 0u; i < k; i++) {
                        v += f[a * k + i] * ds[i * k + j];
                    }
                    (*h)[(a * k + j) * size + column] = v;
                }
            }
        }
    }
    for (var r = 0u; r < size; r++) {
        for (var q = r + 1u; q < size; q++) {
            let v = 0.5 * ((*h)[r * size + q] + (*h)[q * size + r]);
            (*h)[r * size + q] = v;
            (*h)[q * size + r] = v;
        }
    }
    return true;
}

// dF̂ = dD R of an element's point change `p` (R upper triangular k × k
// at rest[base ..]) into `df`, index a·k + j.
fn material_frame_change(base: u32, k: u32, p: ptr<function, array<real, POINTS>>,
                         df: ptr<function, array<real, MAT>>) {
    for (var a = 0u; a < DIM; a++) {
        for (var j = 0u; j < k; j++) {
            var v: real = 0.0;
            for (var i = 0u; i <= j; i++) {
                v += ((*p)[(i + 1u) * DIM + a] - (*p)[a]) * rest_at(base + i * k + j);
            }
            (*df)[a * k + j] = v;
        }
    }
}

// The point vector of a frame vector `yf`: Y[a][i] = V_0 Σ_{j≥i} y[a][j]
// R[i][j], out_{i+1} = Y[:, i], out_0 = −Σ_i Y[:, i].
fn material_point_forces(base: u32, k: u32, v0: real, yf: ptr<function, array<real, MAT>>,
                         out: ptr<function, array<real, POINTS>>) {
    for (var a = 0u; a < DIM; a++) {
        var first: real = 0.0;
        for (var i = 0u; i < k; i++) {
            var v: real = 0.0;
            for (var j = i; j < k; j++) {
                v += (*yf)[a * k + j] * rest_at(base + i * k + j);
            }
            let y = v0 * v;
            (*out)[(i + 1u) * DIM + a] = y;
            first -= y;
        }
        (*out)[a] = first;
    }
}
