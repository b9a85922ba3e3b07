//! Sort keys of the sweep: a box coordinate rounded outward to f32 and
//! mapped to a u32 whose unsigned order is the numeric order.
//!
//! ```text
//! key_down(x) ≤ x ≤ key_up(x)        (f32 values; ±0 normalized: down → −0, up → +0)
//! |x| < 2^−126:  down = −2^−126 if x < 0 else −0;  up = 2^−126 if x > 0 else +0
//! |x| > f32::MAX: down/up saturate to ±f32::MAX or ±∞ on the safe side
//! sortable(f) = bits(f) | 2^31 if f ≥ +0 else !bits(f)
//! a ≤ b  ⇒  sortable(key_down(a)) ≤ sortable(key_up(b))
//! ```
//! The sweep sorts boxes by sortable(key_down(min)) and stops scanning when
//! sortable(key_down(min_t)) > sortable(key_up(max_i)): then min_t > max_i
//! exactly, for this box and every later one. Keys are 32 bits for both
//! precisions (an f64 GPU kernel cannot bitcast f64), denormals are never
//! produced (GPUs may flush them), and the exact overlap test is done on
//! the full-precision coordinates afterwards — so the pair list does not
//! depend on the key precision.

/// Smallest positive normal f32, 2^−126.
pub const F32_MIN_NORMAL: f32 = f32::MIN_POSITIVE;

/// The largest f32 value ≤ x (never +0, never a denormal).
pub fn key_down(x: f64) -> f32 {
    if x.abs() < f64::from(F32_MIN_NORMAL) {
        return if x < 0.0 { -F32_MIN_NORMAL } else { -0.0 };
    }
    if x > f64::from(f32::MAX) {
        return f32::MAX;
    }
    if x < -f64::from(f32::MAX) {
        return f32::NEG_INFINITY;
    }
    let f = x as f32;
    if f64::from(f) > x {
        next_toward_zero_or_down(f)
    } else {
        f
    }
}

/// The smallest f32 value ≥ x (never −0, never a denormal).
pub fn key_up(x: f64) -> f32 {
    -key_down(-x)
}

/// The f32 just below a normal, nonzero f.
fn next_toward_zero_or_down(f: f32) -> f32 {
    let bits = f.to_bits();
    if f > 0.0 {
        f32::from_bits(bits - 1)
    } else {
        f32::from_bits(bits + 1)
    }
}

/// A u32 whose unsigned order is the numeric order of f (−0 before +0).
pub fn sortable_bits(f: f32) -> u32 {
    let bits = f.to_bits();
    if bits & 0x8000_0000 != 0 {
        !bits
    } else {
        bits | 0x8000_0000
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_bracket_the_value_and_keep_order() {
        let values = [
            -1e300,
            -3.5,
            -1.0 - 1e-12,
            -1e-40,
            -0.0,
            0.0,
            1e-40,
            1e-12,
            0.1,
            1.0 + 1e-12,
            7.25,
            3.5e38,
            1e300,
        ];
        for &x in &values {
            let (d, u) = (key_down(x), key_up(x));
            assert!(f64::from(d) <= x && x <= f64::from(u), "{x}: {d} {u}");
            assert!(d.to_bits() != 0 && u.to_bits() != 0x8000_0000, "{x}");
            assert!(d == 0.0 || d.is_infinite() || d.abs() >= F32_MIN_NORMAL);
        }
        for &a in &values {
            for &b in &values {
                if a <= b {
                    assert!(
                        sortable_bits(key_down(a)) <= sortable_bits(key_up(b)),
                        "{a} {b}"
                    );
                }
                if a < b {
                    assert!(sortable_bits(key_down(a)) <= sortable_bits(key_down(b)));
                }
            }
        }
        assert!(f64::from(key_down(0.1)) < 0.1);
        assert!(f64::from(key_up(0.1)) > 0.1);
        assert_eq!(key_down(2.5), 2.5);
        assert_eq!(key_up(2.5), 2.5);
    }
}
