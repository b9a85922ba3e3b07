//! The XPBD projection of an expression family's colour (the per-element
//! math is in `expression.rs`'s docs), generic over the precision: the
//! golden path (f64) and the f32 reference (f32) run this one code.
//!
//! ```text
//! per block of BLOCK = 64 slots:
//!   gather  element by element: each member's offset, inverse mass and
//!           coordinates (into the tape's input columns: without the
//!           column map when they are its first columns, as compiled),
//!           the constants
//!   tape    C and ∇C over the block (Tape::eval_block, one op over the lanes)
//!   wsum = Σ_j [w_j ≠ 0] w_j Σ_a g_ja², w_j g_ja: lane by lane, each
//!           lane's sums in registers (≤ 16 coordinates; else member by
//!           member over the lanes)
//!   Δλ before the clamp and each lane's case: lane-wise over the block
//!   update  element by element in slot order: the checks, the clamp, λ,
//!           x_j += (w_j g_j) Δλ (member j, then axis a)
//! ```
//! Elements of a colour share no dynamic particle and fixed ones are
//! never written, so this reads and writes what projecting the elements
//! one after another would. Arity ≤ 4 and N ≤ 4 run compiled for their
//! (arity, N) ([`Fixed`]: the member and axis loops have constant trip
//! counts), any other shape the same source with run-time bounds ([`Any`]):
//! the same operations in the same order either way.

use std::ops::Range;

use multiversion::multiversion;

use super::expression::ExpressionKind;
use super::real::ProjectionReal;
use super::relation::Relation;
use crate::expr::{BLOCK, Block, Column, Real};

/// Positions an expression projection reads and writes (flat, `dim` per
/// particle).
pub trait Positions<R> {
    /// Coordinates `range`, to read.
    fn values(&self, range: Range<usize>) -> &[R];
    /// Coordinates `range`, to write.
    fn values_mut(&mut self, range: Range<usize>) -> &mut [R];
}

impl<R> Positions<R> for [R] {
    #[inline(always)]
    fn values(&self, range: Range<usize>) -> &[R] {
        &self[range]
    }
    #[inline(always)]
    fn values_mut(&mut self, range: Range<usize>) -> &mut [R] {
        &mut self[range]
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
    /// w_j ∂C/∂x_ja per coordinate (member j, axis a) of each lane.
    step: Vec<Column<R>>,
    /// The column map of an element of more than [`SMALL`] coordinates.
    map: [Vec<usize>; 2],
}

impl<R: Real> ProjectionScratch<R> {
    /// Empty scratch.
    pub fn new() -> Self {
        ProjectionScratch {
            block: Block::new(),
            offset: Vec::new(),
            weight: Vec::new(),
            step: Vec::new(),
            map: [Vec::new(), Vec::new()],
        }
    }
}

/// An element's shape: arity and dimension.
trait Shape: Copy {
    fn arity(self) -> usize;
    fn dim(self) -> usize;
}

/// A shape known at compile time.
#[derive(Clone, Copy)]
struct Fixed<const A: usize, const D: usize>;

impl<const A: usize, const D: usize> Shape for Fixed<A, D> {
    #[inline(always)]
    fn arity(self) -> usize {
        A
    }
    #[inline(always)]
    fn dim(self) -> usize {
        D
    }
}

/// A shape known at run time (arity, dimension).
#[derive(Clone, Copy)]
struct Any(usize, usize);

impl Shape for Any {
    #[inline(always)]
    fn arity(self) -> usize {
        self.0
    }
    #[inline(always)]
    fn dim(self) -> usize {
        self.1
    }
}

/// `shapes!((arity, dim), f(args); (A, D)…)`: `f(Fixed::<A, D>, args)`
/// for the listed shapes, `f(Any(arity, dim), args)` otherwise.
macro_rules! shapes {
    ($shape:expr, $f:ident $args:tt; $(($a:literal, $d:literal)),*) => {
        match $shape {
            $(($a, $d) => shapes!(@call $f, Fixed::<$a, $d>, $args),)*
            (arity, dim) => shapes!(@call $f, Any(arity, dim), $args),
        }
    };
    (@call $f:ident, $shape:expr, ($($arg:expr),*)) => {
        $f($shape, $($arg),*)
    };
}

/// Projects the slots of `c` (module docs); `lambda` holds their
/// multipliers (`lambda[0]` is slot `c.slots.start`). Every element is
/// projected; the first failing slot is returned.
pub fn project<R: ProjectionReal, X: Positions<R> + ?Sized>(
    c: &Colour<'_, R>,
    x: &mut X,
    lambda: &mut [R],
    scratch: &mut ProjectionScratch<R>,
) -> Result<(), usize> {
    shapes!(
        (c.kind.arity, c.dim),
        project_blocks(c, x, lambda, scratch);
        (1, 1), (1, 2), (1, 3), (1, 4), (2, 1), (2, 2), (2, 3), (2, 4),
        (3, 1), (3, 2), (3, 3), (3, 4), (4, 1), (4, 2), (4, 3), (4, 4)
    )
}

/// [`project`] through the run-time shape (tests: every compiled shape
/// equals it bit for bit).
#[cfg(test)]
pub(super) fn project_any<R: ProjectionReal, X: Positions<R> + ?Sized>(
    c: &Colour<'_, R>,
    x: &mut X,
    lambda: &mut [R],
    scratch: &mut ProjectionScratch<R>,
) -> Result<(), usize> {
    project_blocks(Any(c.kind.arity, c.dim), c, x, lambda, scratch)
}

/// [`project`] for elements of shape `shape`, block by block.
fn project_blocks<S: Shape, R: ProjectionReal, X: Positions<R> + ?Sized>(
    shape: S,
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
        if let Some(e) = project_block(shape, c, start..start + len, x, lambda, scratch) {
            failed = failed.or(Some(e));
        }
        start += len;
    }
    failed.map_or(Ok(()), Err)
}

