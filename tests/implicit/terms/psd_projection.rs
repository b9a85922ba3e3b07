//! PSD projection: nearest, deterministic, keeps PSD input.

use super::*;

#[test]
fn psd_projection_is_nearest_deterministic_and_keeps_psd_input() {
    let mut rng = Lcg(1605);
    let (mut worst_neg, mut worst_ref) = (0.0f64, 0.0f64);
    for n in 1..=8 {
        for _ in 0..20 {
            let mut a = vec![0.0; n * n];
            for i in 0..n {
                for j in 0..=i {
                    let v = rng.next();
                    a[i * n + j] = v;
                    a[j * n + i] = v;
                }
            }
            let mut p = a.clone();
            let report = project_psd(&mut p, n, &mut PsdScratch::new());
            let mut again = a.clone();
            project_psd(&mut again, n, &mut PsdScratch::new());
            assert!(
                p.iter()
                    .zip(&again)
                    .all(|(x, y)| x.to_bits() == y.to_bits())
            );
            for i in 0..n {
                for j in 0..n {
                    assert_eq!(p[i * n + j].to_bits(), p[j * n + i].to_bits());
                }
            }
            let w = eigenvalues(&p, n);
            worst_neg = worst_neg.max(-w[0]);
            // Reference: V max(Λ, 0) Vᵀ from nalgebra.
            let m = nalgebra::DMatrix::from_row_slice(n, n, &a);
            let e = nalgebra::SymmetricEigen::new(m);
            let lambda = nalgebra::DMatrix::from_diagonal(&e.eigenvalues.map(|v| v.max(0.0)));
            let reference = &e.eigenvectors * lambda * e.eigenvectors.transpose();
            for i in 0..n {
                for j in 0..n {
                    worst_ref = worst_ref.max((p[i * n + j] - reference[(i, j)]).abs());
                }
            }
            assert_eq!(
                report.clipped,
                e.eigenvalues.iter().filter(|&&v| v < 0.0).count()
            );
            // A PSD input (B Bᵀ) comes back bit for bit.
            let b: Vec<f64> = (0..n * n).map(|_| rng.next()).collect();
            let mut psd = vec![0.0; n * n];
            for i in 0..n {
                for j in 0..n {
                    psd[i * n + j] = (0..n).map(|l| b[i * n + l] * b[j * n + l]).sum::<f64>()
                        + if i == j { 0.1 } else { 0.0 };
                }
            }
            let before = psd.clone();
            let report = project_psd(&mut psd, n, &mut PsdScratch::new());
            assert_eq!(report.clipped, 0);
            assert!(
                psd.iter()
                    .zip(&before)
                    .all(|(x, y)| x.to_bits() == y.to_bits())
            );
        }
    }
    let mut bad = vec![1.0, f64::NAN, f64::NAN, 1.0];
    let report = project_psd(&mut bad, 2, &mut PsdScratch::new());
    assert!(!report.finite && bad[0] == 1.0 && bad[1].is_nan());
    bound(
        "PSD projection smallest eigenvalue (|A| ≤ 1)",
        worst_neg,
        64.0 * 8.0 * EPS,
        "Jacobi residual",
    );
    bound(
        "PSD projection vs nalgebra V max(Λ,0) Vᵀ",
        worst_ref,
        1e3 * EPS,
        "two eigensolvers",
    );
}
