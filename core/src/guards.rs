//! State guards: read-only checks of every completed substep.
//!
//! ```text
//! "guards": {"orientation": true, "min_measure_ratio": r, "max_speed": v}
//!
//! measure ratio   J per element of every family with a rest shape
//!                 (has_rest_shape):
//!                 oriented measure   J = V(x) / V_rest, V the signed
//!                                    full-dimensional measure det([x1−x0 … xN−x0])/N!
//!                 stvk, neo_hookean  J = det F̂ (k = N, signed) or
//!                                    √(det G / det G_0) (k < N, ≥ 0), the
//!                                    material's own measure ratio
//!                                    (material::measure_ratio)
//! orientation     J > 0 is required          (inverted or collapsed: J ≤ 0;
//!                 for k < N only a collapse, J = 0, breaks it)
//! measure ratio   J ≥ r is required          (0 < r ≤ 1)
//! speed           |v_i|² ≤ v² is required   per dynamic particle, the sum
//!                 Σ_a v_a² in axis order; the report names |v_i|
//! ```
//! The plan runs the checks as kernels at the end of each substep:
//! [`crate::Kernel::GuardMeasure`] per guarded family (its elements in the
//! family's compiled slot order; per element orientation first, then the
//! ratio), then [`crate::Kernel::GuardSpeed`] (particles in index order).
//! The first violation in that order rejects the step: the backend rolls
//! it back and returns [`crate::StepError::GuardRejected`]. Both backends
//! evaluate the same arithmetic through [`measure_violation`] and
//! [`speed_violation`] (the GPU's guard kernel mirrors them in WGSL).

use crate::geometry::{Scratch, oriented_volume};
pub use crate::guard_rules::{
    Adaptive, Attempt, GuardKind, GuardRejection, GuardSubject, Guards, MAX_SUBDIVISIONS,
    guarded_families, has_rest_shape,
};
use crate::material::{LawRefusal, MaterialScratch, measure_ratio};
use crate::{Family, Plan, StageName, StepError};

/// The first element (slot order) of family `family` of `plan` that
/// breaks a measure guard at positions `x`, as (slot, guard, J, limit).
pub fn measure_violation(
    plan: &Plan,
    family: usize,
    x: &[f64],
) -> Option<(usize, GuardKind, f64, f64)> {
    let guards = plan.guards.as_ref()?;
    let mut ratios = ElementRatios::new(plan, family)?;
    (0..ratios.family.len()).find_map(|slot| {
        let j = ratios.ratio(slot, x);
        element_verdict(guards, j).map(|(kind, limit)| (slot, kind, j, limit))
    })
}

/// J of element `slot` (compiled order) of family `family` at positions
/// `x` (NaN for a family without a rest shape or a slot past its end).
pub fn element_ratio_at(plan: &Plan, family: usize, slot: usize, x: &[f64]) -> f64 {
    ElementRatios::new(plan, family)
        .filter(|r| slot < r.family.len())
        .map_or(f64::NAN, |mut r| r.ratio(slot, x))
}

/// J of the elements of one family with a rest shape, with the scratch
/// of the measure (the value alone: bit for bit the measure the
/// projection and the GPU's guard kernel compute).
struct ElementRatios<'a> {
    dim: usize,
    family: &'a Family,
    points: Vec<f64>,
    scratch: Scratch,
    material_scratch: MaterialScratch,
}

impl<'a> ElementRatios<'a> {
    fn new(plan: &'a Plan, family: usize) -> Option<Self> {
        let fam = plan.families.get(family)?;
        if !has_rest_shape(fam) {
            return None;
        }
        Some(ElementRatios {
            dim: plan.dim,
            family: fam,
            points: vec![0.0; fam.arity * plan.dim],
            scratch: Scratch::new(),
            material_scratch: MaterialScratch::new(),
        })
    }

