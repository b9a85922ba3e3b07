//! Expression families: C = value(x0 … x{arity−1}) − rest for a user's
//! `value` expression (docs/expressions.md), compiled once per (dimension,
//! arity) by [`crate::expr`] into straight-line tapes; ∇C is derived,
//! never written. The projection below is generic over the precision, so
//! the golden path (f64) and the f32 reference (f32) run one code, and
//! the WGSL kernel performs the same operations in the same order.
//!
//! ```text
//! per block of BLOCK = 64 slots of a colour: gather the coordinates, evaluate
//!   the value+gradient tape over the block (a column per tape slot) and the
//!   wsum and Δλ below lane-wise (the same operations per lane), then update
//!   (elements of a colour share no dynamic particle, so this equals
//!   evaluating them one after another); the tape's inputs are the element's
//!   coordinates, then its per-element constants (m per element, computed at
//!   load: bending's quadratic weights)
//! per element, in slot order:
//!   C non-finite                         → the element fails (typed step error)
//!   wsum = Σ_j [w_j ≠ 0] w_j Σ_a g_ja²    (j, then a ascending; fixed particles skipped)
//!   wsum non-finite or 0                 → no response (∇C zero or undefined)
//!   Δλ = (−(C − rest) − α~ λ) / (wsum + α~);  non-finite → the element fails
//!   "==": λ' = λ + Δλ
//!   ">=": t = λ + Δλ; λ' = t < 0 ? 0 : t; Δλ = λ' − λ     "<=": λ' = t < 0 ? t : 0; Δλ = λ' − λ
//!   x_j += (w_j g_j) Δλ  (dynamic j)
//! violation: "==" |C|, ">=" max(−C, 0), "<=" max(C, 0)
//! ```

use std::ops::Range;
use std::sync::OnceLock;

use multiversion::multiversion;

use super::real::ProjectionReal;
use super::relation::Relation;
use crate::expr::{
    self, BLOCK, Block, Column, Columns, Compiled, Outputs, ParamValue, Real, Slot, Stats, Tape,
};

/// A compiled expression family.
#[derive(Debug, Clone)]
pub struct ExpressionKind {
    /// What the plan calls it: `expression`, or the built-in kind it
    /// defines (`bending`).
    pub name: &'static str,
    /// The value expression.
    pub source: String,
    /// Its relation.
    pub relation: Relation,
    /// Particles per element.
    pub arity: usize,
    /// C alone (rest values, residuals).
    pub value: Tape,
    /// C and ∇C (the projection).
    pub gradient: Tape,
    /// Per-element constants m (tape inputs arity·dim … + m − 1).
    pub element_constants: usize,
    /// The constants, m per element in the family's element order
    /// (authored order as [`crate::kinds::expression_of`] builds them,
    /// colour order in a [`crate::Plan`]); read them with
    /// [`ExpressionKind::constants`].
    pub constants: Vec<f64>,
    /// The rest value an element takes when the family gives none
    /// (`None`: C at the authored positions, the rule of every family;
    /// quadratic bending: 0, flat).
    pub fixed_rest: Option<f64>,
    /// The slot of each input in [`ExpressionKind::gradient`].
    gradient_inputs: Vec<Option<Slot>>,
    compiled: Compiled,
    /// C, ∇C and ∇²C, derived on first request (the implicit paths).
    hessian: OnceLock<Result<Tape, expr::ExprError>>,
}

impl PartialEq for ExpressionKind {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
            && self.source == other.source
            && self.relation == other.relation
            && self.arity == other.arity
            && self.gradient == other.gradient
            && self.element_constants == other.element_constants
            && self.fixed_rest == other.fixed_rest
            && self.constants.len() == other.constants.len()
            && (self.constants.iter().zip(&other.constants))
                .all(|(a, b)| a.to_bits() == b.to_bits())
    }
}

impl ExpressionKind {
    /// The expression `source` named `name` (`expression`, or the built-in
    /// kind it defines) with `params`, for elements of `arity` particles in
    /// R^`dim`.
    pub fn new(
        name: &'static str,
        source: &str,
        params: &[(String, ParamValue)],
        relation: Relation,
        arity: usize,
        dim: usize,
    ) -> Result<ExpressionKind, expr::ExprError> {
        Self::with_constants(name, source, params, &[], Vec::new(), relation, arity, dim)
    }

