//! ∇C and ∇²C of random expressions against central finite differences
//! (f64), and the Hessian's symmetry.
//!
//! ```text
//! D_h f = (f(x + h e_j) − f(x − h e_j)) / 2h  = f' + f'''h²/6 + O(ε|f|/h)
//! ```
//! The test uses two steps h and h/2: where they agree to τ the central
//! difference is trusted (smooth there) and the derivative must agree with
//! it to 4τ + 1e-7·(1 + |f'|); where they do not (a kink of abs/min/max
//! within h), the point is skipped and counted — at most 5 % may be.

use super::random::{Rng, program};
use super::{compiled, eval_one, full, params};

fn fd(f: &dyn Fn(&[f64]) -> f64, x: &[f64], j: usize, h: f64) -> f64 {
    let mut p = x.to_vec();
    let mut m = x.to_vec();
    p[j] += h;
    m[j] -= h;
    (f(&p) - f(&m)) / (2.0 * h)
}

#[test]
fn gradient_and_hessian_match_finite_differences() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let (mut checked, mut skipped, mut programs) = (0usize, 0usize, 0usize);
    for case in 0..120 {
        let dim = 1 + case % 4;
        let arity = 1 + (case / 4) % 3;
        let src = program(&mut rng, 3, arity, dim);
        let c = compiled(&src, &params(dim), arity, dim);
        let tape = full(&c);
        let n = arity * dim;
        programs += 1;
        for _ in 0..4 {
            let x: Vec<f64> = (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect();
            let out = eval_one(&tape, &x);
            if !out.iter().all(|v| v.is_finite()) {
                continue;
            }
            let value = |y: &[f64]| eval_one(&tape, y)[0];
            for j in 0..n {
                let h = 1e-4;
                let (d1, d2) = (fd(&value, &x, j, h), fd(&value, &x, j, h / 2.0));
                let tau = (d1 - d2).abs();
                let g = out[1 + j];
                if tau > 1e-6 * (1.0 + g.abs()) {
                    skipped += 1;
                    continue;
                }
                checked += 1;
                assert!(
                    (g - d2).abs() <= 4.0 * tau + 1e-7 * (1.0 + g.abs()),
                    "{src}\nx = {x:?}\n∂{j}: {g} vs FD {d2} (τ {tau:e})"
                );
                // Row j of the Hessian: central differences of ∇C_k.
                for k in 0..n {
                    let grad_k = |y: &[f64]| eval_one(&tape, y)[1 + k];
                    let (e1, e2) = (fd(&grad_k, &x, j, h), fd(&grad_k, &x, j, h / 2.0));
                    let tau = (e1 - e2).abs();
                    let hjk = out[1 + n + tape.hessian_index(j, k)];
                    if tau > 1e-5 * (1.0 + hjk.abs()) {
                        skipped += 1;
                        continue;
                    }
                    checked += 1;
                    // The stored entry is (min, max): the same number for
                    // (j, k) and (k, j), so this checks symmetry of ∇²C too.
                    assert!(
                        (hjk - e2).abs() <= 4.0 * tau + 1e-6 * (1.0 + hjk.abs()),
                        "{src}\nx = {x:?}\n∂{j}∂{k}: {hjk} vs FD {e2} (τ {tau:e})"
                    );
                }
            }
        }
    }
    eprintln!(
        "derivatives: {programs} programs, {checked} entries checked, {skipped} skipped at kinks"
    );
    assert!(checked > 10_000, "{checked}");
    assert!(skipped * 20 <= checked, "{skipped} skipped of {checked}");
}

#[test]
fn the_stored_upper_triangle_is_the_symmetric_hessian() {
    // The reverse pass of ∇C_k gives the lower entries too: they agree with
    // the stored upper ones within rounding.
    let mut rng = Rng(7);
    for case in 0..40 {
        let dim = 1 + case % 3;
        let src = program(&mut rng, 3, 2, dim);
        let c = compiled(&src, &params(dim), 2, dim);
        let tape = full(&c);
        let n = 2 * dim;
        let x: Vec<f64> = (0..n).map(|_| rng.uniform(-1.0, 1.0)).collect();
        let h = super::super::diff_full_hessian(&c, &x);
        for j in 0..n {
            for k in 0..n {
                let (a, b) = (h[j * n + k], h[k * n + j]);
                if a.is_finite() && b.is_finite() {
                    assert!(
                        (a - b).abs() <= 1e-12 * (1.0 + a.abs()),
                        "{src}: H[{j}][{k}] = {a}, H[{k}][{j}] = {b}"
                    );
                }
            }
        }
        let _ = tape;
    }
}
