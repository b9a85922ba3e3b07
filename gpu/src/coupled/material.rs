//! Material families (StVK, Neo-Hookean) and expression families (their
//! ∇²C springs, expression.rs) in the GPU coupled step — the dense blocks —
//! host side: the data `shaders/coupled_material.wgsl` reads, and the two
//! things the host decides from read-back values as the golden path does
//! (cpu/src/coupled/elements/materials.rs): why an element is refused,
//! and an element's rounding (δW; an expression's `expression_rounding`)
//! for the rounding floor.
//!
//! ```text
//! blocks          the material and expression elements in element order (families
//!                 first in the element list, family order, slot order), block m ↔ e
//! material_words  [stride: max of (N k_max)² and (arity·N)², M, per block: e, rest
//!                 offset of its family, slot in the family, flags (FLAG_NEO_HOOKEAN)];
//!                 an expression block: [e, offset of its per-element constants in
//!                 material_rest, slot, the family's expression index k]
//! material_rest   per material family, per slot: R (k × k), V_0 (xpbd's layout); then
//!                 per expression family with per-element constants, m per slot
//! frames          M × stride reals: H_F⁺ (K⁺) per block, written on the device
//! element_reals   [μ, λ] of a material element, [α, rest] of an expression's
//!                 (mod.rs `upload_elements`)
//! ```

use hyperpbd_core::implicit::{expression_rounding, material_energy_rounding};
use hyperpbd_core::material::{Law, MaterialScratch, element_energy};
use hyperpbd_core::{FamilyKind, GpuError, Plan, Refusal};

use crate::Precision;
use crate::barrier::{LOOPS_CUT, NONE, STATUS_WORDS, refuse_cut_loops};
use crate::codes::FLAG_NEO_HOOKEAN;
use crate::context::GpuContext;
use crate::params::push_reals;
use crate::xpbd::material::push_rest_data;

/// The dense-block elements of a plan (material and expression): (family,
/// slot) per block, and each block's element index.
#[derive(Debug, Default)]
pub(super) struct Materials {
    /// (family, slot in the family) of each block.
    pub blocks: Vec<(usize, usize)>,
    /// Element index of each block.
    pub elements: Vec<usize>,
}

impl Materials {
    /// The plan's material elements, in element order.
    pub fn of(plan: &Plan) -> Self {
        let mut out = Materials::default();
        let mut e = 0;
        for (f, family) in plan.families.iter().enumerate() {
            let material = matches!(
                family.kind,
                FamilyKind::Material { .. } | FamilyKind::Expression(_)
            );
            for slot in 0..family.len() {
                if material {
                    out.blocks.push((f, slot));
                    out.elements.push(e);
                }
                e += 1;
            }
        }
        out
    }

    /// Blocks (material elements).
    pub fn len(&self) -> usize {
        self.blocks.len()
    }

    /// (family, slot) of element e, if it is a material element.
    pub fn of_element(&self, e: usize) -> Option<(usize, usize)> {
        let m = self.elements.binary_search(&e).ok()?;
        Some(self.blocks[m])
    }

