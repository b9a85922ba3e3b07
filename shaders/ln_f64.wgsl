// ln for f64 from arithmetic, floor and ldexp only (lavapipe's f64 log
// returns garbage; see DESIGN.md "f64 on the GPU").
//
//   y = x·2^-e with e from an f32 log2 estimate of x, corrected so that
//   m ∈ [√½, √2):   ln x = e ln2 + 2 atanh(s),  s = (m − 1)/(m + 1), |s| ≤ 0.1716
//   2 atanh(s) = 2 s Σ_{k=0}^{12} s^{2k}/(2k + 1)     (truncation < 1e-19 relative)
//   ln2 = LN2_HI + LN2_LO (fdlibm split: e·LN2_HI is exact for |e| < 2^20)
// Inputs are finite and > 0 (the barrier calls it with 0 < d/d^ < 1);
// values outside the f32 range are scaled by 2^±100 first.

const LN2_HI: f64 = 6.93147180369123816490e-01;
const LN2_LO: f64 = 1.90821492927058770002e-10;
const SQRT2: f64 = 1.41421356237309504880;

fn ln_real(x0: f64) -> f64 {
    var y = x0;
    var e: f64 = 0.0;
    for (var guard = 0u; guard < 12u && y < 1e-30; guard++) {
        y = ldexp(y, 100);
        e -= 100.0;
    }
    for (var guard = 0u; guard < 12u && y > 1e30; guard++) {
        y = ldexp(y, -100);
        e += 100.0;
    }
    let k = floor(log2(f32(y)));
    var m = ldexp(y, -i32(k));
    e += f64(k);
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
    let s = (m - 1.0) / (m + 1.0);
    let s2 = s * s;
    // poly = Σ_{k=0}^{12} s2^k/(2k + 1), Horner from 1/25 down to 1: the next
    // line becomes `var poly: f64 = c_0;` and `poly = poly * s2 + c_k;` from
    // material::ln's ATANH_SERIES when the module is composed (shader.rs).
    // ATANH_SERIES
    return e * LN2_HI + (e * LN2_LO + 2.0 * s * poly);
}

// Machine epsilon of the precision (rounding-floor tests).
const REAL_EPS: f64 = 2.220446049250313e-16;
