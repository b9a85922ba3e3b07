//! The exponential from arithmetic, floor and ldexp only, in f64 and f32,
//! exactly as `shaders/exp_f64.wgsl` and `shaders/exp_f32.wgsl` compute it
//! (lavapipe's f64 `exp` is garbage and its f32 one is its own polynomial;
//! see DESIGN.md "f64 on the GPU"), so an expression's `exp` gives the same
//! bits on the CPU and in WGSL.
//!
//! ```text
//! k = floor(x·(1/ln2) + ½)                      (nearest integer to x/ln2)
//! r = (x − k·LN2_HI) − k·LN2_LO,  |r| ≲ ½ ln2    (fdlibm split: k·LN2_HI exact)
//! q = Σ_{j=2}^{D} r^{j−2}/j!   (Horner from 1/D! down to 1/2; D = 13 in f64, 8 in f32;
//!                              truncation r^{D+1}/(D+1)! < 6e-18 resp. 6e-9 relative)
//! p = 1 + (r + r²·q)       (the leading 1 + r carried exactly: the rounding
//!                           of the Horner sum lands on r²q, |r²q| < 0.07)
//! exp x = p·2^k            (ldexp; for the top k = 2^(E−1)·… written ldexp(p, k−1)·2)
//! x > MAX → +∞ (x·HUGE);  x < MIN → 0  (MIN keeps every result normal:
//!   GPUs may flush subnormals, so the flush is part of the definition)
//! NaN → NaN
//! ```
//! Measured against `libm` (tests below): within 1 ulp in f64 on
//! [−708, 709.7] and within 1 ulp in f32 on [−86, 88.7].

/// 1/j! for j = 13 … 2: the f64 Horner coefficients of q, highest first.
/// `shaders/exp_f64.wgsl`'s polynomial is written from this table
/// (`expr::wgsl_support`).
pub const EXP_SERIES_F64: [f64; 12] = [
    1.0 / 6_227_020_800.0,
    1.0 / 479_001_600.0,
    1.0 / 39_916_800.0,
    1.0 / 3_628_800.0,
    1.0 / 362_880.0,
    1.0 / 40_320.0,
    1.0 / 5_040.0,
    1.0 / 720.0,
    1.0 / 120.0,
    1.0 / 24.0,
    1.0 / 6.0,
    1.0 / 2.0,
];

/// 1/j! for j = 8 … 2 rounded to f32: the f32 Horner coefficients of q.
pub const EXP_SERIES_F32: [f32; 7] = [
    (1.0 / 40_320.0) as f32,
    (1.0 / 5_040.0) as f32,
    (1.0 / 720.0) as f32,
    (1.0 / 120.0) as f32,
    (1.0 / 24.0) as f32,
    (1.0 / 6.0) as f32,
    0.5,
];

/// 1/ln 2 (f64).
pub const EXP_INV_LN2_F64: f64 = std::f64::consts::LOG2_E;
/// fdlibm's high part of ln 2 (33 significant bits).
pub const EXP_LN2_HI_F64: f64 = 6.931_471_803_691_238e-1;
/// ln 2 − [`EXP_LN2_HI_F64`].
pub const EXP_LN2_LO_F64: f64 = 1.908_214_929_270_587_7e-10;
/// Above this, exp overflows: +∞ (ln of f64::MAX, rounded down).
pub const EXP_MAX_F64: f64 = 709.782_712_893_384;
/// Below this, exp is 0 (keeps every result a normal f64).
pub const EXP_MIN_F64: f64 = -708.0;

/// 1/ln 2 (f32).
pub const EXP_INV_LN2_F32: f32 = std::f32::consts::LOG2_E;
/// fdlibm's expf high part of ln 2 (0x3f317200).
pub const EXP_LN2_HI_F32: f32 = 0.693_145_75;
/// ln 2 − [`EXP_LN2_HI_F32`] (0x35bfbe8e).
pub const EXP_LN2_LO_F32: f32 = 1.428_606_8e-6;
/// Above this, exp overflows: +∞ (ln of f32::MAX, rounded down).
pub const EXP_MAX_F32: f32 = 88.722_83;
/// Below this, exp is 0 (keeps every result a normal f32).
pub const EXP_MIN_F32: f32 = -86.0;

