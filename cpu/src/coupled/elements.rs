//! The coupling elements of the coupled implicit step: springs, materials,
//! ball–ball barriers and lagged pair friction, evaluated element by
//! element and gathered per particle in one fixed order.
//!
//! ```text
//! elements  springs and materials (Plan::families, family then colour order), ball pairs
//!           (pair order), pair-friction lags (pair order at x^t)
//! record e  [E_e, c_0, c_1, ∇E_e (S values), aux_e (S values)],   S = max arity · N
//!           spring:    c = (along, across) radial | (1/α, ·) Gauss–Newton;  aux = ∇C
//!           material:  c, aux unused; H_F⁺ in `blocks` (materials.rs), one block per material
//!           expression: c, aux unused; K⁺ ((arity·N)², core's expression_spring) in `blocks`
//!           ball:      c = (along, across) of K⁺;                            aux = ∇d = (−n, n)
//!           friction:  c = (along, across) of the tangent K;                 aux = (û, ·)
//! gather    particle k: Σ over its slots (element order, then the slot within the element)
//! ```
//! Each element writes only its own record or product slot, each particle
//! reads its own list: the passes split over the threads and give the same
//! bytes for any thread count.

// Index loops mirror the math line by line.
#![allow(clippy::needless_range_loop)]

mod contact_gradients;
mod materials;

use crate::parallel::Workers;
use hyperpbd_core::barrier::BarrierLaw;
use hyperpbd_core::broadphase::Pair;
use hyperpbd_core::geometry::Scratch;
use hyperpbd_core::implicit::resolution::{ball_rounding, spring_rounding};
use hyperpbd_core::implicit::{
    ElementLists, ExpressionScratch, PairLag, RadialCurvature, Spring, SpringCurvature,
    TangentCurvature, apply_dense, ball_pair_barrier, evaluate_spring, expression_rounding,
    expression_spring, pair_friction,
};
use hyperpbd_core::{ConstraintKind, FamilyKind, Plan};
use materials::MaterialBuffers;
use std::ops::Range;

/// Elements per chunk of the element passes.
pub const ELEMENT_GRAIN: usize = 256;

/// What one element is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    /// Element `element` of family `family`.
    Spring { family: u32, element: u32 },
    /// Element `element` of the material family `family`, its H_F⁺ block
    /// the `block`-th of `blocks`.
    Material {
        family: u32,
        element: u32,
        block: u32,
    },
    /// Element `element` of the expression family `family`, its K⁺ the
    /// `block`-th of `blocks`.
    Expression {
        family: u32,
        element: u32,
        block: u32,
    },
    /// A ball–ball barrier.
    Ball,
    /// Pair friction of lag `lag`.
    Friction { lag: u32 },
}

/// The element list of one pair set, with its per-particle gather lists.
#[derive(Debug, Default)]
pub struct Elements {
    kinds: Vec<Kind>,
    /// Members and per-particle gather lists (core's `ElementLists`).
    lists: ElementLists,
    /// One record per element (see the module docs).
    pub records: Vec<f64>,
    /// Product / diagonal values per slot (`arity_max · N` per element).
    slots: Vec<f64>,
    /// Element index of each dense block (material and expression elements).
    blocks: Vec<u32>,
    /// Per block: H_F⁺ of a material, K⁺ of an expression; `block_stride`
    /// values each.
    block_values: Vec<f64>,
    block_stride: usize,
}

/// Buffers of one chunk of element evaluations.
#[derive(Debug, Default)]
struct Buffers {
    geometry: Scratch,
    material: MaterialBuffers,
    expression: ExpressionScratch,
}

impl Elements {
    /// Number of elements.
    pub fn len(&self) -> usize {
        self.kinds.len()
    }

    /// The first particle of element e (for a report).
    pub fn first_particle(&self, e: usize) -> usize {
        self.lists.members(e)[0] as usize
    }

    /// Values per record.
    fn record_len(&self, dim: usize) -> usize {
        3 + 2 * self.lists.arity_max * dim
    }