    /// [`ExpressionKind::new`] with per-element constants named `names`
    /// (scalars in `source`), `constants` holding `names.len()` values per
    /// element (authored order).
    #[allow(clippy::too_many_arguments)]
    pub fn with_constants(
        name: &'static str,
        source: &str,
        params: &[(String, ParamValue)],
        names: &[&str],
        constants: Vec<f64>,
        relation: Relation,
        arity: usize,
        dim: usize,
    ) -> Result<ExpressionKind, expr::ExprError> {
        let compiled = expr::compile_with_constants(source, params, names, arity, dim)?;
        let value = compiled.tape(Outputs::Value)?;
        let gradient = compiled.tape(Outputs::ValueGradient)?;
        let gradient_inputs = gradient.input_slots();
        Ok(ExpressionKind {
            name,
            source: source.into(),
            relation,
            arity,
            value,
            gradient,
            element_constants: names.len(),
            constants,
            fixed_rest: None,
            gradient_inputs,
            compiled,
            hessian: OnceLock::new(),
        })
    }

    /// The constants of element `e` (the family's element order: colour
    /// order in a plan); empty for a kind without per-element constants.
    pub fn constants(&self, e: usize) -> &[f64] {
        let m = self.element_constants;
        &self.constants[e * m..(e + 1) * m]
    }

    /// This kind with its elements' constants in the order `source`
    /// (`source[slot]` = the element's index in the current order: the
    /// plan's colour order from the authored one).
    pub fn reordered(&self, source: &[u32]) -> ExpressionKind {
        let mut out = self.clone();
        out.constants = (source.iter())
            .flat_map(|&e| self.constants(e as usize).iter().copied())
            .collect();
        out
    }

    /// Evaluates `tape` (one of this kind's) over slots `slots` of a family
    /// whose particle indices are `elements` (arity per slot), in
    /// precision `R`: coordinate k of the flat positions is `x(k)`, constant
    /// m of slot e is `constants[e·m_count + m]`. Lane l is slot
    /// `slots.start + l`.
    #[allow(clippy::too_many_arguments)]
    pub fn eval_slots<R: Real>(
        &self,
        tape: &Tape,
        dim: usize,
        elements: &[u32],
        constants: &[R],
        slots: Range<usize>,
        x: impl Fn(usize) -> R,
        columns: &mut Columns<R>,
    ) {
        let (arity, m) = (self.arity, self.element_constants);
        let n = arity * dim;
        let first = slots.start;
        tape.eval(
            slots.len(),
            |j, lane| {
                let e = first + lane;
                if j < n {
                    x(elements[e * arity + j / dim] as usize * dim + j % dim)
                } else {
                    constants[e * m + (j - n)]
                }
            },
            columns,
        );
    }

    /// Op counts and derivative sizes (`hyperpbd plan`).
    pub fn stats(&self) -> Stats {
        self.compiled.stats()
    }

    /// C, ∇C and ∇²C (the implicit paths), derived once on first request;
    /// an error when the derivatives exceed the tape limits.
    pub fn hessian_tape(&self) -> Result<&Tape, expr::ExprError> {
        let tape = self
            .hessian
            .get_or_init(|| self.compiled.tape(Outputs::ValueGradientHessian));
        tape.as_ref().map_err(Clone::clone)
    }

    /// [`ExpressionKind::hessian_tape`] of a family that validation let onto
    /// an implicit path (it derives the tape there and refuses a failure).
    pub fn hessian(&self) -> &Tape {
        self.hessian_tape()
            .expect("validation derives ∇²C of every implicit plan's expression family")
    }

    /// C of element `e` (its constants: [`ExpressionKind::constants`]) at
    /// `points` (arity × `dim`), in precision `R` (constants rounded once).
    pub fn value_at<R: Real>(&self, e: usize, points: &[R], columns: &mut Columns<R>) -> R {
        self.eval_at(&self.value, e, points, columns);
        columns.get(self.value.value, 0)
    }

    /// Runs `tape` (one of this kind's) on element `e` alone: inputs its
    /// coordinates `points` (arity × `dim`), then its constants rounded
    /// once to `R`; read the outputs from `columns` (lane 0).
    pub fn eval_at<R: Real>(&self, tape: &Tape, e: usize, points: &[R], columns: &mut Columns<R>) {
        let n = tape.inputs;
        let constants = self.constants(e);
        tape.eval(
            1,
            |j, _| match j < n {
                true => points[j],
                false => R::constant(constants[j - n]),
            },
            columns,
        );
    }

    /// The rest value of element `e` at its authored `points` when the
    /// family gives none.
    pub fn default_rest(&self, e: usize, points: &[f64], columns: &mut Columns<f64>) -> f64 {
        match self.fixed_rest {
            Some(rest) => rest,
            None => self.value_at(e, points, columns),
        }
    }

