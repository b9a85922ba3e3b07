//! The element Hessian of a hyperelastic simplex, W = V_0 Ψ(F̂), for
//! Newton: exact, analytic, assembled in the frame coordinates F̂ and
//! projected there.
//!
//! ```text
//! F̂ = D R  (N × k),  C = F̂ᵀF̂,  S = 2 ∂Ψ/∂C,  P̂ = ∂Ψ/∂F̂ = F̂ S        (material module)
//! directional derivative of P̂ in the direction dF̂:
//!   dC  = dF̂ᵀF̂ + F̂ᵀdF̂
//!   StVK: dS = μ dC + (λ/2) tr(dC) I
//!   NH:   dS = (μ − λ ln J) C⁻¹ dC C⁻¹ + (λ/2) tr(C⁻¹ dC) C⁻¹
//!         (dC⁻¹ = −C⁻¹ dC C⁻¹,  d ln J = ½ tr(C⁻¹ dC))
//!   dP̂  = dF̂ S + F̂ dS
//! H_F = ∂²Ψ/∂F̂²  (Nk × Nk, index a·k + j as F̂[a][j]): column (b, m) is dP̂
//!   for dF̂ = e_b e_mᵀ, where dC = e_m f_bᵀ + f_b e_mᵀ (f_b = row b of F̂):
//!   dC_ij = δ_im F̂[b][j] + δ_jm F̂[b][i]            tr dC = 2 F̂[b][m]
//!   NH with w = C⁻¹ f_b:  C⁻¹ dC C⁻¹ = c_m wᵀ + w c_mᵀ (c_m = column m of C⁻¹),
//!                         tr(C⁻¹ dC) = 2 w_m
//!   then H_F ← ½ (H_F + H_Fᵀ) (exactly symmetric; the asymmetry is rounding)
//! element Hessian in the edges D (and vertices, through D = S_e x):
//!   ∂²W/∂D² [dD] = V_0 (H_F [dD R]) Rᵀ
//! ```
//! **Projection in F̂ coordinates.** The Newton block used is
//! V_0 (R ⊗ I) H_F⁺ (Rᵀ ⊗ I) mapped to the vertices, H_F⁺ = `project_psd`
//! of H_F. R is invertible and the edge map S_e is onto, so this block is
//! PSD, equals the exact Hessian whenever that is PSD, and keeps the
//! translations in its null space exactly. H_F is the law's own tangent in
//! an orthonormal rest frame: its spectrum does not depend on the element's
//! shape or size (V_0 and R carry those), which is why the projection is
//! taken there rather than on the (k + 1)N vertex block; it is also the
//! smaller matrix (Nk).
//!
//! Products and the diagonal (the element's vertex layout, (k + 1) × N):
//! ```text
//! dD[a][i] = p_{i+1}[a] − p_0[a];   dF̂[a][j] = Σ_{i=0..j} dD[a][i] R[i][j]
//! y_F[r]   = Σ_c H_F⁺[r][c] dF̂[c]                    (c ascending)
//! Y[a][i]  = V_0 Σ_{j=i..k−1} y_F[a][j] R[i][j];   out_{i+1} = Y[:, i],  out_0 = −Σ_i Y[:, i]
//! diagonal at vertex J, axis a:  ρ_J[j] = R[J−1][j] (J ≥ 1),  −Σ_{i≤j} R[i][j] (J = 0)
//!                                 V_0 Σ_j Σ_m ρ_J[j] H_F⁺[(a,j),(a,m)] ρ_J[m]
//! ```

use crate::kinds::ProjectionReal;
use crate::material::{
    Law, LawRefusal, MaterialElement, MaterialScratch, RestView, element_energy, ln, measure_ratio,
    scatter_frame_rows,
};

/// Buffers of the Hessian evaluation, reused between elements.
#[derive(Debug, Default, Clone)]
pub struct MaterialHessianScratch {
    dc: Vec<f64>,
    ds: Vec<f64>,
    w: Vec<f64>,
    df: Vec<f64>,
    yf: Vec<f64>,
    rho: Vec<f64>,
}

impl MaterialHessianScratch {
    /// Empty scratch; buffers grow on first use.
    pub fn new() -> Self {
        MaterialHessianScratch::default()
    }

