// ln for f32: the built-in (correct on every tested adapter in f32).
fn ln_real(x0: f32) -> f32 {
    return log(x0);
}

// Machine epsilon of the precision (rounding-floor tests).
const REAL_EPS: f32 = 1.1920928955078125e-7;
