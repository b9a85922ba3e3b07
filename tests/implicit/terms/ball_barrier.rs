//! The ball–ball barrier: finite differences and momentum conservation.

use super::*;

#[test]
fn ball_barrier_matches_finite_differences_and_conserves_momentum() {
    let mut rng = Lcg(1604);
    let law = BarrierLaw {
        stiffness: 50.0,
        activation_distance: 0.1,
    };
    let radii = (0.2, 0.3);
    let (mut worst_g, mut worst_h, mut worst_sum) = (0.0f64, 0.0f64, 0.0f64);
    for dim in DIMS {
        for gap in [0.004, 0.03, 0.08] {
            let n = unit(dim, &mut rng);
            let xi: Vec<f64> = (0..dim).map(|_| rng.next()).collect();
            let length = radii.0 + radii.1 + gap;
            let mut points = xi.clone();
            points.extend(xi.iter().zip(&n).map(|(x, n)| x + length * n));
            let eval = |x: &[f64]| {
                let (mut dg, mut g) = (vec![0.0; 2 * dim], vec![0.0; 2 * dim]);
                let pair = ball_pair_barrier(&law, x, radii, dim, &mut dg, &mut g);
                (pair, dg, g)
            };
            let (pair, dg, g) = eval(&points);
            assert!(pair.distance > 0.0 && pair.distance < 0.1 && pair.energy > 0.0);
            let h = 1e-3 * pair.distance;
            worst_g = worst_g.max(jacobian_worst(&|x| vec![eval(x).0.energy], &points, &g, h));
            let (_, b1, b2) = law.evaluate(pair.distance);
            let ell = pair.distance + radii.0 + radii.1;
            let mut exact = vec![0.0; 4 * dim * dim];
            RadialCurvature::exact(b1, b2, ell).block(&dg[dim..], &mut exact);
            worst_h = worst_h.max(jacobian_worst(&|x| eval(x).2, &points, &exact, h));
            let mut block = vec![0.0; 4 * dim * dim];
            pair.curvature.block(&dg[dim..], &mut block);
            let w = eigenvalues(&block, 2 * dim);
            assert!(w[0] >= -64.0 * EPS * b2, "N = {dim}: {w:?}");
            assert_eq!(pair.curvature.across, 0.0);
            assert_eq!(pair.curvature.along, b2);
            for a in 0..dim {
                worst_sum = worst_sum.max((g[a] + g[dim + a]).abs() / b1.abs());
            }
        }
        // Inactive and infeasible pairs.
        let mut points = vec![0.0; 2 * dim];
        points[dim] = 0.7;
        let (mut dg, mut g) = (vec![0.0; 2 * dim], vec![1.0; 2 * dim]);
        let far = ball_pair_barrier(&law, &points, radii, dim, &mut dg, &mut g);
        assert_eq!((far.energy, far.slope), (0.0, 0.0));
        assert!(g.iter().all(|&v| v == 0.0));
        points[dim] = 0.5;
        let touching = ball_pair_barrier(&law, &points, radii, dim, &mut dg, &mut g);
        assert_eq!(touching.energy, f64::INFINITY);
    }
    bound(
        "ball barrier gradient vs FD",
        worst_g,
        1.0,
        "Richardson + rounding model",
    );
    bound(
        "ball barrier exact Hessian vs FD",
        worst_h,
        1.0,
        "Richardson + rounding model",
    );
    bound(
        "ball barrier |∇_i + ∇_j| / |b'|",
        worst_sum,
        0.0,
        "equal and opposite by construction",
    );
}