    fn resize(&mut self, k: usize, dim: usize) {
        self.dc.resize(k * k, 0.0);
        self.ds.resize(k * k, 0.0);
        self.w.resize(k, 0.0);
        self.rho.resize(k, 0.0);
        self.df.resize(dim * k, 0.0);
        self.yf.resize(dim * k, 0.0);
    }
}

/// W of the element (as `material::element_energy`), ∇W into `grad`, and
/// the exact H_F = ∂²Ψ/∂F̂² (Nk × Nk, row-major, symmetrised) into
/// `frame_hessian`. Project it with [`super::project_psd`] before use.
pub fn material_term(
    element: MaterialElement<'_>,
    grad: &mut [f64],
    frame_hessian: &mut [f64],
    scratch: &mut MaterialScratch,
    hs: &mut MaterialHessianScratch,
) -> Result<f64, LawRefusal> {
    let energy = element_energy(element, grad, scratch)?;
    let dim = element.dim;
    let k = element.order();
    let log_ratio = match element.material.law {
        Law::StVenantKirchhoff => 0.0,
        Law::NeoHookean => {
            // element_energy accepted J > 0; this recomputes the same bits.
            let ratio = measure_ratio(element.points, dim, element.rest, scratch);
            ln(ratio)
        }
    };
    hs.resize(k, dim);
    let law = FrameLaw {
        neo_hookean: element.material.law == Law::NeoHookean,
        mu: element.material.lame.mu,
        lambda: element.material.lame.lambda,
        log_ratio,
    };
    let MaterialHessianScratch { dc, ds, w, .. } = hs;
    frame_hessian_of(
        &law,
        dim,
        k,
        [&scratch.image, &scratch.stress, &scratch.c_inverse],
        [dc, ds, w],
        frame_hessian,
    );
    Ok(energy)
}

/// The law of one element as the frame Hessian reads it, in precision `R`.
#[derive(Debug, Clone, Copy)]
pub struct FrameLaw<R> {
    /// Neo-Hookean (else StVK).
    pub neo_hookean: bool,
    /// Lamé μ.
    pub mu: R,
    /// Lamé λ.
    pub lambda: R,
    /// ln J (Neo-Hookean; the caller's own precision's ln).
    pub log_ratio: R,
}

/// H_F = ∂²Ψ/∂F̂² (Nk × Nk, row-major, symmetrised; module docs) into
/// `out` from `[F̂ (N × k), S, C⁻¹ (Neo-Hookean)]`, with scratch
/// `[dC, dS (k × k), w (k)]`, in precision `R` (f64: the golden path;
/// f32: the f32 reference, as `shaders/material_hessian.wgsl`).
pub fn frame_hessian_of<R: ProjectionReal>(
    law: &FrameLaw<R>,
    dim: usize,
    k: usize,
    [f, s, c_inv]: [&[R]; 3],
    [dc, ds, w]: [&mut [R]; 3],
    out: &mut [R],
) {
    let FrameLaw {
        neo_hookean,
        mu,
        lambda,
        log_ratio,
    } = *law;
    let (zero, half, two) = (R::constant(0.0), R::constant(0.5), R::constant(2.0));
    let size = dim * k;
    for b in 0..dim {
        for m in 0..k {
            if neo_hookean {
                for i in 0..k {
                    let mut v = zero;
                    for j in 0..k {
                        v += c_inv[i * k + j] * f[b * k + j];
                    }
                    w[i] = v;
                }
                let shear = mu - lambda * log_ratio;
                let volume = lambda * w[m];
                for i in 0..k {
                    for j in 0..k {
                        let rank_two = c_inv[i * k + m] * w[j] + w[i] * c_inv[j * k + m];
                        ds[i * k + j] = shear * rank_two + volume * c_inv[i * k + j];
                    }
                }
            } else {
                for i in 0..k {
                    for j in 0..k {
                        let mut v = zero;
                        if i == m {
                            v += f[b * k + j];
                        }
                        if j == m {
                            v += f[b * k + i];
                        }
                        dc[i * k + j] = v;
                    }
                }
                let trace = two * f[b * k + m];
                for i in 0..k {
                    for j in 0..k {
                        let identity = if i == j { half * lambda * trace } else { zero };
                        ds[i * k + j] = mu * dc[i * k + j] + identity;
                    }
                }
            }
            let column = b * k + m;
            for a in 0..dim {
                for j in 0..k {
                    let mut v = if a == b { s[m * k + j] } else { zero };
                    for i in 0..k {
                        v += f[a * k + i] * ds[i * k + j];
                    }
                    out[(a * k + j) * size + column] = v;
                }
            }
        }
    }
    for r in 0..size {
        for c in r + 1..size {
            let v = half * (out[r * size + c] + out[c * size + r]);
            out[r * size + c] = v;
            out[c * size + r] = v;
        }
    }
}

