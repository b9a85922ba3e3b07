//! The f32 natural logarithm of `shaders/ln_f32.wgsl`, from arithmetic
//! only, so the Neo-Hookean law's ln J is the GPU's bits.
//!
//! ```text
//! x = m · 2^e,  m ∈ (√½, √2]     (m ∈ [1, 2) from the bits, halved if m > √2)
//! ln x = e ln2 + 2 atanh(s),  s = (m − 1)/(m + 1),  |s| ≤ 0.1716
//! 2 atanh(s) = 2s + 2s·s²·Q,  Q = Σ_{k=1}^{5} s^{2(k−1)}/(2k + 1)   (Horner, 1/11 down to 1/3)
//! 2s = f − s·f,  f = m − 1 (exact), so with hfsq = f²/2, R = 2 s² Q (fdlibm):
//! ln x = e·LN2_HI − ((hfsq − (s·(hfsq + R) + e·LN2_LO)) − f)
//! ```
//! The exact f carries the leading term, so the roundings of s land only
//! on the corrections: within 1 ulp of `libm::logf` on every positive
//! normal f32 (measured, all 2 130 706 432 of them: 74 810 at 1 ulp; the
//! plain e ln2 + 2 s poly sum put 1 001 at 3 ulp). Subnormal x (which the
//! shader's ldexp may flush) is outside its domain. The shader finds e from a log2 estimate,
//! corrects m into the same interval and scales by 2^±64 exactly where
//! ldexp would leave the normal range: (m, e) is unique, so both reach the
//! same pair and then run the same operations. Defined for positive normal
//! f32. It lives in core so that the f32 reference (`hyperpbd-cpu`) and
//! the expression compiler's f32 evaluator share one definition.

use super::ln::{ATANH_SERIES, ATANH_TERMS_F32};

/// 0x3f317180 (17 significant bits: e·LN2_HI exact for |e| ≤ 128).
const LN2_HI: f32 = 0.693_138_1;
/// 0x3717f7d1: ln 2 − LN2_HI to f32.
const LN2_LO: f32 = 9.058_001e-6;
/// √2 rounded to f32 (0x3fb504f3).
const SQRT2: f32 = std::f32::consts::SQRT_2;

/// ln x by the arithmetic of `shaders/ln_f32.wgsl`.
pub fn ln_f32(x: f32) -> f32 {
    let bits = x.to_bits();
    let mut e = (((bits >> 23) & 0xff) as i32 - 127) as f32;
    let mut m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    if m > SQRT2 {
        m *= 0.5;
        e += 1.0;
    }
    let f = m - 1.0;
    let s = f / (m + 1.0);
    let s2 = s * s;
    let hfsq = 0.5 * f * f;
    // 1/11 … 1/3: the series' last ATANH_TERMS_F32 terms but its 1.
    let series = &ATANH_SERIES[ATANH_SERIES.len() - ATANH_TERMS_F32..ATANH_SERIES.len() - 1];
    let mut poly = series[0] as f32;
    for &c in &series[1..] {
        poly = poly * s2 + c as f32;
    }
    let r = 2.0 * s2 * poly;
    e * LN2_HI - ((hfsq - (s * (hfsq + r) + e * LN2_LO)) - f)
}

#[cfg(test)]
mod tests {
    use super::ln_f32 as ln;
    use super::*;
    use crate::ulps::ulps_f32 as ulps;

    #[test]
    fn constants_are_fdlibms_bits() {
        assert_eq!(LN2_HI.to_bits(), 0x3f31_7180);
        assert_eq!(LN2_LO.to_bits(), 0x3717_f7d1);
        assert_eq!(SQRT2.to_bits(), 0x3fb5_04f3);
    }

    #[test]
    fn within_one_ulp_of_libm_over_the_normal_range() {
        assert_eq!(ln(1.0), 0.0);
        // Every 61st positive normal f32, and every f32 within 2^-8 of 1
        // (all of them measured once: 74 810 at 1 ulp, none further).
        let mut worst = 0;
        let mut check = |x: f32| {
            let d = ulps(ln(x), libm::logf(x));
            assert!(d <= 1, "ln({x:e}) = {:e}, logf {:e}", ln(x), libm::logf(x));
            worst = worst.max(d);
        };
        let (lo, hi) = (f32::MIN_POSITIVE.to_bits(), f32::MAX.to_bits());
        for b in (lo..=hi).step_by(61) {
            check(f32::from_bits(b));
        }
        for b in (1.0f32 - 1.0 / 256.0).to_bits()..=(1.0f32 + 1.0 / 256.0).to_bits() {
            check(f32::from_bits(b));
        }
        assert!(worst <= 1);
    }
}
