//! Preconditioned CG on known SPD systems: the CG bounds and breakdown.

use super::*;

/// Dense SPD products for PCG.
fn dense(a: &[f64]) -> impl FnMut(&[f64], &mut [f64]) + '_ {
    move |p: &[f64], out: &mut [f64]| out.copy_from_slice(&mat_vec(a, p))
}

#[test]
fn pcg_solves_spd_systems_within_the_cg_bounds_and_reports_breakdown() {
    let mut rng = Lcg(1607);
    let settings = PcgSettings {
        max_iterations: 1000,
        relative_tolerance: 1e-10,
        absolute_tolerance: 0.0,
    };
    let mut ws = PcgWorkspace::new();
    // Diagonal H with the Jacobi preconditioner: one iteration, exact.
    let n = 37;
    let diag: Vec<f64> = (0..n).map(|i| 1.0 + i as f64 * 3.7).collect();
    let mut h = vec![0.0; n * n];
    for i in 0..n {
        h[i * n + i] = diag[i];
    }
    let inverse: Vec<f64> = diag.iter().map(|d| 1.0 / d).collect();
    let b: Vec<f64> = (0..n).map(|_| rng.next()).collect();
    let mut d = vec![0.0; n];
    let report = pcg(dense(&h), &inverse, &b, 1, settings, &mut d, &mut ws);
    assert_eq!(
        (report.status, report.iterations),
        (PcgStatus::Converged, 1)
    );
    for i in 0..n {
        assert!((d[i] * diag[i] - b[i]).abs() <= 2.0 * EPS * b[i].abs());
    }
    // Three distinct eigenvalues, identity preconditioner: ≤ 3 iterations.
    let n = 24;
    let q = rotation(n, &mut rng);
    let spectrum: Vec<f64> = (0..n).map(|i| [1.0, 4.0, 9.0][i % 3]).collect();
    let mut h = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            h[i * n + j] = (0..n)
                .map(|l| q[i * n + l] * spectrum[l] * q[j * n + l])
                .sum();
        }
    }
    let x_star: Vec<f64> = (0..n).map(|_| rng.next()).collect();
    let b = mat_vec(&h, &x_star);
    let ones = vec![1.0; n];
    d.resize(n, 0.0);
    let report = pcg(dense(&h), &ones, &b, 4, settings, &mut d, &mut ws);
    assert_eq!(report.status, PcgStatus::Converged);
    bound(
        "PCG iterations, 3 distinct eigenvalues",
        report.iterations as f64,
        3.0,
        "exact CG terminates",
    );
    let error = x_star
        .iter()
        .zip(&d)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    bound(
        "PCG solution error, 3 eigenvalues",
        error,
        9.0 * 1e-10 * 10.0,
        "κ · tolerance · |x*|",
    );
    // Mass + stiffness chain (tridiagonal), Jacobi: iterations within the Chebyshev bound.
    let n = 400;
    let (m, k) = (1.0, 400.0);
    let mut h = vec![0.0; n * n];
    for i in 0..n {
        h[i * n + i] = m + 2.0 * k;
        if i + 1 < n {
            h[i * n + i + 1] = -k;
            h[(i + 1) * n + i] = -k;
        }
    }
    let w = eigenvalues(&h, n);
    let kappa = w[n - 1] / w[0];
    let q_rate = (kappa.sqrt() - 1.0) / (kappa.sqrt() + 1.0);
    let limit = ((2.0 * kappa.sqrt() / 1e-10).ln() / (1.0 / q_rate).ln()).ceil();
    let x_star: Vec<f64> = (0..n).map(|_| rng.next()).collect();
    let b = mat_vec(&h, &x_star);
    let inverse: Vec<f64> = (0..n).map(|i| 1.0 / h[i * n + i]).collect();
    d.resize(n, 0.0);
    let report = pcg(dense(&h), &inverse, &b, 2, settings, &mut d, &mut ws);
    assert_eq!(report.status, PcgStatus::Converged);
    bound(
        "PCG iterations, chain",
        report.iterations as f64,
        limit,
        "2√κ q^k ≤ tolerance",
    );
    let residual: f64 = mat_vec(&h, &d)
        .iter()
        .zip(&b)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt();
    let b_norm = b.iter().map(|v| v * v).sum::<f64>().sqrt();
    bound(
        "PCG true residual / ‖b‖, chain",
        residual / b_norm,
        2e-10,
        "tolerance + recurrence drift",
    );
    // Deterministic to the bit.
    let mut again = vec![0.0; n];
    pcg(dense(&h), &inverse, &b, 2, settings, &mut again, &mut ws);
    assert!(
        d.iter()
            .zip(&again)
            .all(|(a, b)| a.to_bits() == b.to_bits())
    );
    // Budget, frozen coordinates, breakdown, non-finite.
    let tight = PcgSettings {
        max_iterations: 2,
        ..settings
    };
    let report = pcg(dense(&h), &inverse, &b, 2, tight, &mut d, &mut ws);
    assert_eq!(
        (report.status, report.iterations),
        (PcgStatus::BudgetExhausted, 2)
    );
    let bd: f64 = b.iter().zip(&d).map(|(p, q)| p * q).sum();
    assert!(
        bd > 0.0,
        "a budget-exhausted iterate is a descent direction"
    );
    let mut frozen = inverse.clone();
    frozen[5] = 0.0;
    pcg(dense(&h), &frozen, &b, 2, settings, &mut d, &mut ws);
    assert_eq!(d[5], 0.0);
    let indefinite = [1.0, 0.0, 0.0, -1.0];
    let report = pcg(
        dense(&indefinite),
        &[1.0, 1.0],
        &[0.0, 1.0],
        2,
        settings,
        &mut d[..2],
        &mut ws,
    );
    assert_eq!(
        report.status,
        PcgStatus::NonPositiveCurvature { curvature: -1.0 }
    );
    let report = pcg(
        dense(&[f64::NAN]),
        &[1.0],
        &[1.0],
        1,
        settings,
        &mut d[..1],
        &mut ws,
    );
    assert_eq!(report.status, PcgStatus::NonFinite);
    let report = pcg(
        dense(&indefinite),
        &[1.0, 1.0],
        &[0.0, 0.0],
        2,
        settings,
        &mut d[..2],
        &mut ws,
    );
    assert_eq!(
        (report.status, report.iterations),
        (PcgStatus::Converged, 0)
    );
}