/// What an element does this iteration.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Case {
    /// Updates λ and its dynamic members.
    Move,
    /// No response (∇C zero or undefined).
    Skip,
    /// A non-finite value or Δλ: a typed step error.
    Fail,
}

/// Elements of at most this many coordinates keep their column map in
/// local arrays (where the compiler sees that the updates cannot change it).
const SMALL: usize = 16;

/// `column(k)` for k < n: in `small` when n ≤ [`SMALL`], else in `large`.
#[inline(always)]
fn column_map<'a>(
    n: usize,
    column: impl Fn(usize) -> usize,
    small: &'a mut [usize; SMALL],
    large: &'a mut Vec<usize>,
) -> &'a [usize] {
    if n <= SMALL {
        for (k, c) in small[..n].iter_mut().enumerate() {
            *c = column(k);
        }
        &small[..n]
    } else {
        large.clear();
        large.extend((0..n).map(column));
        large
    }
}

/// Gathers the coordinates of the elements `members` (arity per lane, at
/// most [`BLOCK`] lanes), element by element: coordinate k of a lane's
/// element goes to `store(k, lane, value)`; `member(j, lane, particle)`
/// sees each member.
#[inline(always)]
fn gather<S: Shape, R: Copy, X: Positions<R> + ?Sized>(
    shape: S,
    members: &[u32],
    x: &X,
    mut store: impl FnMut(usize, usize, R),
    mut member: impl FnMut(usize, usize, usize),
) {
    let (arity, dim) = (shape.arity(), shape.dim());
    for (lane, element) in members.chunks_exact(arity).take(BLOCK).enumerate() {
        let lane = lane % BLOCK;
        for (j, &i) in element.iter().enumerate() {
            let i = i as usize;
            member(j, lane, i);
            for (a, &v) in x.values(i * dim..i * dim + dim).iter().enumerate() {
                store(j * dim + a, lane, v);
            }
        }
    }
}

