//! Material elements (StVK, Neo-Hookean) as terms of the coupled
//! objective: the law's energy W = V_0 Ψ(F̂) from core's material module,
//! its vertex gradient, and the projected frame Hessian H_F⁺ of
//! `implicit::material_term` (docs/implicit.md §2).
//!
//! ```text
//! energy     W_e = V_0 Ψ(F̂_e(x))         a law refusal (NH: J ≤ 0) is W = +∞, ∇W = 0:
//!                                        a rejected line-search trial, never a NaN
//! curvature  H_F⁺ = project_psd(H_F)     (Nk)² per element, once per Newton iteration
//! product    (K_e⁺ p)_e = V_0 Sᵀ(R ⊗ I) H_F⁺ (Rᵀ ⊗ I) S p_e     (apply_material_curvature)
//! diagonal   material_curvature_diagonal (the Jacobi preconditioner's share)
//! rounding   δW_e (material_energy_rounding), for the rounding floor of step 11
//! ```
//! H_F⁺ is PSD and maps through the onto edge map, so the vertex block is
//! PSD with the translations in its null space; it equals the exact
//! Hessian whenever that is PSD. No finite difference is taken anywhere.

use super::{Elements, Kind, Terms, expression_kind};
use crate::parallel::Workers;
use hyperpbd_core::implicit::{
    ExpressionScratch, MaterialHessianScratch, PsdScratch, apply_material_curvature,
    expression_curvature, material_curvature_diagonal, material_energy_rounding, material_term,
    project_psd,
};
use hyperpbd_core::material::{LawRefusal, MaterialScratch, element_energy};
use hyperpbd_core::{Family, FamilyKind, Plan};

/// Buffers of one chunk of material evaluations.
#[derive(Debug, Default)]
pub struct MaterialBuffers {
    law: MaterialScratch,
    hessian: MaterialHessianScratch,
    psd: PsdScratch,
}

/// Values of H_F⁺ per material element: (N k)² for the largest k of the plan.
pub fn frame_stride(families: &[Family], dim: usize) -> usize {
    families
        .iter()
        .filter_map(|f| f.kind.rest_view(0).map(|_| (dim * (f.arity - 1)).pow(2)))
        .max()
        .unwrap_or(0)
}

/// Values per dense block: H_F⁺ of the largest material ((N k)²) or K⁺ of
/// the largest expression element ((arity·N)²).
pub fn block_stride(plan: &Plan) -> usize {
    let expressions = (plan.families.iter())
        .filter(|f| matches!(f.kind, FamilyKind::Expression(_)))
        .map(|f| (f.arity * plan.dim).pow(2))
        .max()
        .unwrap_or(0);
    frame_stride(&plan.families, plan.dim).max(expressions)
}

/// W of slot `element` of the material family `family` at `points`, ∇W
/// into `gradient`; a law refusal gives +∞ with ∇W = 0.
pub fn energy(
    family: &Family,
    element: usize,
    points: &[f64],
    dim: usize,
    gradient: &mut [f64],
    b: &mut MaterialBuffers,
) -> f64 {
    let Some(m) = family.kind.material_element(element, points, dim) else {
        return f64::NAN;
    };
    match element_energy(m, gradient, &mut b.law) {
        Ok(w) => w,
        Err(_) => {
            gradient.fill(0.0);
            f64::INFINITY
        }
    }
}

/// Why slot `element` of `family` is refused at `points`, if it is.
pub fn refusal(
    family: &Family,
    element: usize,
    points: &[f64],
    dim: usize,
    b: &mut MaterialBuffers,
) -> Option<LawRefusal> {
    let m = family.kind.material_element(element, points, dim)?;
    let mut gradient = vec![0.0; points.len()];
    element_energy(m, &mut gradient, &mut b.law).err()
}

/// H_F⁺ of the element at `points` into `out` ((N k)² values, row-major);
/// false when the law refuses or the block is not finite.
pub fn projected_frame_hessian(
    family: &Family,
    element: usize,
    points: &[f64],
    dim: usize,
    out: &mut [f64],
    b: &mut MaterialBuffers,
) -> bool {
    let Some(m) = family.kind.material_element(element, points, dim) else {
        return false;
    };
    let size = dim * (family.arity - 1);
    let mut gradient = vec![0.0; points.len()];
    let MaterialBuffers { law, hessian, psd } = b;
    let evaluated = material_term(m, &mut gradient, &mut out[..size * size], law, hessian);
    evaluated.is_ok() && project_psd(&mut out[..size * size], size, psd).finite
}

