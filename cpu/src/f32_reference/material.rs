//! The material energy constraint in f32, as `shaders/material.wgsl`'s
//! `material_constraint` computes it (both laws, in its operation order).
//!
//! ```text
//! rest data  per element e at e (k² + 1): R (k × k, row-major, upper), V_0
//! D[a][j] = x_{j+1}[a] − x_0[a];  F̂ = D R;  C = F̂ᵀF̂
//! stvk    E = ½(C − I);  Ψ = μ tr(E²) + (λ/2)(tr E)²;  S = 2μE + λ tr(E) I
//! neo_h.  J = det F̂ (k = N) or Π L_jj (k < N), C = L Lᵀ; refused unless
//!         J > 0 and the Cholesky succeeds; C⁻¹ = Yᵀ Y, Y = L⁻¹;
//!         Ψ = ½μ(tr C − k) − μ ln J + ½λ (ln J)²;  S = μ(I − C⁻¹) + λ ln J C⁻¹
//! ∇W      P̂ = F̂ S;  ∇_{i+1}W[a] = V_0 Σ_{j≥i} P̂[a][j] R[i][j];  ∇_0 W = −Σ_i ∇_{i+1}W
//! C       W = V_0 Ψ;  W ≤ 0 → C = 0, ∇C = 0;  else C = √(2W), ∇C = ∇W / C
//! ```
//! ln is the arithmetic f32 ln of `ln_f32.wgsl` ([`super::ln::ln`]).

// Coordinate loops index several arrays at once, as a kernel does.
#![allow(clippy::needless_range_loop)]

use super::ln::ln;
use hyperpbd_core::FamilyKind;
use hyperpbd_core::implicit::{FrameLaw, curvature_product, frame_hessian_of};
use hyperpbd_core::material::{self, deform_into, pull_back_of, ratio_and_factor_of};

/// One material family as the device stores it: the law, Lamé μ and λ
/// (the call's friction and factor) and the rest data, all rounded to f32.
pub struct Law {
    pub neo_hookean: bool,
    pub mu: f32,
    pub lambda: f32,
    /// Simplex order k.
    pub k: usize,
    pub data: Vec<f32>,
}

/// The law of a material family as the GPU uploads it
/// (`gpu/src/xpbd/material.rs`): per element R then V_0, Lamé μ and λ,
/// each rounded to f32 once.
pub(super) fn material_law(kind: &FamilyKind) -> Option<Law> {
    let FamilyKind::Material {
        material,
        order,
        frames,
        measures,
    } = kind
    else {
        return None;
    };
    let kk = order * order;
    let mut data = Vec::with_capacity(measures.len() * (kk + 1));
    for (frame, &measure) in frames.chunks_exact(kk).zip(measures) {
        data.extend(frame.iter().map(|&r| r as f32));
        data.push(measure as f32);
    }
    Some(Law {
        neo_hookean: material.law == hyperpbd_core::material::Law::NeoHookean,
        mu: material.lame.mu as f32,
        lambda: material.lame.lambda as f32,
        k: *order,
        data,
    })
}

/// Cholesky factor L of the symmetric n×n `a` into `l` (core's, in f32);
/// false when a pivot is not > 0 (or NaN).
pub(super) fn cholesky(a: &[f32], n: usize, l: &mut [f32]) -> bool {
    material::cholesky(a, n, l).is_ok()
}

/// C⁻¹ = Yᵀ Y, Y = L⁻¹ (L lower triangular, nonzero diagonal), into `inv`
/// (core's, in f32).
fn inverse(l: &[f32], n: usize, inv: &mut [f32]) {
    let mut y = vec![0.0f32; n * n];
    material::lower_triangular_inverse(l, n, &mut y);
    material::inverse_from_factor_inverse(&y, n, inv);
}

/// The deformation of one element: edges D (N × k), F̂ = D R, C = F̂ᵀF̂.
struct Deformation {
    edges: Vec<f32>,
    image: Vec<f32>,
    c: Vec<f32>,
}

impl Law {
    /// St. Venant–Kirchhoff: Ψ of C, S into `stress` (core's, in f32).
    fn stvk(&self, c: &[f32], stress: &mut [f32]) -> f32 {
        material::stvk_stress(self.mu, self.lambda, self.k, c, stress)
    }

    /// Compressible Neo-Hookean: Ψ, S into `stress`; None (refused) when
    /// J ≤ 0, NaN or C is not positive definite.
    fn neo_hookean(&self, dim: usize, d: &Deformation, stress: &mut [f32]) -> Option<f32> {
        self.neo_hookean_parts(dim, d, stress)
            .map(|(psi, _, _)| psi)
    }

