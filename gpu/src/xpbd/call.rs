//! One kernel call of a step as the device reads it: the `Call` block of
//! `shaders/step.wgsl`, its op codes and flags, and which particle records
//! each per-particle call reads and writes.
//!
//! ```text
//! Call   op count first family elem_base slot_base arity call      (u32)
//!        flags kind slot_map chunk io carried factors absent       (u32)
//!        alpha_tilde h friction factor                             (real)
//!        normal[4·VEC] gravity[4·VEC]     (real; lanes ≥ DIM zero)
//! ```
//! The vectors are padded to whole vec4 words (VEC = ⌊DIM/4⌋ + 1, as the
//! particle records) so the block is valid in a uniform buffer too: the
//! same bytes are the storage array `calls` and the copies in each
//! dispatch's uniform block ([`dispatch_block`]).

use hyperpbd_core::Kernel;

use crate::Precision;
use crate::kernel_set::BlockWriter;

/// Per-particle calls in one `particles` dispatch at most (OP0..OP7 of
/// step.wgsl).
pub(crate) const SEGMENT: usize = 8;

pub(crate) use crate::codes::{
    FLAG_FIRST, FLAG_FORCE, FLAG_GRAVITY, FLAG_MATERIAL, FLAG_MESH, FLAG_MOVING, FLAG_NEO_HOOKEAN,
    FLAG_ORIENTATION, FLAG_PRIMAL, FLAG_RATIO, FLAG_ROTATES, FLAG_TETHER, FLAG_UNIT_SCALE,
    FLAG_UNREAD, IO_LOAD_P, IO_LOAD_V, IO_LOAD_X, IO_STORE_P, IO_STORE_V, IO_STORE_X, OP_DAMPING,
    OP_FRICTION, OP_GUARD_MEASURE, OP_GUARD_SPEED, OP_HOST, OP_MOTION, OP_NONE, OP_PREDICT,
    OP_PROJECT_CONTACT, OP_PROJECT_DISTANCE, OP_PROJECT_EXPRESSION, OP_PROJECT_MATERIAL,
    OP_PROJECT_ORIENTED, OP_PROJECT_SIMPLEX, OP_RESIDUAL, OP_VELOCITY,
};

/// One kernel call, before encoding.
#[derive(Debug, Clone, Default)]
pub(crate) struct Call {
    pub op: u32,
    pub count: u32,
    pub first: u32,
    pub family: u32,
    pub elem_base: u32,
    pub slot_base: u32,
    pub arity: u32,
    /// Index of the plan's kernel call within the step (error reports).
    pub call: u32,
    pub flags: u32,
    pub kind: u32,
    pub slot_map: u32,
    pub chunk: u32,
    /// Primal-residual projection: offset of the family's element
    /// displacements in `carried` (primal.wgsl).
    pub carried: u32,
    /// Primal-residual material projection: offset of the family's
    /// Newton factors in `carried` (primal_material.wgsl).
    pub factors: u32,
    /// In a batch: this world's own plan has no such call (a friction or
    /// damping response the union of the worlds' stages added,
    /// gpu/src/batch/union.rs); the world skips it. Per world, so not part of
    /// [`Call::same_shape`].
    pub absent: bool,
    pub alpha_tilde: f64,
    pub h: f64,
    pub friction: f64,
    pub factor: f64,
    pub normal: Vec<f64>,
    pub gravity: Vec<f64>,
    /// The plan kernel this call runs (`None` for residual calls).
    pub kernel: Option<Kernel>,
}

impl Call {
    /// True for calls that touch one particle's records only (run per
    /// particle by `particles`) and fuse with their neighbours. A mesh
    /// contact or friction call (FLAG_MESH) runs per particle in a
    /// `particles` dispatch of its own: lavapipe compiles its hierarchy
    /// walk into every pipeline that holds it (about 2 s each), so it is
    /// kept to the three pipelines of its (op, flags).
    pub fn fusable(&self) -> bool {
        self.flags & FLAG_MESH == 0
            && matches!(
                self.op,
                OP_PREDICT
                    | OP_PROJECT_CONTACT
                    | OP_VELOCITY
                    | OP_FRICTION
                    | OP_DAMPING
                    | OP_MOTION
            )
    }

    /// Whether `other` runs the same kernel on the same elements with the
    /// same flags, its reals and `absent` aside (the calls of two worlds
    /// of a batch).
    pub fn same_shape(&self, other: &Call) -> bool {
        let words = |c: &Call| {
            [
                c.op,
                c.count,
                c.first,
                c.family,
                c.elem_base,
                c.slot_base,
                c.arity,
                c.call,
                c.flags,
                c.kind,
                c.slot_map,
                c.chunk,
                c.carried,
                c.factors,
            ]
        };
        words(self) == words(other)
            && self.kernel == other.kernel
            && self.h.to_bits() == other.h.to_bits()
    }