    /// C of slots `slots` of a family of this kind (`elements`: `arity`
    /// particle indices per slot) at `x` (flat, `dim` per particle), in
    /// precision `R`: the value tape over blocks of [`BLOCK`] slots, each
    /// value handed to `each(slot, C)` in slot order. Bit for bit
    /// [`ExpressionKind::value_at`] per slot.
    pub fn values<R: Real>(
        &self,
        dim: usize,
        elements: &[u32],
        slots: Range<usize>,
        x: &[R],
        block: &mut Block<R>,
        mut each: impl FnMut(usize, R),
    ) {
        let (arity, m) = (self.arity, self.element_constants);
        let n = arity * dim;
        let mut start = slots.start;
        while start < slots.end {
            let block_slots = start..BLOCK.min(slots.end - start) + start;
            self.value.eval_block(block, |j, column| {
                let (p, a) = (j / dim, j % dim);
                for (lane, e) in block_slots.clone().enumerate() {
                    column[lane] = match j < n {
                        true => x[elements[e * arity + p] as usize * dim + a],
                        false => R::constant(self.constants[e * m + (j - n)]),
                    };
                }
            });
            let value = block.column(self.value.value);
            for (lane, e) in block_slots.clone().enumerate() {
                each(e, value[lane]);
            }
            start = block_slots.end;
        }
    }

    /// The violation of an element whose value is `value` and rest `rest`,
    /// in precision `R`.
    pub fn violation<R: ProjectionReal>(&self, value: R, rest: R) -> R {
        let c = value - rest;
        let zero = R::constant(0.0);
        let positive = |v: R| if v > zero { v } else { zero };
        match self.relation {
            Relation::Equal => c.abs(),
            Relation::AtLeast => positive(-c),
            Relation::AtMost => positive(c),
        }
    }
}

/// Positions an expression projection reads and writes (flat, `dim` per
/// particle).
pub trait Positions<R> {
    /// Coordinate `k`.
    fn get(&self, k: usize) -> R;
    /// Sets coordinate `k`.
    fn set(&mut self, k: usize, value: R);
}

impl<R: Copy> Positions<R> for [R] {
    fn get(&self, k: usize) -> R {
        self[k]
    }
    fn set(&mut self, k: usize, value: R) {
        self[k] = value;
    }
}

/// Slots `slots` (one colour, or a chunk of one) of an expression family
/// in precision `R`.
pub struct Colour<'a, R> {
    /// The family's kind.
    pub kind: &'a ExpressionKind,
    /// Dimension N.
    pub dim: usize,
    /// The family's particle indices, `arity` per (colour-ordered) slot.
    pub elements: &'a [u32],
    /// The family's rest values, per slot.
    pub rest: &'a [R],
    /// The family's per-element constants, `kind.element_constants` per
    /// slot (the kind's [`ExpressionKind::constants`] in precision `R`).
    pub constants: &'a [R],
    /// α / h².
    pub alpha_tilde: R,
    /// Inverse mass per particle.
    pub inverse_mass: &'a [R],
    /// The slots to project.
    pub slots: Range<usize>,
}

/// The projection's scratch, reused across blocks and calls: the tape's
/// columns and, per member j of the element, each lane's particle offset
/// (particle · N) and inverse mass.
#[derive(Debug, Clone, Default)]
pub struct ProjectionScratch<R> {
    block: Block<R>,
    offset: Vec<[usize; BLOCK]>,
    weight: Vec<Column<R>>,
}

impl<R: Real> ProjectionScratch<R> {
    /// Empty scratch.
    pub fn new() -> Self {
        ProjectionScratch {
            block: Block::new(),
            offset: Vec::new(),
            weight: Vec::new(),
        }
    }
}

/// Projects the slots of `c` (module docs); `lambda` holds their
/// multipliers (`lambda[0]` is slot `c.slots.start`). Every element is
/// projected; the first failing slot is returned.
///
/// The slots run in blocks of [`BLOCK`]: gather the block's coordinates,
/// evaluate the tape over the block ([`Tape::eval_block`]), then update
/// its elements in slot order. A colour's elements share no dynamic
/// particle and fixed ones are never written, so this reads and writes
/// what projecting the elements one after another would.
pub fn project<R: ProjectionReal, X: Positions<R> + ?Sized>(
    c: &Colour<'_, R>,
    x: &mut X,
    lambda: &mut [R],
    scratch: &mut ProjectionScratch<R>,
) -> Result<(), usize> {
    let mut failed = None;
    let mut start = c.slots.start;
    while start < c.slots.end {
        let len = BLOCK.min(c.slots.end - start);
        let lambda = &mut lambda[start - c.slots.start..][..len];
        if let Some(e) = project_block(c, start..start + len, x, lambda, scratch) {
            failed = failed.or(Some(e));
        }
        start += len;
    }
    failed.map_or(Ok(()), Err)
}