    /// [`Law::neo_hookean`]'s Ψ with ln J and C⁻¹.
    fn neo_hookean_parts(
        &self,
        dim: usize,
        d: &Deformation,
        stress: &mut [f32],
    ) -> Option<(f32, f32, Vec<f32>)> {
        let (k, mu, lambda) = (self.k, self.mu, self.lambda);
        let c = &d.c;
        // J (material_ratio): det F̂ by elimination (k = N) or Π L_jj.
        let (mut factor, mut square) = (vec![0.0f32; k * k], vec![0.0f32; k * k]);
        let (ratio, factored) =
            ratio_and_factor_of((k, dim), [&d.image, c], [&mut factor, &mut square]);
        if ratio.is_nan() || ratio <= 0.0 || !factored {
            return None;
        }
        let mut inv = vec![0.0f32; k * k];
        inverse(&factor, k, &mut inv);
        let log_ratio = ln(ratio);
        let psi = material::neo_hookean_stress(mu, lambda, k, c, &inv, log_ratio, stress);
        Some((psi, log_ratio, inv))
    }

    /// The frame Hessian H_F = ∂²Ψ/∂F̂² (N k × N k, row-major, symmetrised)
    /// of element `e` at `pts` into `h`, as `material_hessian.wgsl`'s
    /// `material_frame_hessian`; false when the law refuses the element.
    pub fn frame_hessian(&self, e: usize, pts: &[f32], dim: usize, h: &mut [f32]) -> bool {
        let (k, mu, lambda) = (self.k, self.mu, self.lambda);
        let size = dim * k;
        let d = self.deform(e, pts, dim);
        let f = &d.image;
        let mut s = vec![0.0f32; k * k];
        let (c_inv, log_ratio) = if self.neo_hookean {
            match self.neo_hookean_parts(dim, &d, &mut s) {
                Some((_, log_ratio, inv)) => (inv, log_ratio),
                None => return false,
            }
        } else {
            self.stvk(&d.c, &mut s);
            (Vec::new(), 0.0)
        };
        let (mut dc, mut ds, mut w) = (vec![0.0f32; k * k], vec![0.0f32; k * k], vec![0.0f32; k]);
        let law = FrameLaw {
            neo_hookean: self.neo_hookean,
            mu,
            lambda,
            log_ratio,
        };
        frame_hessian_of(
            &law,
            dim,
            k,
            [f, &s, &c_inv],
            [&mut dc, &mut ds, &mut w],
            &mut h[..size * size],
        );
        true
    }

    /// Column `c` of element `e`'s vertex block of the frame Hessian `h`
    /// into `out` (primal_material.wgsl's `primal_block_column`).
    pub fn block_column(&self, e: usize, h: &[f32], dim: usize, c: usize, out: &mut [f32]) {
        let k = self.k;
        let size = dim * k;
        let base = e * (k * k + 1);
        let (r, v0) = (&self.data[base..base + k * k], self.data[base + k * k]);
        let mut p = vec![0.0f32; (k + 1) * dim];
        p[c] = 1.0;
        let (mut df, mut yf) = (vec![0.0f32; size], vec![0.0f32; size]);
        curvature_product((h, r, v0), (dim, k), &p, [&mut df, &mut yf], out);
    }

    /// W = V_0 Ψ and ∇W of element `e` (material_energy); None: refused.
    pub fn element_energy(
        &self,
        e: usize,
        pts: &[f32],
        dim: usize,
        grad: &mut [f32],
    ) -> Option<f32> {
        self.energy(e, pts, dim, grad)
    }

    /// D, F̂ and C of element `e` at the gathered `pts`.
    fn deform(&self, e: usize, pts: &[f32], dim: usize) -> Deformation {
        let k = self.k;
        let base = e * (k * k + 1);
        let mut d = Deformation {
            edges: vec![0.0; dim * k],
            image: vec![0.0; dim * k],
            c: vec![0.0; k * k],
        };
        let frame = &self.data[base..base + k * k];
        deform_into(pts, (dim, k), frame, [&mut d.edges, &mut d.image, &mut d.c]);
        d
    }

    /// W = V_0 Ψ of element `e` at `pts`, ∇W into `grad`; None: refused.
    fn energy(&self, e: usize, pts: &[f32], dim: usize, grad: &mut [f32]) -> Option<f32> {
        let k = self.k;
        let base = e * (k * k + 1);
        let v0 = self.data[base + k * k];
        let mut d = self.deform(e, pts, dim);
        let mut stress = vec![0.0f32; k * k];
        let psi = if self.neo_hookean {
            self.neo_hookean(dim, &d, &mut stress)?
        } else {
            self.stvk(&d.c, &mut stress)
        };
        // Pull-back: P̂ = F̂ S (into the edges), then ∇W.
        let frame = &self.data[base..base + k * k];
        let (image, edges) = (&d.image, &mut d.edges);
        pull_back_of((k, dim), (frame, v0), [image, &stress], edges, grad);
        Some(v0 * psi)
    }

    /// C = √(2W) of element `e` at the gathered `pts` (k + 1 points of
    /// `dim` coordinates), ∇C into `grad`; None when the law refuses it.
    pub fn constraint(&self, e: usize, pts: &[f32], dim: usize, grad: &mut [f32]) -> Option<f32> {
        let energy = self.energy(e, pts, dim, grad)?;
        let count = (self.k + 1) * dim;
        if energy <= 0.0 {
            grad[..count].fill(0.0);
            return Some(0.0);
        }
        let cval = (2.0 * energy).sqrt();
        for t in 0..count {
            grad[t] /= cval;
        }
        Some(cval)
    }
}
