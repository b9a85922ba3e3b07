//! Expression families: C = value(x0 … x{arity−1}) − rest for a user's
//! `value` expression (docs/expressions.md), compiled once per (dimension,
//! arity) by [`crate::expr`] into straight-line tapes; ∇C is derived,
//! never written. The projection below is generic over the precision, so
//! the golden path (f64) and the f32 reference (f32) run one code, and
//! the WGSL kernel performs the same operations in the same order.
//!
//! ```text
//! per colour: evaluate the value+gradient tape over every element (a
//!   column per slot: elements of a colour share no dynamic particle, so
//!   this equals evaluating them one after another); the tape's inputs are
//!   the element's coordinates, then its per-element constants (m per
//!   element, computed at load: bending's quadratic weights)
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

use super::relation::Relation;
use crate::expr::{self, Columns, Compiled, Outputs, ParamValue, Real, Stats, Tape};

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
        let n = self.value.inputs;
        let constants = self.constants(e);
        self.value.eval(
            1,
            |j, _| match j < n {
                true => points[j],
                false => R::constant(constants[j - n]),
            },
            columns,
        );
        columns.get(self.value.value, 0)
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

/// The precisions the projection (and the numeric code both precisions
/// share: geometry::symmetric_eigen, implicit::project_psd) runs in.
pub trait ProjectionReal: Real {
    /// Neither NaN nor ±∞.
    fn finite(self) -> bool;
    /// NaN.
    fn is_nan(self) -> bool;
    /// The machine epsilon (1 ulp of 1).
    fn epsilon() -> Self;
    /// The value in f64 (exact).
    fn to_f64(self) -> f64;
}

impl ProjectionReal for f64 {
    fn finite(self) -> bool {
        self.is_finite()
    }
    fn is_nan(self) -> bool {
        f64::is_nan(self)
    }
    fn epsilon() -> Self {
        f64::EPSILON
    }
    fn to_f64(self) -> f64 {
        self
    }
}

impl ProjectionReal for f32 {
    fn finite(self) -> bool {
        self.is_finite()
    }
    fn is_nan(self) -> bool {
        f32::is_nan(self)
    }
    fn epsilon() -> Self {
        f32::EPSILON
    }
    fn to_f64(self) -> f64 {
        f64::from(self)
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

/// Projects the slots of `c` (module docs); `lambda` holds their
/// multipliers (`lambda[0]` is slot `c.slots.start`). Every element is
/// projected; the first failing slot is returned.
pub fn project<R: ProjectionReal, X: Positions<R> + ?Sized>(
    c: &Colour<'_, R>,
    x: &mut X,
    lambda: &mut [R],
    columns: &mut Columns<R>,
) -> Result<(), usize> {
    let (dim, arity) = (c.dim, c.kind.arity);
    let tape = &c.kind.gradient;
    let zero = R::constant(0.0);
    let (elements, slots) = (c.elements, c.slots.clone());
    let read = |k: usize| x.get(k);
    c.kind
        .eval_slots(tape, dim, elements, c.constants, slots, read, columns);
    let mut failed = None;
    // The columns read per element, looked up once per call.
    let values = columns.column(tape.value);
    let gradient: Vec<&[R]> = tape.gradient.iter().map(|&g| columns.column(g)).collect();
    for (lane, e) in c.slots.clone().enumerate() {
        let value = values[lane];
        if !value.finite() {
            failed = failed.or(Some(e));
            continue;
        }
        let members = &c.elements[e * arity..(e + 1) * arity];
        let mut wsum = zero;
        for (j, &i) in members.iter().enumerate() {
            let w = c.inverse_mass[i as usize];
            if w == zero {
                continue;
            }
            let mut g2 = zero;
            for column in &gradient[j * dim..(j + 1) * dim] {
                let g = column[lane];
                g2 = g2 + g * g;
            }
            wsum = wsum + w * g2;
        }
        if !wsum.finite() || wsum == zero {
            continue;
        }
        let l = lambda[lane];
        let raw = (-(value - c.rest[e]) - c.alpha_tilde * l) / (wsum + c.alpha_tilde);
        if !raw.finite() {
            failed = failed.or(Some(e));
            continue;
        }
        let t = l + raw;
        let (next, dl) = match c.kind.relation {
            Relation::Equal => (t, raw),
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
        for (j, &i) in members.iter().enumerate() {
            let i = i as usize;
            let w = c.inverse_mass[i];
            if w == zero {
                continue;
            }
            for (a, column) in gradient[j * dim..(j + 1) * dim].iter().enumerate() {
                let k = i * dim + a;
                x.set(k, x.get(k) + w * column[lane] * dl);
            }
        }
    }
    failed.map_or(Ok(()), Err)
}
