//! Block evaluation of a [`Tape`]: the column evaluator ([`super::Columns`])
//! over a fixed [`BLOCK`] of lanes, for the projection's inner loop. Each op
//! runs over one block at a time (dispatch paid once per op and block); a
//! column is a `[R; BLOCK]`, so the loops have a constant trip count (no
//! bounds checks, vectorised), and ops × `BLOCK` reals stay in the first
//! level cache while the caller gathers the inputs before and reads the
//! outputs after.
//!
//! ```text
//! block b = lanes b·BLOCK … b·BLOCK + BLOCK − 1
//! Input j:  filled by the caller (coordinate j of each lane's element)
//! every other op: as Tape::eval, lane by lane, the same IEEE operation
//! ```
//! Every lane runs the same operations in the same order as
//! [`Tape::eval`], so the results are bit for bit those of the column
//! evaluator (lanes past the caller's count hold stale values; they are
//! computed and never read).

use super::eval::{Real, apply};
use super::graph::{Op, Slot};
use super::tape::Tape;
use multiversion::multiversion;

/// Lanes of one block: a 30-op tape's columns take 15 KiB in f64.
pub const BLOCK: usize = 64;

/// One column of a block.
pub type Column<R> = [R; BLOCK];

/// The columns of one block (scratch reused across blocks and calls: after
/// the first call of a tape, a call allocates nothing).
#[derive(Debug, Clone, Default)]
pub struct Block<R> {
    data: Vec<Column<R>>,
}

impl<R: Real> Block<R> {
    /// Empty scratch.
    pub fn new() -> Self {
        Block { data: Vec::new() }
    }

    /// Slot `slot` in every lane of the block.
    pub fn column(&self, slot: Slot) -> &Column<R> {
        &self.data[slot]
    }

    /// Sizes the block for `tape` (at least one column per op; values
    /// kept), so that a caller can fill the input columns with
    /// [`Block::column_mut`].
    pub fn fit(&mut self, tape: &Tape) {
        self.fit_with_spare(tape, 0);
    }

    /// [`Block::fit`] with `spare` more columns after the tape's (slots
    /// `tape.ops.len()` …): scratch no op reads, kept by
    /// [`Tape::eval_block`].
    pub fn fit_with_spare(&mut self, tape: &Tape, spare: usize) {
        let columns = tape.ops.len() + spare;
        if self.data.len() < columns {
            self.data.resize(columns, [R::default(); BLOCK]);
        }
    }

    /// Slot `slot` to write (after [`Block::fit`]).
    pub fn column_mut(&mut self, slot: Slot) -> &mut Column<R> {
        &mut self.data[slot]
    }

    /// Every column, indexed by slot (after [`Block::fit`]).
    pub fn columns(&self) -> &[Column<R>] {
        &self.data
    }

    /// Every column, to write (after [`Block::fit`]).
    pub fn columns_mut(&mut self) -> &mut [Column<R>] {
        &mut self.data
    }
}

impl Tape {
    /// The slot of `Op::Input(j)` for every input j (`None`: the tape does
    /// not read it).
    pub fn input_slots(&self) -> Vec<Option<Slot>> {
        let mut slots = vec![None; self.inputs + self.constants];
        for (slot, op) in self.ops.iter().enumerate() {
            if let Op::Input(j) = *op {
                slots[j] = Some(slot);
            }
        }
        slots
    }
}

impl Tape {
    /// Evaluates every slot in precision `R` over one block (with AVX where
    /// the CPU has it: the same IEEE operations, four lanes per
    /// instruction); `input(j, column)` fills coordinate j of each lane's
    /// element (a caller that filled the input columns already,
    /// [`Block::column_mut`], passes a closure that does nothing). Read the
    /// outputs with [`Block::column`].
    pub fn eval_block<R: Real>(
        &self,
        block: &mut Block<R>,
        input: impl FnMut(usize, &mut Column<R>),
    ) {
        block.fit(self);
        run(&self.ops, &mut block.data, input);
    }
}

/// The ops over one block (`data`: a column per op, sized).
#[multiversion(targets("x86_64+avx"))]
fn run<R: Real, F: FnMut(usize, &mut Column<R>)>(ops: &[Op], data: &mut [Column<R>], mut input: F) {
    for (i, op) in ops.iter().enumerate() {
        let (done, rest) = data.split_at_mut(i);
        let col = |s: Slot| &done[s][..];
        apply(*op, &mut rest[0][..], col, |j, out| {
            input(j, out.try_into().expect("a block column"))
        });
    }
}
