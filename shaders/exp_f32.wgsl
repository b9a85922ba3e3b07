// exp for f32 from arithmetic, floor and ldexp only (a built-in exp is the
// adapter's own approximation): core's expr::exp_f32 (core/src/expr/exp.rs)
// bit for bit wherever f32 operations are correctly rounded.
//
//   k = floor(x/ln2 + ½),  r = (x − k·LN2_HI) − k·LN2_LO   (fdlibm split)
//   q = Σ_{j=2}^{8} r^(j−2)/j!  (Horner from 1/8! down to 1/2);  p = 1 + (r + r²·q)
//   exp x = ldexp(p, k)  (k = 128: ldexp(p, 127)·2, exact)
//   x > EXP_MAX → +∞ (x·1e38);  x < EXP_MIN → 0 (results stay normal)
// The constants and the Horner lines are written from the Rust table when
// the module is composed (expr::wgsl_support): the next line becomes
// `const EXP_INV_LN2: f32 = …;` etc.
// EXP_CONSTANTS

fn exp_real(x: f32) -> f32 {
    if (x != x) {
        return x;
    }
    if (x > EXP_MAX) {
        return x * 1e38;
    }
    if (x < EXP_MIN) {
        return 0.0;
    }
    let k = floor(x * EXP_INV_LN2 + 0.5);
    let r = (x - k * EXP_LN2_HI) - k * EXP_LN2_LO;
    // The next line becomes `var q: f32 = c_0;` and `q = q * r + c_j;`.
    // EXP_SERIES
    let p = 1.0 + (r + (r * r) * q);
    if (k > 127.0) {
        return ldexp(p, i32(k) - 1) * 2.0;
    }
    return ldexp(p, i32(k));
}
