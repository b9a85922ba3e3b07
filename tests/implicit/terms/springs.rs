//! Distance, tether and measure springs: finite-difference gradients and
//! Hessians, exact projection, Gauss–Newton curvature exact at rest.

use super::*;

/// A spring element's terms and gradients (∇C, ∇E) at `x`.
fn spring_at(
    kind: ConstraintKind,
    alpha: f64,
    rest: f64,
    x: &[f64],
    dim: usize,
) -> (hyperpbd::core::implicit::Spring, Vec<f64>, Vec<f64>) {
    let (mut cg, mut eg) = (vec![0.0; x.len()], vec![0.0; x.len()]);
    let s = evaluate_spring(
        kind,
        alpha,
        rest,
        x,
        dim,
        &mut cg,
        &mut eg,
        &mut Scratch::new(),
    );
    (s, cg, eg)
}

#[test]
fn distance_and_tether_springs_match_finite_differences_and_project_exactly() {
    let mut rng = Lcg(1601);
    let alpha = 0.01;
    let (mut worst_g, mut worst_h, mut worst_psd, mut worst_apply) =
        (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut control = f64::INFINITY;
    for dim in DIMS {
        for kind in [ConstraintKind::Distance, ConstraintKind::Tether] {
            for rest_factor in [0.7, 1.3] {
                let points = simplex(dim, 1, &mut rng);
                let length = (0..dim)
                    .map(|a| (points[dim + a] - points[a]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                let rest = rest_factor * length;
                let eval = |x: &[f64]| spring_at(kind, alpha, rest, x, dim);
                let (spring, cg, eg) = eval(&points);
                let n = &cg[dim..];
                worst_g = worst_g.max(jacobian_worst(
                    &|x| vec![eval(x).0.energy],
                    &points,
                    &eg,
                    1e-4,
                ));
                // The exact Hessian (unprojected) from the radial form.
                let c = spring.value;
                let slack = kind == ConstraintKind::Tether && c <= 0.0;
                let exact = if slack {
                    RadialCurvature::default()
                } else {
                    RadialCurvature::exact(c / alpha, 1.0 / alpha, length)
                };
                let mut exact_block = vec![0.0; 4 * dim * dim];
                exact.block(n, &mut exact_block);
                worst_h = worst_h.max(jacobian_worst(&|x| eval(x).2, &points, &exact_block, 1e-4));
                if kind == ConstraintKind::Distance && dim > 1 {
                    // Negative control: without C∇²C/α the check must fail.
                    let mut gauss_newton = vec![0.0; 4 * dim * dim];
                    RadialCurvature {
                        across: 0.0,
                        ..exact
                    }
                    .block(n, &mut gauss_newton);
                    control =
                        control.min(jacobian_worst(&|x| eval(x).2, &points, &gauss_newton, 1e-4));
                }
                let mut block = vec![0.0; 4 * dim * dim];
                spring.block(&cg, dim, &mut block);
                let w = eigenvalues(&block, 2 * dim);
                worst_psd = worst_psd.max(-w[0] * alpha);
                if c > 0.0 || dim == 1 {
                    assert_eq!(
                        block, exact_block,
                        "{kind:?} N = {dim}: PSD block must be kept"
                    );
                } else if !slack {
                    // Compressed distance: eigenvalues 2/α once, 0 otherwise.
                    let top = w[2 * dim - 1];
                    assert!((top * alpha - 2.0).abs() < 1e-12, "{w:?}");
                    assert!(
                        w[..2 * dim - 1].iter().all(|v| v.abs() * alpha < 1e-12),
                        "{w:?}"
                    );
                }
                assert!(matches!(spring.curvature, SpringCurvature::Radial(_)));
                // apply and diagonal agree with the dense block.
                let p: Vec<f64> = (0..2 * dim).map(|_| rng.next()).collect();
                let mut y = vec![0.0; 2 * dim];
                spring.apply(&cg, dim, &p, &mut y);
                let reference = mat_vec(&block, &p);
                let mut diagonal = vec![0.0; 2 * dim];
                spring.diagonal(&cg, dim, &mut diagonal);
                for i in 0..2 * dim {
                    worst_apply = worst_apply.max((y[i] - reference[i]).abs() * alpha);
                    worst_apply =
                        worst_apply.max((diagonal[i] - block[i * 2 * dim + i]).abs() * alpha);
                }
            }
        }
    }
    assert!(
        control > 100.0,
        "negative control (Gauss–Newton only) passed the FD check: {control}"
    );
    bound(
        "spring radial gradient vs FD",
        worst_g,
        1.0,
        "Richardson + rounding model",
    );
    bound(
        "spring radial exact Hessian vs FD",
        worst_h,
        1.0,
        "Richardson + rounding model",
    );
    bound(
        "spring radial projected min eigenvalue ·α",
        worst_psd,
        64.0 * EPS,
        "PSD to rounding",
    );
    bound(
        "spring apply/diagonal vs dense ·α",
        worst_apply,
        64.0 * EPS,
        "same products, other order",
    );
}

#[test]
fn measure_springs_are_gauss_newton_and_exact_at_rest() {
    let mut rng = Lcg(1602);
    let alpha = 0.05;
    let (mut worst_g, mut worst_h) = (0.0f64, 0.0f64);
    let mut cases = Vec::new();
    for dim in DIMS {
        for k in [1, 2.min(dim), dim] {
            cases.push((ConstraintKind::SimplexMeasure, dim, k));
        }
        cases.push((ConstraintKind::OrientedMeasure, dim, dim));
    }
    cases.dedup();
    for (kind, dim, k) in cases {
        let points = simplex(dim, k, &mut rng);
        let count = (k + 1) * dim;
        let eval = |x: &[f64], rest: f64| spring_at(kind, alpha, rest, x, dim);
        let value = eval(&points, 0.0).0.value;
        // Stretched: FD gradient.
        let rest = 0.8 * value;
        let (_, _, eg) = eval(&points, rest);
        worst_g = worst_g.max(jacobian_worst(
            &|x| vec![eval(x, rest).0.energy],
            &points,
            &eg,
            1e-4,
        ));
        // At rest (C = 0): the Gauss–Newton block is the exact Hessian.
        let (spring, cg, _) = eval(&points, value);
        assert_eq!(spring.value, 0.0);
        assert_eq!(
            spring.curvature,
            SpringCurvature::GaussNewton {
                weight: 1.0 / alpha
            }
        );
        let mut block = vec![0.0; count * count];
        spring.block(&cg, dim, &mut block);
        worst_h = worst_h.max(jacobian_worst(&|x| eval(x, value).2, &points, &block, 1e-4));
        let p: Vec<f64> = (0..count).map(|_| rng.next()).collect();
        let mut y = vec![0.0; count];
        spring.apply(&cg, dim, &p, &mut y);
        let reference = mat_vec(&block, &p);
        let mut diagonal = vec![0.0; count];
        spring.diagonal(&cg, dim, &mut diagonal);
        let scale = max_abs(&block) * count as f64;
        for i in 0..count {
            assert!((y[i] - reference[i]).abs() <= 16.0 * EPS * scale * max_abs(&p));
            assert_eq!(diagonal[i], block[i * count + i]);
        }
        assert!(
            eigenvalues(&block, count)[0] >= -16.0 * EPS * scale,
            "{kind:?} N = {dim} k = {k}"
        );
    }
    bound(
        "measure spring gradient vs FD",
        worst_g,
        1.0,
        "Richardson + rounding model",
    );
    bound(
        "measure spring Gauss–Newton at C = 0 vs FD Hessian",
        worst_h,
        1.0,
        "exact there",
    );
}
