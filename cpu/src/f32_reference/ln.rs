//! The f32 natural logarithm of `shaders/ln_f32.wgsl`, from arithmetic
//! only, so the Neo-Hookean law's ln J is the GPU's bits. Its one
//! definition (math, constants, tests) is core's
//! [`hyperpbd_core::material::ln_f32`], shared with the expression
//! compiler's f32 evaluator.

pub use hyperpbd_core::material::ln_f32 as ln;