    /// Rebuilds the list: every spring of `plan`, the ball pairs `balls`
    /// (with `collisions`) and the friction lags `lags`.
    pub fn rebuild(&mut self, plan: &Plan, balls: &[Pair], lags: &[PairLag]) {
        let arity_max = plan.families.iter().map(|f| f.arity).fold(2, usize::max);
        self.kinds.clear();
        self.lists.clear(arity_max);
        self.blocks.clear();
        self.block_stride = materials::block_stride(plan);
        let mut next = 0u32;
        for (f, family) in plan.families.iter().enumerate() {
            let material = family.kind.rest_view(0).is_some();
            let expression = matches!(family.kind, FamilyKind::Expression(_));
            for e in 0..family.len() {
                let members = &family.elements[e * family.arity..(e + 1) * family.arity];
                let (family, element) = (f as u32, e as u32);
                let block = self.blocks.len() as u32;
                let kind = if material {
                    Kind::Material {
                        family,
                        element,
                        block,
                    }
                } else if expression {
                    Kind::Expression {
                        family,
                        element,
                        block,
                    }
                } else {
                    Kind::Spring { family, element }
                };
                if material || expression {
                    self.blocks.push(next);
                }
                self.kinds.push(kind);
                self.lists.push(members);
                next += 1;
            }
        }
        for pair in balls {
            self.kinds.push(Kind::Ball);
            self.lists.push(pair);
        }
        for (l, lag) in lags.iter().enumerate() {
            self.kinds.push(Kind::Friction { lag: l as u32 });
            self.lists.push(&lag.pair);
        }
        self.lists.build_gather(plan.particle_count());
    }

    /// The points of element e at `x` into `points` (arity × N).
    fn gather_points(&self, e: usize, x: &[f64], dim: usize, points: &mut [f64]) -> usize {
        let members = self.lists.members(e);
        for (j, &i) in members.iter().enumerate() {
            let i = i as usize;
            points[j * dim..(j + 1) * dim].copy_from_slice(&x[i * dim..(i + 1) * dim]);
        }
        members.len()
    }

    /// Evaluates every element at `x` into [`Elements::records`]; the
    /// first element (index) whose energy or gradient is not finite.
    pub fn evaluate(
        &mut self,
        workers: &Workers,
        terms: &Terms<'_>,
        x: &[f64],
    ) -> Result<(), usize> {
        let dim = terms.plan.dim;
        let stride = self.record_len(dim);
        self.fill_blocks(
            |e| &mut e.records,
            workers,
            self.len(),
            stride,
            |this, r, out| {
                let mut scratch = Buffers::default();
                let mut points = vec![0.0; this.lists.arity_max * dim];
                for e in r.clone() {
                    let record = &mut out[(e - r.start) * stride..(e - r.start + 1) * stride];
                    this.evaluate_one(e, terms, x, &mut points, record, &mut scratch);
                    if !record.iter().all(|v| v.is_finite()) {
                        return Err(e);
                    }
                }
                Ok(())
            },
        )
    }

    /// Refills the array `blocks` picks with `len` zero blocks of `stride`
    /// reals and has `fill(self, items, their blocks)` write them, chunk by
    /// chunk on `workers`; the first item `fill` reports.
    fn fill_blocks(
        &mut self,
        blocks: fn(&mut Self) -> &mut Vec<f64>,
        workers: &Workers,
        len: usize,
        stride: usize,
        fill: impl Fn(&Self, Range<usize>, &mut [f64]) -> Result<(), usize> + Sync,
    ) -> Result<(), usize> {
        let mut out = std::mem::take(blocks(self));
        out.clear();
        out.resize(len * stride, 0.0);
        let this = &*self;
        let result = workers.try_for_spans(len, ELEMENT_GRAIN, stride, [&mut out], |r, [o]| {
            fill(this, r, o)
        });
        *blocks(self) = out;
        result
    }