/// out = K_e⁺ p (or, for `p` = None, the diagonal of K_e⁺) for the
/// element's H_F⁺ `frame_hessian`, both in the element's vertex layout.
pub fn curvature(
    family: &Family,
    element: usize,
    frame_hessian: &[f64],
    dim: usize,
    p: Option<&[f64]>,
    out: &mut [f64],
    b: &mut MaterialBuffers,
) {
    let Some((_, rest)) = family.kind.rest_view(element) else {
        return;
    };
    let n = family.arity * dim;
    let out = &mut out[..n];
    match p {
        None => material_curvature_diagonal(frame_hessian, rest, dim, out, &mut b.hessian),
        Some(p) => apply_material_curvature(frame_hessian, rest, dim, &p[..n], out, &mut b.hessian),
    }
}

/// δW of the element at `points` (0 where the law refuses: no change is
/// accepted there).
pub fn rounding(
    family: &Family,
    element: usize,
    points: &[f64],
    dim: usize,
    b: &mut MaterialBuffers,
) -> f64 {
    let Some(m) = family.kind.material_element(element, points, dim) else {
        return 0.0;
    };
    let mut gradient = vec![0.0; points.len()];
    material_energy_rounding(m, &mut gradient, &mut b.law).map_or(0.0, |(_, bound)| bound)
}

impl Elements {
    /// The dense curvature blocks at `x` (step 6, once per Newton
    /// iteration): H_F⁺ of every material element, K⁺ of every expression
    /// element (core's `expression_curvature`); the first element whose law
    /// refuses or whose block is not finite.
    pub fn curvatures(
        &mut self,
        workers: &Workers,
        terms: &Terms<'_>,
        x: &[f64],
    ) -> Result<(), usize> {
        let dim = terms.plan.dim;
        let stride = self.block_stride;
        let len = self.blocks.len();
        self.fill_blocks(
            |e| &mut e.block_values,
            workers,
            len,
            stride,
            |this, r, out| {
                let mut buffers = MaterialBuffers::default();
                let mut expression = ExpressionScratch::default();
                let mut points = vec![0.0; this.lists.arity_max * dim];
                for m in r.clone() {
                    let e = this.blocks[m] as usize;
                    let arity = this.gather_points(e, x, dim, &mut points);
                    let points = &points[..arity * dim];
                    let block = &mut out[(m - r.start) * stride..(m - r.start + 1) * stride];
                    let ok = match this.kinds[e] {
                        Kind::Material {
                            family, element, ..
                        } => projected_frame_hessian(
                            &terms.plan.families[family as usize],
                            element as usize,
                            points,
                            dim,
                            block,
                            &mut buffers,
                        ),
                        Kind::Expression {
                            family, element, ..
                        } => {
                            let family = &terms.plan.families[family as usize];
                            let element = element as usize;
                            expression_curvature(
                                expression_kind(&family.kind),
                                element,
                                (family.compliance, family.rest[element]),
                                points,
                                block,
                                &mut expression,
                            )
                        }
                        Kind::Spring { .. } | Kind::Ball | Kind::Friction { .. } => {
                            unreachable!("blocks list material and expression elements only")
                        }
                    };
                    if !ok {
                        return Err(e);
                    }
                }
                Ok(())
            },
        )
    }

    /// The law's refusal of element e at `x` with its family's index and
    /// authored element index, if e is a refused material element.
    pub fn material_refusal(
        &self,
        e: usize,
        plan: &Plan,
        x: &[f64],
    ) -> Option<(usize, usize, LawRefusal)> {
        let Kind::Material {
            family, element, ..
        } = self.kinds[e]
        else {
            return None;
        };
        let dim = plan.dim;
        let mut points = vec![0.0; self.lists.arity_max * dim];
        let arity = self.gather_points(e, x, dim, &mut points);
        let f = &plan.families[family as usize];
        let points = &points[..arity * dim];
        let refusal = refusal(f, element as usize, points, dim, &mut Default::default())?;
        Some((
            family as usize,
            f.authored_element(element as usize),
            refusal,
        ))
    }
}