/// [`gather`] into the tape's input columns (`input[k]`: the column of
/// coordinate k); when the tape's first columns are its coordinates in
/// order (k → k, as the compiler numbers them), stored without the map.
#[inline(always)]
fn gather_columns<S: Shape, R: Copy, X: Positions<R> + ?Sized>(
    shape: S,
    members: &[u32],
    x: &X,
    input: &[usize],
    columns: &mut [Column<R>],
    member: impl FnMut(usize, usize, usize),
) {
    let n = shape.arity() * shape.dim();
    if input.iter().enumerate().all(|(k, &c)| c == k) {
        let columns = &mut columns[..n];
        gather(shape, members, x, |k, lane, v| columns[k][lane] = v, member);
    } else {
        let store = |k: usize, lane: usize, v| columns[input[k]][lane] = v;
        gather(shape, members, x, store, member);
    }
}

/// wsum = Σ_j [w_j ≠ 0] w_j Σ_a g_ja² (from 0, j then a ascending) and
/// each w_j g_ja into `wg`, every lane of the block (`gradient[k]`: the
/// column of ∂C/∂coordinate k): [`weights_by_lane`] when the element has
/// at most [`SMALL`] coordinates, else [`weights_by_member`] — the same
/// operations either way.
#[inline(always)]
fn weights<S: Shape, R: ProjectionReal>(shape: S, sums: Weights<'_, R>) {
    if shape.arity() * shape.dim() <= SMALL {
        weights_by_lane(shape, sums);
    } else {
        weights_by_member(shape, sums);
    }
}

/// What [`weights`] reads (the block's columns, the column of each
/// ∂C/∂coordinate, each member's inverse masses) and writes (w g per
/// coordinate, wsum).
struct Weights<'a, R> {
    columns: &'a [Column<R>],
    gradient: &'a [usize],
    weight: &'a [Column<R>],
    wg: &'a mut [Column<R>],
    wsum: &'a mut Column<R>,
}

/// [`weights`] lane by lane, each lane's sums in registers (the ∂C
/// columns looked up once; at most [`SMALL`] coordinates).
#[inline(always)]
fn weights_by_lane<S: Shape, R: ProjectionReal>(shape: S, sums: Weights<'_, R>) {
    let (dim, zero, wg) = (shape.dim(), R::constant(0.0), sums.wg);
    let mut g = [&sums.columns[0]; SMALL];
    for (g, &k) in g.iter_mut().zip(sums.gradient) {
        *g = &sums.columns[k];
    }
    for lane in 0..BLOCK {
        let mut sum = zero;
        for (j, w) in sums.weight.iter().enumerate() {
            let (w, mut g2) = (w[lane], zero);
            for a in 0..dim {
                let g = g[j * dim + a][lane];
                g2 += g * g;
                wg[j * dim + a][lane] = w * g;
            }
            let with = sum + w * g2;
            sum = if w == zero { sum } else { with };
        }
        sums.wsum[lane] = sum;
    }
}

/// [`weights`] member by member, one axis over every lane at a time.
#[inline(always)]
fn weights_by_member<S: Shape, R: ProjectionReal>(shape: S, sums: Weights<'_, R>) {
    let (dim, zero, wsum) = (shape.dim(), R::constant(0.0), sums.wsum);
    wsum.fill(zero);
    for (j, w) in sums.weight.iter().enumerate() {
        let mut g2 = [zero; BLOCK];
        for (a, wg) in sums.wg[j * dim..][..dim].iter_mut().enumerate() {
            let g = &sums.columns[sums.gradient[j * dim + a]];
            for lane in 0..BLOCK {
                g2[lane] += g[lane] * g[lane];
                wg[lane] = w[lane] * g[lane];
            }
        }
        for lane in 0..BLOCK {
            let with = wsum[lane] + w[lane] * g2[lane];
            wsum[lane] = if w[lane] == zero { wsum[lane] } else { with };
        }
    }
}

