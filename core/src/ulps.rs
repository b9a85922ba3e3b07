//! Distances in units in the last place, for the accuracy tests of the
//! f32 and f64 elementary functions (`expr/exp.rs`, `material/ln_f32.rs`).
//!
//! ```text
//! key(v) = bits(v) for v ≥ +0, 2^(w−1) − bits(v) below: the order of the reals
//! ulps(a, b) = |key(a) − key(b)|          (a, b finite; ±0 are 0 apart)
//! ```

/// Distance in ulp between two finite f32.
pub(crate) fn ulps_f32(a: f32, b: f32) -> u64 {
    let key = |v: f32| {
        let b = v.to_bits() as i64;
        if b < 0x8000_0000 { b } else { 0x8000_0000 - b }
    };
    key(a).abs_diff(key(b))
}

/// Distance in ulp between two finite f64.
pub(crate) fn ulps_f64(a: f64, b: f64) -> u64 {
    let key = |v: f64| {
        let b = v.to_bits() as i128;
        if b < 0x8000_0000_0000_0000 {
            b
        } else {
            0x8000_0000_0000_0000 - b
        }
    };
    key(a).abs_diff(key(b)) as u64
}
