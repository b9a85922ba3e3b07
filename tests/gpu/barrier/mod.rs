//! Barrier kernels on the GPU against the f64 golden path: the f64 `ln`
//! helper against libm, per-particle barrier energy / gradient / Hessian
//! block / smallest distance, and filter fractions, in f32 and f64, with
//! derived per-particle bounds printed as
//! `BOUND | name | measured | bound | rationale`. In f32 on lavapipe
//! (`common::exact::f32_identical`) every particle's evaluation and filter
//! fraction is also asserted bit-identical to the f32 reference
//! (`hyperpbd_cpu::f32_reference::barrier`), under the f32 floor too.
//!
//! ```text
//! δd  = K·ε·S       distance error of the kernel: S = |x|∞ + max |obstacle coordinate| + r,
//!                   K = 16 (DIM + 4) covers the dot products, the Gram solve of a
//!                   well-shaped simplex (condition ≤ ~10) and the upload rounding
//! per obstacle with CPU distance d, direction n, |x − q| = ρ:
//!   Δb   ≤ max± |b(d ± δd) − b(d)|   + 16ε|b|   + κ e² λ
//!   Δg_a ≤ max± |b'(d ± δd) − b'(d)| + 16ε|b'| + 2κ|e| λ + |b'| δn
//!   ΔH   ≤ max± |b''(d ± δd) − b''(d)| + 16ε|b''| + 2κ λ + 2|b''| δn
//!   δn = 8ε (plane) or 2 δd / ρ (simplex);  λ = ln error (2^-21 in f32, 0 in f64:
//!   the arithmetic ln is within 16ε relative, inside the 16ε terms)
//! summed over obstacles. Samples closer than 4 δd to an obstacle are the
//! f32 floor: the kernel cannot resolve d there, they are counted and not
//! compared (in f64 there are none). The f32 filter fraction is certified
//! in exact arithmetic only where d0 > η δd / (1 − η) = 9 δd: the test checks
//! that every f32 fraction keeps d > 0 along the whole cut step in f64 for
//! samples above that floor.
//! ```

use crate::common;

mod kernels;
mod whole_steps;

use common::Lcg;
use common::bound::print_bound;
use common::gpu::adapter_or_skip;
use hyperpbd::barrier::{
    BarrierLaw, BarrierObstacles, FILTER_SAFETY, ParticleBarrier, evaluate_particle_barrier,
    filter_fraction,
};
use hyperpbd::gpu::Precision;
use hyperpbd::gpu::barrier::BarrierKernels;
use hyperpbd::{Obstacle, Scene};

const PRECISIONS: [Precision; 2] = [Precision::F32, Precision::F64];
const COUNTS: [usize; 5] = [0, 1, 63, 65, 200];