/// (wsum, w g) of [`weights_by_lane`] and of [`weights_by_member`] on the
/// same block (tests: they agree bit for bit); at most [`SMALL`]
/// coordinates.
#[cfg(test)]
pub(super) fn weights_both<R: ProjectionReal>(
    (arity, dim): (usize, usize),
    columns: &[Column<R>],
    gradient: &[usize],
    weight: &[Column<R>],
) -> [(Column<R>, Vec<Column<R>>); 2] {
    assert!(arity * dim <= SMALL);
    let zero = R::constant(0.0);
    let mut out = [(); 2].map(|_| ([zero; BLOCK], vec![[zero; BLOCK]; arity * dim]));
    let [(sum, wg), (sum_m, wg_m)] = &mut out;
    let sums = |wg, wsum| Weights {
        columns,
        gradient,
        weight,
        wg,
        wsum,
    };
    weights_by_lane(Any(arity, dim), sums(wg, sum));
    weights_by_member(Any(arity, dim), sums(wg_m, sum_m));
    out
}

/// One block (≤ [`BLOCK`] slots) of [`project`]; the first failing slot.
#[multiversion(targets("x86_64+avx"))]
fn project_block<S: Shape, R: ProjectionReal, X: Positions<R> + ?Sized>(
    shape: S,
    c: &Colour<'_, R>,
    slots: Range<usize>,
    x: &mut X,
    lambda: &mut [R],
    s: &mut ProjectionScratch<R>,
) -> Option<usize> {
    let (arity, dim) = (shape.arity(), shape.dim());
    let (kind, tape) = (c.kind, &c.kind.gradient);
    let zero = R::constant(0.0);
    // The column of each coordinate input (the spare column after the
    // tape's when the tape does not read it) and of each ∂C/∂input.
    let (n, spare) = (arity * dim, tape.ops.len());
    let mut small = [[0; SMALL]; 2];
    let [small_input, small_gradient] = &mut small;
    let [large_input, large_gradient] = &mut s.map;
    let input = |k: usize| kind.gradient_inputs[k].unwrap_or(spare);
    let input = column_map(n, input, small_input, large_input);
    let gradient = column_map(n, |k| tape.gradient[k], small_gradient, large_gradient);
    s.offset.resize(arity, [0; BLOCK]);
    s.weight.resize(arity, [zero; BLOCK]);
    s.step.resize(n, [zero; BLOCK]);
    let (offset, weight) = (&mut s.offset[..arity], &mut s.weight[..arity]);
    s.block.fit_with_spare(tape, 1);
    // Gather: each member's particle offset and inverse mass, the
    // coordinates into the tape's input columns, then the per-element
    // constants (tape inputs arity·N …).
    let columns = s.block.columns_mut();
    let members = &c.elements[slots.start * arity..slots.end * arity];
    gather_columns(shape, members, x, input, columns, |j, lane, i| {
        offset[j][lane] = i * dim;
        weight[j][lane] = c.inverse_mass[i];
    });
    let m = kind.element_constants;
    for q in 0..m {
        if let Some(slot) = kind.gradient_inputs[n + q] {
            for (lane, e) in slots.clone().enumerate() {
                columns[slot][lane] = c.constants[e * m + q];
            }
        }
    }
    tape.eval_block(&mut s.block, |_, _| {});
    let columns = s.block.columns();
    // wsum = Σ_j [w_j ≠ 0] w_j Σ_a g_ja², and each w_j g_ja of the update
    // (`wg`, the same product it multiplies by Δλ), every lane at once.
    let (mut wsum, wg) = ([zero; BLOCK], &mut s.step[..n]);
    let sums = Weights {
        columns,
        gradient,
        weight,
        wg,
        wsum: &mut wsum,
    };
    weights(shape, sums);
    // Δλ before the clamp and each lane's case, every lane at once: the
    // value non-finite, or Δλ non-finite where wsum is finite and not 0 →
    // the element fails; wsum non-finite or 0 → no response.
    let value = &columns[tape.value];
    let (mut raw, mut case) = ([zero; BLOCK], [Case::Move; BLOCK]);
    let lanes = raw
        .iter_mut()
        .zip(&wsum)
        .zip(value)
        .zip(&c.rest[slots.clone()]);
    for ((((raw, &wsum), &value), &rest), &l) in lanes.zip(lambda.iter()) {
        *raw = (-(value - rest) - c.alpha_tilde * l) / (wsum + c.alpha_tilde);
    }
    let lanes = case.iter_mut().zip(&wsum).zip(value).zip(&raw);
    for (((case, &wsum), &value), &raw) in lanes {
        let responds = wsum.finite() && wsum != zero;
        *case = match (value.finite(), responds, raw.finite()) {
            (false, _, _) | (true, true, false) => Case::Fail,
            (true, false, _) => Case::Skip,
            (true, true, true) => Case::Move,
        };
    }
    // Element by element, in slot order: failures, the clamp, λ and the
    // update x_ja += (w_j g_ja) Δλ of the dynamic members, member j then
    // axis a.
    let relation = kind.relation;
    let mut failed = None;
    for (lane, e) in slots.enumerate().take(BLOCK) {
        let lane = lane % BLOCK;
        match case[lane] {
            Case::Move => {}
            Case::Skip => continue,
            Case::Fail => {
                failed = failed.or(Some(e));
                continue;
            }
        }
        let l = lambda[lane];
        let t = l + raw[lane];
        let (next, step) = match relation {
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
        for (j, (w, k)) in weight.iter().zip(offset.iter()).enumerate() {
            let (w, k) = (w[lane], k[lane]);
            if w != zero {
                let wg = &wg[j * dim..][..dim];
                for (v, wg) in x.values_mut(k..k + dim).iter_mut().zip(wg) {
                    *v += wg[lane] * step;
                }
            }
        }
    }
    failed
}

/// C of slots `slots` of a family of kind `kind` (`elements`: `arity`
/// particle indices per slot) at `x` (flat, `dim` per particle), in
/// precision `R`: the value tape over blocks of [`BLOCK`] slots (gathered
/// as the projection gathers), each value handed to `each(slot, C)` in
/// slot order. Bit for bit [`ExpressionKind::value_at`] per slot.
pub fn values<R: Real>(
    kind: &ExpressionKind,
    dim: usize,
    elements: &[u32],
    slots: Range<usize>,
    x: &[R],
    block: &mut Block<R>,
    each: impl FnMut(usize, R),
) {
    shapes!(
        (kind.arity, dim),
        values_of(kind, elements, slots, x, block, each);
        (1, 1), (1, 2), (1, 3), (1, 4), (2, 1), (2, 2), (2, 3), (2, 4),
        (3, 1), (3, 2), (3, 3), (3, 4), (4, 1), (4, 2), (4, 3), (4, 4)
    )
}

/// [`values`] for elements of shape `shape`.
fn values_of<S: Shape, R: Real>(
    shape: S,
    kind: &ExpressionKind,
    elements: &[u32],
    slots: Range<usize>,
    x: &[R],
    block: &mut Block<R>,
    mut each: impl FnMut(usize, R),
) {
    let (arity, tape) = (shape.arity(), &kind.value);
    let (n, m, spare) = (arity * shape.dim(), kind.element_constants, tape.ops.len());
    let (mut small, mut large) = ([0; SMALL], Vec::new());
    let input = column_map(
        n,
        |k| kind.value_inputs[k].unwrap_or(spare),
        &mut small,
        &mut large,
    );
    let mut start = slots.start;
    while start < slots.end {
        let block_slots = start..BLOCK.min(slots.end - start) + start;
        block.fit_with_spare(tape, 1);
        let columns = block.columns_mut();
        let members = &elements[start * arity..block_slots.end * arity];
        gather_columns(shape, members, x, input, columns, |_, _, _| {});
        for q in 0..m {
            if let Some(slot) = kind.value_inputs[n + q] {
                for (lane, e) in block_slots.clone().enumerate() {
                    columns[slot][lane] = R::constant(kind.constants[e * m + q]);
                }
            }
        }
        tape.eval_block(block, |_, _| {});
        let value = block.column(tape.value);
        for (lane, e) in block_slots.clone().enumerate() {
            each(e, value[lane]);
        }
        start = block_slots.end;
    }
}