    /// J of element `slot` at positions `x` (see the module docs).
    fn ratio(&mut self, slot: usize, x: &[f64]) -> f64 {
        let (dim, arity) = (self.dim, self.family.arity);
        let element = &self.family.elements[slot * arity..(slot + 1) * arity];
        for (j, &i) in element.iter().enumerate() {
            let i = i as usize;
            self.points[j * dim..(j + 1) * dim].copy_from_slice(&x[i * dim..(i + 1) * dim]);
        }
        match self.family.kind.rest_view(slot) {
            Some((_, rest)) => measure_ratio(&self.points, dim, rest, &mut self.material_scratch),
            None => oriented_volume(&self.points, dim, &mut self.scratch) / self.family.rest[slot],
        }
    }
}

/// The guard an element of ratio `j` breaks (orientation first), with its
/// limit.
pub fn element_verdict(guards: &Guards, j: f64) -> Option<(GuardKind, f64)> {
    if guards.orientation && (j <= 0.0 || j.is_nan()) {
        return Some((GuardKind::Orientation, 0.0));
    }
    match guards.min_measure_ratio {
        Some(r) if j < r || j.is_nan() => Some((GuardKind::MinMeasureRatio, r)),
        _ => None,
    }
}

/// |v_i|² as the speed guard sums it: Σ_a v_a² in axis order.
pub fn squared_speed(v: &[f64]) -> f64 {
    v.iter().fold(0.0, |s, &a| s + a * a)
}

/// The first dynamic particle of `plan` faster than the speed guard at
/// velocities `v`, as (particle, |v|, limit).
pub fn speed_violation(plan: &Plan, v: &[f64]) -> Option<(usize, f64, f64)> {
    let limit = plan.guards.as_ref()?.max_speed?;
    let bound = limit * limit;
    let dim = plan.dim;
    (0..plan.particle_count()).find_map(|i| {
        if plan.inverse_mass[i] == 0.0 {
            return None;
        }
        let s2 = squared_speed(&v[i * dim..(i + 1) * dim]);
        (s2 > bound || s2.is_nan()).then(|| (i, s2.sqrt(), limit))
    })
}

/// The rejection of `substep` for the measure violation `found` of
/// family `family` (slot → authored element).
pub fn measure_rejection(
    plan: &Plan,
    family: usize,
    found: (usize, GuardKind, f64, f64),
    substep: u32,
) -> GuardRejection {
    let (slot, guard, value, limit) = found;
    let fam = &plan.families[family];
    GuardRejection {
        guard,
        subject: GuardSubject::Element {
            family,
            family_label: fam.label.clone(),
            element: fam.authored_element(slot),
        },
        value,
        limit,
        substep,
    }
}

/// The step error of a material projection the law refused inside
/// `substep` (a Neo-Hookean element of family `family`, compiled slot
/// `slot`, collapsed or inverted) — one rule for both backends: under
/// element guards it is the guards' rejection, so that an adaptive step
/// retries it; without them it stays `StepError::MaterialRefused`.
///
/// ```text
/// J ≤ 0 (or collapsed to rounding) with orientation on  →  orientation
/// J < r with min_measure_ratio r                        →  min_measure_ratio
/// ```
/// The end-of-substep check would have rejected the same element had the
/// projection been allowed to finish: a collapse or inversion is exactly
/// what these guards exist to catch, and the law cannot evaluate past it.
pub fn material_refusal_error(
    plan: &Plan,
    family: usize,
    slot: usize,
    refusal: LawRefusal,
    substep: u32,
) -> StepError {
    let j = refusal.measure_ratio();
    let verdict = plan.guards.as_ref().and_then(|guards| {
        element_verdict(guards, j)
            .or_else(|| guards.orientation.then_some((GuardKind::Orientation, 0.0)))
    });
    if let Some((guard, limit)) = verdict {
        let found = (slot, guard, j, limit);
        return StepError::GuardRejected(measure_rejection(plan, family, found, substep));
    }
    let fam = &plan.families[family];
    StepError::MaterialRefused {
        stage: StageName::Project,
        substep,
        family,
        family_label: fam.label.clone(),
        element: fam.authored_element(slot),
        refusal,
    }
}

/// The rejection of `substep` for the speed violation `found`.
pub fn speed_rejection(found: (usize, f64, f64), substep: u32) -> GuardRejection {
    let (particle, value, limit) = found;
    GuardRejection {
        guard: GuardKind::MaxSpeed,
        subject: GuardSubject::Particle(particle),
        value,
        limit,
        substep,
    }
}
