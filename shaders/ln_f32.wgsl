// ln for f32 from arithmetic, floor and ldexp only: the built-in log is an
// adapter's approximation (llvmpipe's a polynomial the CPU cannot repeat);
// this one is the f32 reference's ln (cpu/src/f32_reference/ln.rs) bit for
// bit wherever f32 operations are correctly rounded, within 1 ulp of
// libm's logf on every positive normal f32.
//
//   y = x·2^-e with e from the built-in log2 estimate of x, corrected so
//   that m ∈ (√½, √2]:   ln x = e ln2 + 2 atanh(s),  s = (m − 1)/(m + 1), |s| ≤ 0.1716
//   2 atanh(s) = 2s + 2s·s²·Q,  Q = Σ_{k=1}^{5} s^{2(k−1)}/(2k + 1)  (truncation < 5e-11 relative)
//   2s = f − s·f with f = m − 1 exact (fdlibm's arrangement: hfsq = f²/2, R = 2s²Q)
//   ln x = e·LN2_HI − ((hfsq − (s·(hfsq + R) + e·LN2_LO)) − f)
//   ln2 = LN2_HI + LN2_LO (fdlibm's f32 split: LN2_HI has 17 bits, so
//   e·LN2_HI is exact for |e| ≤ 128)
// (m, e) is unique, so the estimate's error (a ±1 in e, corrected) moves no
// bit. Inputs are positive normal f32; values whose ldexp would leave the
// normal range are scaled by 2^±64 first (exact).

const LN2_HI: f32 = 0.69313812255859375;
const LN2_LO: f32 = 9.0580006144591607153415679931640625e-6;
const SQRT2: f32 = 1.41421353816986083984375;

fn ln_real(x0: f32) -> f32 {
    var y = x0;
    var e: f32 = 0.0;
    if (y < 1e-30) {
        y = ldexp(y, 64);
        e -= 64.0;
    }
    if (y > 1e30) {
        y = ldexp(y, -64);
        e += 64.0;
    }
    let k = floor(log2(y));
    var m = ldexp(y, -i32(k));
    e += k;
    if (m < 1.0) {
        m = m * 2.0;
        e -= 1.0;
    }
    if (m >= 2.0) {
        m = m * 0.5;
        e += 1.0;
    }
    if (m > SQRT2) {
        m = m * 0.5;
        e += 1.0;
    }
    let f = m - 1.0;
    let s = f / (m + 1.0);
    let s2 = s * s;
    let hfsq = 0.5 * f * f;
    // Q by Horner from 1/11 down to 1/3: the next line becomes
    // `var poly: f32 = c_0;` and `poly = poly * s2 + c_k;` from the last
    // ATANH_TERMS_F32 entries of material::ln's ATANH_SERIES but its 1,
    // each rounded to f32, when the module is composed (shader.rs).
    // ATANH_SERIES
    let r = 2.0 * s2 * poly;
    return e * LN2_HI - ((hfsq - (s * (hfsq + r) + e * LN2_LO)) - f);
}

// Machine epsilon of the precision (rounding-floor tests).
const REAL_EPS: f32 = 1.1920928955078125e-7;
