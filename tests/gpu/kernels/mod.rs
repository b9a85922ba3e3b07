//! Every kernel alone, CPU golden path vs GPU, f32 and f64.
//!
//! Each kernel is run on the same input on both backends and the states are
//! compared right after it. Inputs are made identical before every kernel
//! by copying the GPU state into the CPU backend (`write_state`); in f32 the
//! GPU state is f32-representable, so both then hold exactly the same
//! numbers. The substep start `p` is set by `Predict` from that identical
//! state; only the multipliers λ (written by `Project`, read by `Friction`)
//! cannot be copied and carry the previous kernel's rounding.
//!
//! ```text
//! per case, per (family, color):  sync → Predict → cmp → sync → Project(f, c) → cmp
//!                                 → sync → Velocity → cmp → sync → Friction(g) → cmp
//!                                 → sync → Damping → cmp
//! ```
//!
//! # Bounds: ε × magnitude × roundings of that one kernel
//!
//! The GPU evaluates the CPU's expressions in the same order; with equal
//! inputs the only differences are the roundings of the GPU precision
//! (f32: ε = 2⁻²³; parameters h, g, w, f, rest, n, μ are also rounded to f32
//! once, each counted as a rounding). A rounding perturbs a value by at most
//! ε × its magnitude, and every magnitude in a kernel's chain is bounded by
//! the scales below, so a kernel's error is at most ε × scale × r, with r the
//! roundings on the longest chain to one output coordinate (counted from the
//! WGSL; N = dimension):
//!
//! ```text
//! X  largest |coordinate| before/after     V  largest |velocity| before/after
//! A  largest |s g| + |w f|                  κ  conditioning of a measure element
//!
//! Predict        x: ε·8·(X + h(V + hA))     v: ε·8·(V + hA)
//!                (4 parameter roundings h, s·g, w, f; 2 mul, 2 add)
//! Project        x: ε·X·(2 + 2κ·r)          v: 0 (not touched: bit-identical)
//!                coordinate differences ≤ 2X; the final add x += Δ rounds at X
//!                r = 2N + 13 distance       (diff, N squares + sum, sqrt, rest,
//!                                            C, Δλ (3), 1/len, n, w n Δλ, add)
//!                r = 4N + 15 contact        (n·x, rest, C, Δλ, clamp (2),
//!                                            correction, static friction:
//!                                            x − p, n·Δx, tangent, |t|, x −= t)
//!                r = 4N + 8k + 20 measure   (edges, Gram/edge matrix, k×k
//!                                            elimination and adjugate, scale,
//!                                            gradient, Σ w|∇C|², C, Δλ, update)
//!                κ = 1 for distance and contact; for a simplex the Hadamard
//!                ratio Π|e_j| / |det E| (oriented) or Π|e_j|² / det(EᵀE)
//!                (squared measure): the error of an elimination determinant
//!                is relative to Π|e_j|, not to the determinant.
//! Velocity       x: 0                       v: ε·3·V   (x − p, h, division)
//! Friction       x: 0                       v: ε·(5N + 14)·V + μ·B_λ / h
//!                B_λ = the position bound of this substep's Project of the
//!                family (the error of w λ, the normal correction); 0 if the
//!                family was not projected (λ = 0 on both).
//! Damping        x: 0                       v: ε·2·V   (factor, multiply)
//! ```
//!
//! f64 (ε = 2⁻⁵²): the same expressions in the same order, every operation
//! correctly rounded on both sides (lavapipe compiles f64 add, mul, div and
//! sqrt to the x86 instructions the CPU uses), so on lavapipe every kernel
//! is asserted bit-identical (`common::exact`: bound 0, printed `exact`).
//! On other adapters the one licensed difference is contraction: Vulkan
//! lets a driver fuse a·b + c into an FMA unless the SPIR-V says
//! NoContraction, and naga does not say it. A fused pair skips one
//! rounding, so there the f64 bound is a few (R64 = 4) ulps of the same
//! scales, through the same κ and λ propagation as above (ε·X·(2 + 2κ·4)
//! for Project, ε·4·V + μ·B_λ/h for Friction, ε·4·scale for the others) —
//! and velocities of Project, x of Velocity/Friction/Damping stay exactly
//! equal.
//!
//! f32 on lavapipe: every kernel is also run on the f32 reference
//! (`hyperpbd_cpu::f32_reference`, the WGSL's f32 operations on the CPU)
//! from the same synced input, λ carried as on the device, and asserted
//! bit-identical to the GPU; those rows print `exact`, the bounds above as
//! `… model` rows beside them (asserted as before).
//!
//! Decisions (`λ > 0`, static friction `|Δt| ≤ μ w λ`, `len > 0`) are
//! discontinuous; the cases are built so that no element sits within
//! rounding of one: penetrations ≥ 1 mm or clearances ≥ 1 cm; sliding
//! contacts move 8.3 mm tangentially per substep against a static bound
//! ≤ 3.1 mm, sticking ones ≤ 0.07 mm against ≥ 0.6 mm.

use crate::common;

mod accepted_calls;
mod bounds;
mod cases;
mod kernel_by_kernel;
mod pair;

use common::Lcg;

use common::exact::{bits, f32_identical, f64_identical};
use common::gpu::adapter_or_skip;
use hyperpbd::{
    Backend, ConstraintFamily, ConstraintKind, CpuBackend, F32Reference, FamilyKind, Kernel,
    Particle, Plan, Scene, SceneBuilder, State,
};
use hyperpbd_gpu::{GpuBackend, Precision};
use hyperpbd_verify::compare::{coordinate_scale, max_abs_diff};

/// Roundings allowed for f64 on a chain the driver may contract.
const R64: f64 = 4.0;

fn eps(precision: Precision) -> f64 {
    precision.epsilon()
}

fn max_abs(values: &[f64]) -> f64 {
    values.iter().fold(0.0, |m, x| m.max(x.abs()))
}

fn build(b: SceneBuilder) -> Scene {
    b.build().expect("test scene is valid")
}
