//! The natural logarithm from arithmetic, sqrt-free, exactly as
//! `shaders/ln_f64.wgsl` computes it, so the Neo-Hookean law gives the same
//! bits on the CPU and in an f64 WGSL kernel (the GPU's built-in f64 log is
//! wrong on lavapipe; see DESIGN.md). Within a few ulp of `libm::log`
//! (tests/materials/law.rs measures it).
//!
//! ```text
//! x = m · 2^e,  m ∈ (√½, √2]      (unique: m ∈ [1, 2) from frexp, halved if m > √2)
//! ln x = e ln2 + 2 atanh(s),  s = (m − 1)/(m + 1),  |s| ≤ 0.1716
//! 2 atanh(s) = 2 s Σ_{k=0}^{12} s^{2k}/(2k + 1)      (Horner from 1/25 down to 1)
//! ln x = e·LN2_HI + (e·LN2_LO + 2·s·poly)           (fdlibm split of ln 2)
//! ```
//! The WGSL finds e from an f32 log2 estimate and corrects m into the
//! same interval, so both sides reach the same (m, e) and then run the same
//! operations in the same order. Defined for finite x > 0; other inputs
//! give NaN (x ≤ 0, NaN) or +∞ (x = +∞), which the laws never pass.

// The f64 values of the shader's literals 6.93147180369123816490e-01 and
// 1.90821492927058770002e-10.
const LN2_HI: f64 = 0.693_147_180_369_123_8;
const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;

/// 1/(2k + 1) for k = 12 … 0: the Horner coefficients of 2 atanh(s)/(2s)
/// in s², highest first. `shaders/ln_f64.wgsl`'s polynomial is written
/// from this table when a module is composed (`gpu/src/shader.rs`).
pub const ATANH_SERIES: [f64; 13] = [
    1.0 / 25.0,
    1.0 / 23.0,
    1.0 / 21.0,
    1.0 / 19.0,
    1.0 / 17.0,
    1.0 / 15.0,
    1.0 / 13.0,
    1.0 / 11.0,
    1.0 / 9.0,
    1.0 / 7.0,
    1.0 / 5.0,
    1.0 / 3.0,
    1.0,
];

/// How many of the last [`ATANH_SERIES`] terms (1/11 … 1) the f32 ln
/// sums: `shaders/ln_f32.wgsl` and the f32 reference's `ln` (truncation
/// s^12/13 < 5e-11 relative for |s| ≤ 0.1716, far below f32's 2^-24).
/// Their polynomial is 1/11 … 1/3 rounded to f32; the 1 is carried exactly
/// by f = m − 1.
pub const ATANH_TERMS_F32: usize = 6;

/// ln x by the arithmetic of `shaders/ln_f64.wgsl`.
pub fn ln(x: f64) -> f64 {
    if x.is_nan() || x <= 0.0 {
        return f64::NAN;
    }
    if x == f64::INFINITY {
        return x;
    }
    let (fraction, exponent) = libm::frexp(x);
    let mut m = 2.0 * fraction;
    let mut e = f64::from(exponent - 1);
    if m > std::f64::consts::SQRT_2 {
        m *= 0.5;
        e += 1.0;
    }
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    let mut poly = ATANH_SERIES[0];
    for &c in &ATANH_SERIES[1..] {
        poly = poly * s2 + c;
    }
    e * LN2_HI + (e * LN2_LO + 2.0 * s * poly)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_points_and_domain() {
        assert_eq!(ln(1.0), 0.0);
        approx::assert_relative_eq!(ln(2.0), std::f64::consts::LN_2, max_relative = 2e-16);
        approx::assert_relative_eq!(ln(0.5), -std::f64::consts::LN_2, max_relative = 2e-16);
        assert!(ln(0.0).is_nan() && ln(-1.0).is_nan() && ln(f64::NAN).is_nan());
        assert_eq!(ln(f64::INFINITY), f64::INFINITY);
        // Subnormals normalise through frexp.
        approx::assert_relative_eq!(ln(5e-324), libm::log(5e-324), max_relative = 1e-15);
    }
}
