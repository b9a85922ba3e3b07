//! hyperpbd-verify: the error models and comparers that judge a run
//! against the CPU golden path. `hyperpbd compare` and the tests use them;
//! a library user does not need them (the facade `hyperpbd` does not
//! re-export them).
//!
//! ```text
//! compare           DivergenceModel, Frame, Divergence; ErrorModel (accumulated)
//! compare_frame     FrameErrorModel: XPBD, one frame's rounding count
//! compare_material  material families' rounding and conditioning
//! compare_barrier   BarrierErrorModel: incremental potential, residual-driven
//! compare_coupled   coupled implicit step in f32: ∇F in f64, per-particle modulus
//! ```
//!
//! Crates stay one-way: core ← cpu ← verify (verify never reaches back
//! into the facade or the CLI).

pub mod compare;
pub mod compare_barrier;
pub mod compare_coupled;
pub mod compare_frame;
pub mod compare_material;