    /// One element's record at `x`.
    fn evaluate_one(
        &self,
        e: usize,
        terms: &Terms<'_>,
        x: &[f64],
        points: &mut [f64],
        record: &mut [f64],
        scratch: &mut Buffers,
    ) {
        let dim = terms.plan.dim;
        let arity = self.gather_points(e, x, dim, points);
        let width = self.lists.arity_max * dim;
        let (head, rest) = record.split_at_mut(3);
        let (gradient, aux) = rest.split_at_mut(width);
        let points = &points[..arity * dim];
        match self.kinds[e] {
            Kind::Spring { family, element } => {
                let family = &terms.plan.families[family as usize];
                let element = element as usize;
                let spring = evaluate_spring(
                    constraint_kind(&family.kind),
                    family.compliance,
                    family.rest[element],
                    points,
                    dim,
                    &mut aux[..arity * dim],
                    &mut gradient[..arity * dim],
                    &mut scratch.geometry,
                );
                head[0] = spring.energy;
                (head[1], head[2]) = match spring.curvature {
                    SpringCurvature::Radial(k) => (k.along, k.across),
                    SpringCurvature::GaussNewton { weight } => (weight, 0.0),
                };
            }
            Kind::Material {
                family, element, ..
            } => {
                head[0] = materials::energy(
                    &terms.plan.families[family as usize],
                    element as usize,
                    points,
                    dim,
                    &mut gradient[..arity * dim],
                    &mut scratch.material,
                );
            }
            Kind::Expression {
                family, element, ..
            } => {
                let family = &terms.plan.families[family as usize];
                let element = element as usize;
                let spring = expression_spring(
                    expression_kind(&family.kind),
                    element,
                    (family.compliance, family.rest[element]),
                    points,
                    &mut gradient[..arity * dim],
                    &mut scratch.expression,
                );
                head[0] = spring.energy;
            }
            Kind::Ball => {
                let (i, j) = self.pair(e);
                let radii = (terms.plan.radius[i], terms.plan.radius[j]);
                let ball = ball_pair_barrier(
                    terms.law,
                    points,
                    radii,
                    dim,
                    &mut aux[..2 * dim],
                    &mut gradient[..2 * dim],
                );
                head[0] = ball.energy;
                (head[1], head[2]) = (ball.curvature.along, ball.curvature.across);
            }
            Kind::Friction { lag } => {
                let lag = &terms.lags[lag as usize];
                let (i, j) = self.pair(e);
                let mut starts = [0.0f64; 2 * hyperpbd_core::MAX_DIM];
                starts[..dim].copy_from_slice(&terms.start[i * dim..(i + 1) * dim]);
                starts[dim..2 * dim].copy_from_slice(&terms.start[j * dim..(j + 1) * dim]);
                let term = pair_friction(
                    &lag.normal,
                    lag.force_limit,
                    terms.slip_length,
                    points,
                    &starts[..2 * dim],
                    &mut gradient[..2 * dim],
                    &mut aux[..dim],
                );
                head[0] = term.energy;
                (head[1], head[2]) = (term.curvature.along, term.curvature.across);
            }
        }
    }

    /// (i, j) of a two-particle element.
    fn pair(&self, e: usize) -> (usize, usize) {
        let members = self.lists.members(e);
        (members[0] as usize, members[1] as usize)
    }