    /// The encoded block (`Call` of step.wgsl).
    pub fn encode(&self, dim: usize, precision: Precision) -> Vec<u8> {
        let vector = |v: &[f64]| {
            let mut out = v.to_vec();
            out.resize(4 * crate::layout::record_words(dim), 0.0);
            out
        };
        BlockWriter::new(precision)
            .words(&[
                self.op,
                self.count,
                self.first,
                self.family,
                self.elem_base,
                self.slot_base,
                self.arity,
                self.call,
                self.flags,
                self.kind,
                self.slot_map,
                self.chunk,
                records_io(std::slice::from_ref(self)),
                self.carried,
                self.factors,
                u32::from(self.absent),
            ])
            .reals(&[self.alpha_tilde, self.h, self.friction, self.factor])
            .reals(&vector(&self.normal))
            .reals(&vector(&self.gravity))
            .finish()
    }
}

/// The uniform `Dispatch` block of step.wgsl: the range
/// `[first_call, end_call)`, `count`, then copies of `calls` (at most
/// SEGMENT, the ones the dispatch's runner reads from its block), zeros up
/// to SEGMENT calls. The calls start at the call block's alignment (one
/// vec4 of reals).
pub(crate) fn dispatch_block(
    header: [u32; 4],
    calls: &[Call],
    dim: usize,
    precision: Precision,
) -> Vec<u8> {
    let call_size = Call::default().encode(dim, precision).len();
    let start = 4 * crate::params::real_size(precision);
    let mut out = BlockWriter::new(precision).words(&header).finish();
    out.resize(start, 0);
    for call in calls.iter().take(SEGMENT) {
        out.extend(call.encode(dim, precision));
    }
    out.resize(start + SEGMENT * call_size, 0);
    out
}

/// (read, written) records of a per-particle call, as IO_LOAD_* bits.
fn access(call: &Call) -> (u32, u32) {
    let (x, v, p) = (IO_LOAD_X, IO_LOAD_V, IO_LOAD_P);
    match call.op {
        // A turning plane's friction reads its carry at p (motion.wgsl).
        OP_FRICTION if call.flags & FLAG_ROTATES != 0 => (x | v | p, v),
        OP_PREDICT => (x | v, x | v | p),
        OP_PROJECT_CONTACT => (x | p, x),
        OP_VELOCITY => (x | p, v),
        OP_FRICTION | OP_DAMPING => (x | v, v),
        // Pins are fixed: the op stores their records itself (motion.wgsl).
        OP_MOTION => (x | v, 0),
        // Not per-particle: no records of their own.
        OP_PROJECT_DISTANCE
        | OP_PROJECT_SIMPLEX
        | OP_PROJECT_ORIENTED
        | OP_PROJECT_MATERIAL
        | OP_PROJECT_EXPRESSION
        | OP_RESIDUAL
        | OP_GUARD_MEASURE
        | OP_GUARD_SPEED
        | OP_HOST
        | OP_NONE => (0, 0),
        unknown => unreachable!("op {unknown} is not in codes::OPS"),
    }
}

/// The records per-particle `calls` (run in order on each particle) must
/// load — those some call reads before an earlier one wrote them, and x
/// whenever x or v is stored (the inverse mass in x decides) — and store.
pub(crate) fn records_io(calls: &[Call]) -> u32 {
    let (mut written, mut io) = (0, 0);
    for call in calls {
        let (reads, writes) = access(call);
        io |= reads & !written;
        written |= writes;
    }
    for (load, store) in [
        (IO_LOAD_X, IO_STORE_X),
        (IO_LOAD_V, IO_STORE_V),
        (IO_LOAD_P, IO_STORE_P),
    ] {
        if written & load != 0 {
            io |= store;
        }
    }
    if io & (IO_STORE_X | IO_STORE_V) != 0 {
        io |= IO_LOAD_X;
    }
    io
}

#[cfg(test)]
mod tests {
    use super::*;

    fn op(op: u32) -> Call {
        Call {
            op,
            ..Call::default()
        }
    }

    #[test]
    fn a_fused_substep_end_loads_x_and_p_only() {
        // contact, velocity, friction, damping, then the next predict.
        let segment = [
            op(OP_PROJECT_CONTACT),
            op(OP_VELOCITY),
            op(OP_FRICTION),
            op(OP_DAMPING),
            op(OP_PREDICT),
        ];
        let io = records_io(&segment);
        assert_eq!(
            io,
            IO_LOAD_X | IO_LOAD_P | IO_STORE_X | IO_STORE_V | IO_STORE_P
        );
        assert_eq!(
            records_io(&[op(OP_PREDICT)]),
            IO_LOAD_X | IO_LOAD_V | IO_STORE_X | IO_STORE_V | IO_STORE_P
        );
        assert_eq!(
            records_io(&[op(OP_DAMPING)]),
            IO_LOAD_X | IO_LOAD_V | IO_STORE_V
        );
    }
}