/// out = V_0 Sᵀ (R ⊗ I) H (Rᵀ ⊗ I) S p for the gathered element vector `p`
/// ((k + 1) × N) and the frame Hessian `frame_hessian` (projected or not).
/// `out` is overwritten.
pub fn apply_material_curvature(
    frame_hessian: &[f64],
    rest: RestView<'_>,
    dim: usize,
    p: &[f64],
    out: &mut [f64],
    hs: &mut MaterialHessianScratch,
) {
    let k = p.len() / dim - 1;
    hs.resize(k, dim);
    let MaterialHessianScratch { df, yf, .. } = hs;
    curvature_product(
        (frame_hessian, rest.frame, rest.measure),
        (dim, k),
        p,
        [df, yf],
        out,
    );
}

/// [`apply_material_curvature`] in precision `R` on `(H, R, V_0)`, with
/// scratch `[dF, y]` (N k each): dF = (p's edges) R, y = H dF, out = V_0
/// y Rᵀ scattered to the vertices (f32: the f32 reference, as
/// `primal_material.wgsl`'s `primal_block_column`).
pub fn curvature_product<R: ProjectionReal>(
    (frame_hessian, r, measure): (&[R], &[R], R),
    (dim, k): (usize, usize),
    p: &[R],
    [df, yf]: [&mut [R]; 2],
    out: &mut [R],
) {
    let size = dim * k;
    for a in 0..dim {
        for j in 0..k {
            let mut v = R::constant(0.0);
            for i in 0..=j {
                v += (p[(i + 1) * dim + a] - p[a]) * r[i * k + j];
            }
            df[a * k + j] = v;
        }
    }
    for row in 0..size {
        let mut v = R::constant(0.0);
        for c in 0..size {
            v += frame_hessian[row * size + c] * df[c];
        }
        yf[row] = v;
    }
    scatter_frame_rows((k, dim), (r, measure), yf, out);
}

/// Diagonal of the vertex block (the layout of `p` in
/// [`apply_material_curvature`]) into `out`.
pub fn material_curvature_diagonal(
    frame_hessian: &[f64],
    rest: RestView<'_>,
    dim: usize,
    out: &mut [f64],
    hs: &mut MaterialHessianScratch,
) {
    let k = out.len() / dim - 1;
    hs.resize(k, dim);
    let size = dim * k;
    let r = rest.frame;
    let rho = &mut hs.rho;
    for vertex in 0..=k {
        for j in 0..k {
            rho[j] = if vertex == 0 {
                let mut v = 0.0;
                for i in 0..=j {
                    v -= r[i * k + j];
                }
                v
            } else {
                r[(vertex - 1) * k + j]
            };
        }
        for a in 0..dim {
            let mut v = 0.0;
            for j in 0..k {
                let mut row = 0.0;
                for m in 0..k {
                    row += frame_hessian[(a * k + j) * size + a * k + m] * rho[m];
                }
                v += rho[j] * row;
            }
            out[vertex * dim + a] = rest.measure * v;
        }
    }
}

/// The dense ((k + 1)N)² vertex block (row-major) into `out`, column by
/// column through [`apply_material_curvature`] (for tests and audits).
pub fn material_hessian_block(
    frame_hessian: &[f64],
    rest: RestView<'_>,
    dim: usize,
    vertices: usize,
    out: &mut [f64],
    hs: &mut MaterialHessianScratch,
) {
    let count = vertices * dim;
    let mut unit = vec![0.0; count];
    let mut column = vec![0.0; count];
    for c in 0..count {
        unit[c] = 1.0;
        apply_material_curvature(frame_hessian, rest, dim, &unit, &mut column, hs);
        unit[c] = 0.0;
        for r in 0..count {
            out[r * count + c] = column[r];
        }
    }
}