    /// Buffers `material_words`, `material_rest` and `frames` for `plan`
    /// (one-value buffers when it has no material element).
    pub fn buffers(
        &self,
        ctx: &GpuContext,
        plan: &Plan,
        precision: Precision,
    ) -> Result<[wgpu::Buffer; 3], GpuError> {
        let stride = (plan.families.iter())
            .filter_map(|f| match f.kind {
                FamilyKind::Material { .. } => Some((plan.dim * (f.arity - 1)).pow(2)),
                FamilyKind::Expression(_) => Some((plan.dim * f.arity).pow(2)),
                FamilyKind::Distance
                | FamilyKind::Tether
                | FamilyKind::SimplexMeasure { .. }
                | FamilyKind::OrientedMeasure
                | FamilyKind::HyperplaneContact { .. }
                | FamilyKind::MeshContact { .. } => None,
            })
            .max()
            .unwrap_or(0);
        let mut rest = Vec::new();
        let mut offsets = Vec::new();
        for family in &plan.families {
            offsets.push(rest.len() as u32);
            push_rest_data(family, &mut rest);
        }
        // Expression families: their index k (plan order) and their
        // per-element constants (slot order) after every material's rest data.
        let mut constants = vec![0u32; plan.families.len()];
        let mut index = vec![0u32; plan.families.len()];
        let mut k = 0;
        for (f, family) in plan.families.iter().enumerate() {
            if let FamilyKind::Expression(kind) = &family.kind {
                (index[f], constants[f]) = (k, rest.len() as u32);
                rest.extend_from_slice(&kind.constants);
                k += 1;
            }
        }
        let mut words = vec![stride as u32, self.len() as u32];
        for (&(f, slot), &e) in self.blocks.iter().zip(&self.elements) {
            let neo_hookean = matches!(
                plan.families[f].kind,
                FamilyKind::Material { material, .. } if material.law == Law::NeoHookean
            );
            let flags = if neo_hookean { FLAG_NEO_HOOKEAN } else { 0 };
            if let FamilyKind::Expression(kind) = &plan.families[f].kind {
                let at = constants[f] + (slot * kind.element_constants) as u32;
                words.extend([e as u32, at, slot as u32, index[f]]);
            } else {
                words.extend([e as u32, offsets[f], slot as u32, flags]);
            }
        }
        let mut rest_bytes = Vec::new();
        push_reals(&mut rest_bytes, &rest, precision);
        let real = crate::params::real_size(precision);
        rest_bytes.resize(rest_bytes.len().max(real), 0);
        let frames = vec![0u8; (self.len() * stride).max(1) * real];
        Ok([
            ctx.storage("material words", bytemuck::cast_slice(&words))?,
            ctx.storage("material rest", &rest_bytes)?,
            ctx.storage("frames", &frames)?,
        ])
    }
}

/// Why material element (`family`, `slot`) cannot be evaluated at its
/// `points` (cpu `element_refusal`): the law's refusal, else `None`.
pub(super) fn refusal(
    plan: &Plan,
    (family, slot): (usize, usize),
    points: &[f64],
) -> Option<Refusal> {
    let f = &plan.families[family];
    let m = f.kind.material_element(slot, points, plan.dim)?;
    let mut gradient = vec![0.0; points.len()];
    let refusal = element_energy(m, &mut gradient, &mut MaterialScratch::new()).err()?;
    Some(Refusal::Material {
        family,
        family_label: f.label.clone(),
        element: f.authored_element(slot),
        refusal,
    })
}

/// The rounding of dense-block element (`family`, `slot`) whose energy is
/// `energy`: an expression's `expression_rounding` (cpu `energy_scale`),
/// a material's δW at its `points` (0 where the law refuses; cpu
/// `materials::rounding`).
pub(super) fn rounding(
    plan: &Plan,
    (family, slot): (usize, usize),
    points: &[f64],
    energy: f64,
) -> f64 {
    let f = &plan.families[family];
    if let FamilyKind::Expression(kind) = &f.kind {
        return expression_rounding(kind, energy, f.compliance, f.rest[slot]);
    }
    let Some(m) = plan.families[family]
        .kind
        .material_element(slot, points, plan.dim)
    else {
        return 0.0;
    };
    let mut gradient = vec![0.0; points.len()];
    material_energy_rounding(m, &mut gradient, &mut MaterialScratch::new())
        .map_or(0.0, |(_, bound)| bound)
}

/// status[4]'s bit marking a material element's cut loops
/// (coupled_material.wgsl `MATERIAL_LOOPS`).
const MATERIAL_LOOPS: u32 = 0x8000_0000;

/// The coupled kernels' loop check: a material element whose loops
/// llvmpipe cut short is named as one; a particle's, as barrier.rs names it.
pub(super) fn refuse_cut_loops_of(status: &[u32; STATUS_WORDS]) -> Result<(), GpuError> {
    let word = status[LOOPS_CUT];
    if word != NONE && word & MATERIAL_LOOPS != 0 {
        return Err(GpuError::Unsupported {
            what: format!(
                "loops this long on this adapter: it ended the loops of material element {} \
                 early (llvmpipe stops a shader's loops after 65 535 iterations; the Jacobi \
                 sweeps of an element's (N k)² frame Hessian reach that from N k ≈ 20): use a \
                 hardware adapter or the CPU backend",
                word & !MATERIAL_LOOPS
            ),
        });
    }
    refuse_cut_loops(status)
}