    /// out (arity × N) = K_e⁺ p_e (`p` = None: the diagonal of K_e⁺ instead)
    /// from element e's record.
    fn curvature_of(
        &self,
        e: usize,
        terms: &Terms<'_>,
        record: &[f64],
        p: Option<&[f64]>,
        out: &mut [f64],
        buffers: &mut MaterialBuffers,
    ) {
        let dim = terms.plan.dim;
        let arity = self.lists.arity[e] as usize;
        let width = self.lists.arity_max * dim;
        let aux = &record[3 + width..3 + width + arity * dim];
        let radial = RadialCurvature {
            along: record[1],
            across: record[2],
        };
        match self.kinds[e] {
            Kind::Spring { family, .. } => {
                let curvature = match terms.plan.families[family as usize].kind {
                    FamilyKind::Distance | FamilyKind::Tether => SpringCurvature::Radial(radial),
                    FamilyKind::SimplexMeasure { .. }
                    | FamilyKind::OrientedMeasure
                    | FamilyKind::Material { .. }
                    | FamilyKind::HyperplaneContact { .. }
                    | FamilyKind::MeshContact { .. } => {
                        SpringCurvature::GaussNewton { weight: record[1] }
                    }
                    FamilyKind::Expression(_) => {
                        unreachable!("an expression family is an expression element (rebuild)")
                    }
                };
                let spring = Spring {
                    energy: record[0],
                    value: 0.0,
                    curvature,
                };
                match p {
                    None => spring.diagonal(aux, dim, &mut out[..arity * dim]),
                    Some(p) => spring.apply(aux, dim, &p[..arity * dim], &mut out[..arity * dim]),
                }
            }
            Kind::Material {
                family,
                element,
                block,
            } => {
                let stride = self.block_stride;
                let start = block as usize * stride;
                materials::curvature(
                    &terms.plan.families[family as usize],
                    element as usize,
                    &self.block_values[start..start + stride],
                    dim,
                    p,
                    out,
                    buffers,
                );
            }
            Kind::Expression { block, .. } => {
                let n = arity * dim;
                let start = block as usize * self.block_stride;
                let block = &self.block_values[start..start + n * n];
                apply_dense(block, p.map(|p| &p[..n]), &mut out[..n]);
            }
            Kind::Ball => {
                let normal = &aux[dim..2 * dim];
                match p {
                    None => {
                        radial.diagonal(normal, &mut out[..dim]);
                        out.copy_within(..dim, dim);
                    }
                    Some(p) => radial.apply(normal, &p[..2 * dim], &mut out[..2 * dim]),
                }
            }
            Kind::Friction { lag } => {
                let normal = &terms.lags[lag as usize].normal;
                let tangent = TangentCurvature {
                    along: record[1],
                    across: record[2],
                };
                let slip_direction = &aux[..dim];
                match p {
                    None => {
                        tangent.diagonal(normal, slip_direction, &mut out[..dim]);
                        out.copy_within(..dim, dim);
                    }
                    Some(p) => {
                        let p = &p[..2 * dim];
                        tangent.apply_pair(normal, slip_direction, p, &mut out[..2 * dim]);
                    }
                }
            }
        }
    }

    /// Per-slot K_e⁺ p (or the diagonal with `diagonal`) into the slot
    /// buffer, element by element.
    pub fn fill_slots(&mut self, workers: &Workers, terms: &Terms<'_>, p: &[f64], diagonal: bool) {
        let dim = terms.plan.dim;
        let width = self.lists.arity_max * dim;
        let stride = self.record_len(dim);
        let _ = self.fill_blocks(
            |e| &mut e.slots,
            workers,
            self.len(),
            width,
            |this, r, out| {
                let mut points = vec![0.0; width];
                let mut buffers = MaterialBuffers::default();
                for e in r.clone() {
                    let record = &this.records[e * stride..(e + 1) * stride];
                    if !diagonal {
                        this.gather_points(e, p, dim, &mut points);
                    }
                    let slot = &mut out[(e - r.start) * width..(e - r.start + 1) * width];
                    let p = (!diagonal).then_some(&points[..]);
                    this.curvature_of(e, terms, record, p, slot, &mut buffers);
                }
                Ok(())
            },
        );
    }

    /// Adds particle k's gathered values from `source` (records' gradients
    /// with `gradient`, else the slots) into `out` (length N).
    pub fn gather(&self, k: usize, dim: usize, gradient: bool, out: &mut [f64]) {
        let arity_max = self.lists.arity_max;
        let width = arity_max * dim;
        let stride = 3 + 2 * width;
        for &slot in self.lists.slots_of(k) {
            let (e, local) = (slot as usize / arity_max, slot as usize % arity_max);
            let values = if gradient {
                &self.records[e * stride + 3 + local * dim..e * stride + 3 + (local + 1) * dim]
            } else {
                &self.slots[e * width + local * dim..e * width + (local + 1) * dim]
            };
            for a in 0..dim {
                out[a] += values[a];
            }
        }
    }

    /// E_e(y) − E_e(x) per element into `changes` (length `len()`), from
    /// the records at x. A non-finite change means y is infeasible.
    pub fn changes(&self, workers: &Workers, terms: &Terms<'_>, y: &[f64], changes: &mut Vec<f64>) {
        let dim = terms.plan.dim;
        let stride = self.record_len(dim);
        changes.clear();
        changes.resize(self.len(), 0.0);
        let _ = workers.try_for_spans(self.len(), ELEMENT_GRAIN, 1, [changes], |r, [out]| {
            let mut scratch = Buffers::default();
            let mut points = vec![0.0; self.lists.arity_max * dim];
            let mut record = vec![0.0; stride];
            for e in r.clone() {
                // record[0]: the element's energy at y (+∞ for a ball pair
                // at d ≤ 0).
                self.evaluate_one(e, terms, y, &mut points, &mut record, &mut scratch);
                out[e - r.start] = record[0] - self.records[e * stride];
            }
            Ok(())
        });
    }