/// One block (≤ [`BLOCK`] slots) of [`project`]; the first failing slot.
#[multiversion(targets("x86_64+avx"))]
fn project_block<R: ProjectionReal, X: Positions<R> + ?Sized>(
    c: &Colour<'_, R>,
    slots: Range<usize>,
    x: &mut X,
    lambda: &mut [R],
    s: &mut ProjectionScratch<R>,
) -> Option<usize> {
    let (dim, arity, len) = (c.dim, c.kind.arity, slots.len());
    let tape = &c.kind.gradient;
    let zero = R::constant(0.0);
    // Gather, member by member: each lane's particle offset and inverse
    // mass, then its coordinates into the tape's input columns.
    s.offset.resize(arity, [0; BLOCK]);
    s.weight.resize(arity, [zero; BLOCK]);
    s.block.fit(tape);
    let members = &c.elements[slots.start * arity..slots.end * arity];
    for j in 0..arity {
        let (offset, weight) = (&mut s.offset[j], &mut s.weight[j]);
        for (lane, &i) in members.iter().skip(j).step_by(arity).enumerate() {
            offset[lane] = i as usize * dim;
            weight[lane] = c.inverse_mass[i as usize];
        }
        for a in 0..dim {
            if let Some(slot) = c.kind.gradient_inputs[j * dim + a] {
                let column = s.block.column_mut(slot);
                for (value, &k) in column[..len].iter_mut().zip(&s.offset[j][..len]) {
                    *value = x.get(k + a);
                }
            }
        }
    }
    // The per-element constants (tape inputs arity·N …), per lane.
    let m = c.kind.element_constants;
    for q in 0..m {
        if let Some(slot) = c.kind.gradient_inputs[arity * dim + q] {
            let column = s.block.column_mut(slot);
            for (lane, e) in slots.clone().enumerate() {
                column[lane] = c.constants[e * m + q];
            }
        }
    }
    tape.eval_block(&mut s.block, |_, _| {});
    let columns = &s.block;
    let gradient = |j: usize, a: usize| columns.column(tape.gradient[j * dim + a]);
    // wsum = Σ_j [w_j ≠ 0] w_j Σ_a g_ja², every lane at once.
    let mut wsum = [zero; BLOCK];
    for (j, w) in s.weight.iter().enumerate() {
        let mut g2 = [zero; BLOCK];
        for a in 0..dim {
            let g = gradient(j, a);
            for lane in 0..BLOCK {
                g2[lane] += g[lane] * g[lane];
            }
        }
        for lane in 0..BLOCK {
            let with = wsum[lane] + w[lane] * g2[lane];
            wsum[lane] = if w[lane] == zero { wsum[lane] } else { with };
        }
    }
    // Δλ before the clamp, every lane at once (read only where it applies).
    let value = columns.column(tape.value);
    let mut raw = [zero; BLOCK];
    for (lane, e) in slots.clone().enumerate() {
        raw[lane] = (-(value[lane] - c.rest[e]) - c.alpha_tilde * lambda[lane])
            / (wsum[lane] + c.alpha_tilde);
    }
    // Failures, responses, the clamp and λ, lane by lane.
    let mut failed = None;
    let mut dl = [zero; BLOCK];
    let mut moves = [false; BLOCK];
    for (lane, e) in slots.enumerate() {
        if !value[lane].finite() {
            failed = failed.or(Some(e));
            continue;
        }
        if !wsum[lane].finite() || wsum[lane] == zero {
            continue;
        }
        if !raw[lane].finite() {
            failed = failed.or(Some(e));
            continue;
        }
        let l = lambda[lane];
        let t = l + raw[lane];
        let (next, step) = match c.kind.relation {
            Relation::Equal => (t, raw[lane]),
            Relation::AtLeast => {
                let next = if t < zero { zero } else { t };
                (next, next - l)
            }
            Relation::AtMost => {
                let next = if t < zero { t } else { zero };
                (next, next - l)
            }
        };
        lambda[lane] = next;
        dl[lane] = step;
        moves[lane] = true;
    }
    // x_ja += (w_j g_ja) Δλ for the moving lanes' dynamic members, member j
    // then axis a (a coordinate's updates keep the element's order).
    for (j, (w, offset)) in s.weight.iter().zip(&s.offset).enumerate() {
        for a in 0..dim {
            let g = gradient(j, a);
            for lane in 0..len {
                if moves[lane] && w[lane] != zero {
                    let k = offset[lane] + a;
                    x.set(k, x.get(k) + w[lane] * g[lane] * dl[lane]);
                }
            }
        }
    }
    failed
}
