//! Expression families: C = value(x0 … x{arity−1}) − rest for a user's
//! `value` expression (docs/expressions.md), compiled once per (dimension,
//! arity) by [`crate::expr`] into straight-line tapes; ∇C is derived,
//! never written. The projection (`expression_projection.rs`) is generic
//! over the precision, so the golden path (f64) and the f32 reference
//! (f32) run one code, and the WGSL kernel performs the same operations in
//! the same order.
//!
//! ```text
//! per block of BLOCK = 64 slots of a colour: gather, the value+gradient tape
//!   over the block (a column per tape slot), then the update below
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

use super::real::ProjectionReal;
use super::relation::Relation;
use crate::expr::{self, Columns, Compiled, Outputs, ParamValue, Real, Slot, Stats, Tape};

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
    pub(super) gradient_inputs: Vec<Option<Slot>>,
    /// The slot of each input in [`ExpressionKind::value`].
    pub(super) value_inputs: Vec<Option<Slot>>,
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
        let (gradient_inputs, value_inputs) = (gradient.input_slots(), value.input_slots());
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
            value_inputs,
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

    /// The gradient tape in f64 on `slots` of a family whose particle
    /// indices are `elements`, at the flat positions `x` (the golden path's
    /// [`Self::eval_slots`]).
    pub fn gradient_slots(
        &self,
        dim: usize,
        elements: &[u32],
        slots: Range<usize>,
        x: &[f64],
        columns: &mut Columns<f64>,
    ) {
        let (tape, constants) = (&self.gradient, &self.constants);
        self.eval_slots(tape, dim, elements, constants, slots, |k| x[k], columns);
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