    /// Σ |E_e|, and Σ |∂E_e/∂C| δC_e over the springs plus Σ |b'_e| δd_e
    /// over the ball pairs at the records' point (the rounding floor of F's
    /// change: an energy of a cancelling difference inherits that
    /// difference's rounding at its slope), both in element order.
    pub fn energy_scale(&self, terms: &Terms<'_>, x: &[f64]) -> (f64, f64) {
        let dim = terms.plan.dim;
        let stride = self.record_len(dim);
        let (mut energy, mut force) = (0.0, 0.0);
        let mut points = vec![0.0; self.lists.arity_max * dim];
        let mut buffers = MaterialBuffers::default();
        for e in 0..self.len() {
            energy += self.records[e * stride].abs();
            match self.kinds[e] {
                Kind::Spring { family, element } => {
                    let family = &terms.plan.families[family as usize];
                    force += spring_rounding(
                        self.records[e * stride],
                        family.compliance,
                        family.rest[element as usize],
                        dim,
                    );
                }
                Kind::Material {
                    family, element, ..
                } => {
                    let arity = self.gather_points(e, x, dim, &mut points);
                    let family = &terms.plan.families[family as usize];
                    let points = &points[..arity * dim];
                    force +=
                        materials::rounding(family, element as usize, points, dim, &mut buffers);
                }
                Kind::Expression {
                    family, element, ..
                } => {
                    let family = &terms.plan.families[family as usize];
                    force += expression_rounding(
                        expression_kind(&family.kind),
                        self.records[e * stride],
                        family.compliance,
                        family.rest[element as usize],
                    );
                }
                Kind::Ball => {
                    let (i, j) = self.pair(e);
                    self.gather_points(e, x, dim, &mut points);
                    let radii = (terms.plan.radius[i], terms.plan.radius[j]);
                    force += ball_rounding(terms.law, &points[..2 * dim], radii, dim);
                }
                Kind::Friction { .. } => {}
            }
        }
        (energy, force)
    }
}

/// The spring kind of a compiled family.
fn constraint_kind(kind: &FamilyKind) -> ConstraintKind {
    match kind {
        FamilyKind::Distance => ConstraintKind::Distance,
        FamilyKind::Tether => ConstraintKind::Tether,
        FamilyKind::SimplexMeasure { .. } => ConstraintKind::SimplexMeasure,
        // Contact families do not exist on the barrier path's plan.
        FamilyKind::OrientedMeasure
        | FamilyKind::HyperplaneContact { .. }
        | FamilyKind::MeshContact { .. } => ConstraintKind::OrientedMeasure,
        // Expression families are `Kind::Expression` elements.
        FamilyKind::Expression(_) => {
            unreachable!("an expression family is an expression element (Elements::rebuild)")
        }
        // Material families are `Kind::Material` elements, never springs.
        FamilyKind::Material { .. } => {
            unreachable!("a material family is no spring (Elements::rebuild)")
        }
    }
}

/// The compiled expression of an expression family.
fn expression_kind(kind: &FamilyKind) -> &hyperpbd_core::kinds::ExpressionKind {
    match kind.expression() {
        Some(expression) => expression,
        None => {
            unreachable!("expression elements come from expression families (Elements::rebuild)")
        }
    }
}

/// What element evaluation reads besides the element list.
#[derive(Debug, Clone, Copy)]
pub struct Terms<'a> {
    /// The plan (families, radii).
    pub plan: &'a Plan,
    /// κ, d^.
    pub law: &'a BarrierLaw,
    /// x^t.
    pub start: &'a [f64],
    /// Pair friction lags.
    pub lags: &'a [PairLag],
    /// ε = ε_v h.
    pub slip_length: f64,
}