/// exp x by the arithmetic of `shaders/exp_f64.wgsl`.
pub fn exp_f64(x: f64) -> f64 {
    if x.is_nan() {
        return x;
    }
    if x > EXP_MAX_F64 {
        return x * 1e308;
    }
    if x < EXP_MIN_F64 {
        return 0.0;
    }
    let k = (x * EXP_INV_LN2_F64 + 0.5).floor();
    let r = (x - k * EXP_LN2_HI_F64) - k * EXP_LN2_LO_F64;
    let mut q = EXP_SERIES_F64[0];
    for &c in &EXP_SERIES_F64[1..] {
        q = q * r + c;
    }
    let p = 1.0 + (r + (r * r) * q);
    // k ∈ [−1021, 1024]: the casts are exact.
    if k > 1023.0 {
        libm::scalbn(p, k as i32 - 1) * 2.0
    } else {
        libm::scalbn(p, k as i32)
    }
}

/// exp x by the arithmetic of `shaders/exp_f32.wgsl`.
pub fn exp_f32(x: f32) -> f32 {
    if x.is_nan() {
        return x;
    }
    if x > EXP_MAX_F32 {
        return x * 1e38;
    }
    if x < EXP_MIN_F32 {
        return 0.0;
    }
    let k = (x * EXP_INV_LN2_F32 + 0.5).floor();
    let r = (x - k * EXP_LN2_HI_F32) - k * EXP_LN2_LO_F32;
    let mut q = EXP_SERIES_F32[0];
    for &c in &EXP_SERIES_F32[1..] {
        q = q * r + c;
    }
    let p = 1.0 + (r + (r * r) * q);
    // k ∈ [−124, 128]: the casts are exact.
    if k > 127.0 {
        libm::scalbnf(p, k as i32 - 1) * 2.0
    } else {
        libm::scalbnf(p, k as i32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ulps::{ulps_f32 as ulps32, ulps_f64 as ulps64};

    #[test]
    fn constants_are_fdlibms_bits() {
        assert_eq!(EXP_LN2_HI_F32.to_bits(), 0x3f31_7200);
        assert_eq!(EXP_LN2_LO_F32.to_bits(), 0x35bf_be8e);
        assert_eq!(EXP_LN2_HI_F64.to_bits(), 0x3fe6_2e42_fee0_0000);
        assert_eq!(EXP_LN2_LO_F64.to_bits(), 0x3dea_39ef_3579_3c76);
        assert_eq!(EXP_INV_LN2_F64, std::f64::consts::LOG2_E);
    }

    #[test]
    fn exact_points_and_domain() {
        assert_eq!(exp_f64(0.0), 1.0);
        assert_eq!(exp_f32(0.0), 1.0);
        assert_eq!(exp_f64(1000.0), f64::INFINITY);
        assert_eq!(exp_f64(f64::INFINITY), f64::INFINITY);
        assert_eq!(exp_f64(-709.0), 0.0);
        assert_eq!(exp_f64(f64::NEG_INFINITY), 0.0);
        assert!(exp_f64(f64::NAN).is_nan());
        assert_eq!(exp_f32(100.0), f32::INFINITY);
        assert_eq!(exp_f32(-87.0), 0.0);
        assert!(exp_f32(f32::NAN).is_nan());
        assert!(exp_f64(EXP_MIN_F64).is_normal());
        assert!(exp_f32(EXP_MIN_F32).is_normal());
        assert!(exp_f64(EXP_MAX_F64).is_finite());
        assert!(exp_f32(EXP_MAX_F32).is_finite());
    }

    #[test]
    fn f64_within_one_ulp_of_libm() {
        let mut worst = 0;
        let n = 2_000_000;
        for i in 0..=n {
            let x = EXP_MIN_F64 + (709.7 - EXP_MIN_F64) * i as f64 / n as f64;
            worst = worst.max(ulps64(exp_f64(x), libm::exp(x)));
        }
        // Near 0, where r = x.
        for i in -100_000..=100_000 {
            let x = i as f64 * 1e-6;
            worst = worst.max(ulps64(exp_f64(x), libm::exp(x)));
        }
        eprintln!("exp_f64: worst {worst} ulp");
        assert!(worst <= 1, "worst {worst} ulp");
    }

    #[test]
    fn f32_within_one_ulp_of_libm() {
        // Every 7th f32 in [MIN, MAX] (all of them measured once).
        let mut worst = 0;
        let mut check = |x: f32| {
            worst = worst.max(ulps32(exp_f32(x), libm::expf(x)));
        };
        for b in (0..=EXP_MIN_F32.to_bits() & 0x7fff_ffff).step_by(7) {
            check(-f32::from_bits(b));
        }
        for b in (0..=EXP_MAX_F32.to_bits()).step_by(7) {
            check(f32::from_bits(b));
        }
        eprintln!("exp_f32: worst {worst} ulp");
        assert!(worst <= 1, "worst {worst} ulp");
    }
}
