//! Lagged friction: finite differences, a smoothed Coulomb ball, the
//! friction regimes.

use super::*;

#[test]
fn lagged_friction_matches_finite_differences_and_is_a_smoothed_coulomb_ball() {
    let mut rng = Lcg(1610);
    let (limit, eps) = (3.0, 1e-3);
    let (mut worst_g, mut worst_h, mut worst_psd) = (0.0f64, 0.0f64, 0.0f64);
    for dim in DIMS {
        let n = unit(dim, &mut rng);
        for slip in [0.0, 0.3 * eps, 3.0 * eps] {
            let tangent: Vec<f64> = {
                let t = unit(dim, &mut rng);
                let s: f64 = (0..dim).map(|a| t[a] * n[a]).sum();
                let u: Vec<f64> = (0..dim).map(|a| t[a] - s * n[a]).collect();
                let len = u.iter().map(|v| v * v).sum::<f64>().sqrt();
                u.iter()
                    .map(|v| if len > 0.0 { v / len } else { 0.0 })
                    .collect()
            };
            let start: Vec<f64> = (0..dim).map(|_| rng.next()).collect();
            let normal_part = 0.01 * rng.next();
            let x: Vec<f64> = (0..dim)
                .map(|a| start[a] + slip * tangent[a] + normal_part * n[a])
                .collect();
            let eval = |y: &[f64]| {
                let (mut g, mut u) = (vec![0.0; dim], vec![0.0; dim]);
                let term = obstacle_friction(&n, limit, eps, y, &start, &mut g, &mut u);
                (term, g, u)
            };
            let (term, g, u) = eval(&x);
            let mut block = vec![0.0; dim * dim];
            term.curvature.block(&n, &u, &mut block);
            let w = eigenvalues(&block, dim);
            worst_psd = worst_psd.max(-w[0] / (limit / eps));
            if slip == 0.0 || dim == 1 {
                assert!(g.iter().all(|v| v.abs() <= 1e-12 * limit), "{g:?}");
                continue;
            }
            assert_eq!(
                term.regime,
                if slip < eps {
                    FrictionRegime::Sticking
                } else {
                    FrictionRegime::Sliding
                }
            );
            let h = 1e-3 * slip;
            worst_g = worst_g.max(jacobian_worst(&|y| vec![eval(y).0.energy], &x, &g, h));
            worst_h = worst_h.max(jacobian_worst(&|y| eval(y).1, &x, &block, h));
            // The pair form: same term on the relative slip, equal and opposite.
            let mut points = vec![0.0; dim];
            points.extend(&x);
            let mut starts = vec![0.0; dim];
            starts.extend(&start);
            let (mut pg, mut pu) = (vec![0.0; 2 * dim], vec![0.0; dim]);
            let pair = pair_friction(&n, limit, eps, &points, &starts, &mut pg, &mut pu);
            assert_eq!(pair.slip, term.slip);
            for a in 0..dim {
                assert_eq!(pg[dim + a], g[a]);
                assert_eq!(pg[a], -g[a]);
            }
            let p: Vec<f64> = (0..2 * dim).map(|_| rng.next()).collect();
            let mut y = vec![0.0; 2 * dim];
            pair.curvature.apply_pair(&n, &pu, &p, &mut y);
            let v: Vec<f64> = (0..dim).map(|a| p[dim + a] - p[a]).collect();
            let reference = mat_vec(&block, &v);
            for a in 0..dim {
                assert!((y[dim + a] - reference[a]).abs() <= 1e-12 * limit / eps);
            }
        }
    }
    bound(
        "friction gradient vs FD",
        worst_g,
        1.0,
        "Richardson + rounding model",
    );
    bound(
        "friction Hessian vs FD (no projection needed)",
        worst_h,
        1.0,
        "Richardson + rounding model",
    );
    bound(
        "friction block min eigenvalue / (μλ/ε)",
        worst_psd,
        64.0 * EPS,
        "PSD by construction",
    );
    // Force against slip: linear through 0, μλ f₁(y) ≤ μλ, continuous (C¹) at ε.
    let n = [0.0, 1.0];
    for y in [1e-9, 1e-6, 1e-4, 5e-4, 0.999e-3, 1e-3, 2e-3, 1.0] {
        let (mut g, mut u) = ([0.0; 2], [0.0; 2]);
        obstacle_friction(&n, limit, eps, &[y, 0.0], &[0.0, 0.0], &mut g, &mut u);
        let force = g[0];
        let (_, f1, _) = mollifier(y, eps);
        assert!((force - limit * f1).abs() <= 4.0 * EPS * limit, "y = {y}");
        assert!(force <= limit);
        if y < 1e-5 {
            assert!(
                (force / y - 2.0 * limit / eps).abs() <= 1e-2 * limit / eps,
                "sticking stiffness 2μλ/ε"
            );
        }
    }
    let below = mollifier(eps * (1.0 - 1e-12), eps);
    let above = mollifier(eps * (1.0 + 1e-12), eps);
    bound(
        "mollifier f₀ jump at ε",
        (below.0 - above.0).abs() / eps,
        1e-11,
        "continuous",
    );
    bound(
        "mollifier f₁ jump at ε",
        (below.1 - above.1).abs(),
        1e-11,
        "continuous",
    );
    bound(
        "mollifier f₁' jump at ε (·ε)",
        (below.2 - above.2).abs() * eps,
        1e-11,
        "C¹ force",
    );
}
