//! Expression springs (core's `expression_spring`, the coupled step's
//! term for expression families and bending): the distance written as an
//! expression has the built-in spring's energy, gradient and projected
//! curvature; the cosine bending spring's ∇E matches finite differences
//! and its K⁺ is the PSD projection of the finite-difference Hessian.

use super::*;
use hyperpbd::core::implicit::{
    ExpressionScratch, apply_dense, expression_curvature, expression_spring,
};
use hyperpbd::kinds::{BendingModel, ExpressionKind, Relation};

fn compiled(source: &str, relation: Relation, arity: usize, dim: usize) -> ExpressionKind {
    ExpressionKind::new("expression", source, &[], relation, arity, dim).expect("compiles")
}

/// (E, ∇E) of the spring at `x`.
fn energy_at(kind: &ExpressionKind, alpha: f64, rest: f64, x: &[f64]) -> (f64, Vec<f64>) {
    let mut gradient = vec![0.0; x.len()];
    let mut scratch = ExpressionScratch::default();
    let s = expression_spring(kind, 0, (alpha, rest), x, &mut gradient, &mut scratch);
    (s.energy, gradient)
}

/// K⁺ of the spring at `x` (n × n).
fn block_at(kind: &ExpressionKind, alpha: f64, rest: f64, x: &[f64]) -> Vec<f64> {
    let n = x.len();
    let mut block = vec![0.0; n * n];
    let mut scratch = ExpressionScratch::default();
    let ok = expression_curvature(kind, 0, (alpha, rest), x, &mut block, &mut scratch);
    assert!(ok, "finite block");
    block
}

#[test]
fn the_distance_expression_spring_is_the_built_in_spring() {
    let mut rng = Lcg(2901);
    let alpha = 0.01;
    let (mut worst_e, mut worst_g, mut worst_k) = (0.0f64, 0.0f64, 0.0f64);
    for dim in DIMS {
        for (kind, relation) in [
            (ConstraintKind::Distance, Relation::Equal),
            (ConstraintKind::Tether, Relation::AtMost),
        ] {
            let expression = compiled("norm(x1 - x0)", relation, 2, dim);
            for rest_factor in [0.7, 1.3] {
                let points = simplex(dim, 1, &mut rng);
                let length = (0..dim)
                    .map(|a| (points[dim + a] - points[a]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                let rest = rest_factor * length;
                let (mut cg, mut eg) = (vec![0.0; 2 * dim], vec![0.0; 2 * dim]);
                let spring = evaluate_spring(
                    kind,
                    alpha,
                    rest,
                    &points,
                    dim,
                    &mut cg,
                    &mut eg,
                    &mut Scratch::new(),
                );
                let mut builtin = vec![0.0; 4 * dim * dim];
                spring.block(&cg, dim, &mut builtin);
                let (energy, gradient) = energy_at(&expression, alpha, rest, &points);
                let block = block_at(&expression, alpha, rest, &points);
                let scale = length / alpha;
                worst_e = worst_e.max((energy - spring.energy).abs() / (scale * length).max(EPS));
                for i in 0..2 * dim {
                    worst_g = worst_g.max((gradient[i] - eg[i]).abs() / scale);
                }
                for (k, b) in block.iter().zip(&builtin) {
                    worst_k = worst_k.max((k - b).abs() * alpha);
                }
            }
        }
    }
    bound(
        "expression distance spring energy",
        worst_e,
        64.0 * EPS,
        "same C to rounding",
    );
    bound(
        "expression distance spring ∇E",
        worst_g,
        64.0 * EPS,
        "same ∇C to rounding",
    );
    bound(
        "expression distance spring K⁺ vs radial K⁺ ·α",
        worst_k,
        1e-12,
        "exact Hessian projected by Jacobi vs the radial clamp",
    );
}

/// A random hinge in R^dim: the edge x0x1, wings x2 and x3 folded by a
/// random angle.
fn hinge(dim: usize, rng: &mut Lcg) -> Vec<f64> {
    let q = rotation(dim, rng);
    let angle = 0.3 + 2.5 * rng.next().abs();
    let local = [
        [0.0, 0.0, 0.0],
        [1.0 + 0.1 * rng.next(), 0.0, 0.0],
        [0.4 + 0.1 * rng.next(), 1.0, 0.0],
        [0.6 + 0.1 * rng.next(), angle.cos(), angle.sin()],
    ];
    local
        .iter()
        .flat_map(|p| {
            let mut v = vec![0.0; dim];
            v[..3].copy_from_slice(p);
            mat_vec(&q, &v)
        })
        .collect()
}

#[test]
fn the_bending_spring_matches_finite_differences() {
    let mut rng = Lcg(2902);
    let alpha = 0.1;
    let (mut worst_g, mut worst_k, mut worst_apply) = (0.0f64, 0.0f64, 0.0f64);
    let models = [BendingModel::Cosine, BendingModel::Quadratic];
    for (dim, model) in [3, 4, 5].into_iter().flat_map(|d| models.map(|m| (d, m))) {
        for _ in 0..4 {
            let x = hinge(dim, &mut rng);
            let mut family = hyperpbd::ConstraintFamily::new(
                ConstraintKind::Bending,
                alpha,
                vec![vec![0, 1, 2, 3]],
            );
            family.model = Some(model);
            // The quadratic weights come from these (authored) positions.
            let bending =
                hyperpbd::kinds::expression_of(0, &family, 4, dim, |i| &x[i * dim..(i + 1) * dim])
                    .expect("compiles")
                    .expect("bending is an expression");
            // The cosine's rest value, the quadratic's (a norm: ≥ 0).
            let rest = match model {
                BendingModel::Cosine => 0.9,
                BendingModel::Quadratic => 0.05,
            };
            let n = x.len();
            let (_, gradient) = energy_at(&bending, alpha, rest, &x);
            worst_g = worst_g.max(jacobian_worst(
                &|y| vec![energy_at(&bending, alpha, rest, y).0],
                &x,
                &gradient,
                1e-4,
            ));
            // K⁺ against the projection of the central-difference Hessian
            // of E: the projection is 1-Lipschitz in the Frobenius norm, so
            // ‖P(H_h) − K⁺‖ ≤ ‖H_h − K‖ (the difference's error).
            let step = 1e-5;
            let mut fd = vec![0.0; n * n];
            let mut y = x.clone();
            for j in 0..n {
                y[j] = x[j] + step;
                let plus = energy_at(&bending, alpha, rest, &y).1;
                y[j] = x[j] - step;
                let minus = energy_at(&bending, alpha, rest, &y).1;
                y[j] = x[j];
                for i in 0..n {
                    fd[i * n + j] = (plus[i] - minus[i]) / (2.0 * step);
                }
            }
            for i in 0..n {
                for j in 0..i {
                    let mean = 0.5 * (fd[i * n + j] + fd[j * n + i]);
                    (fd[i * n + j], fd[j * n + i]) = (mean, mean);
                }
            }
            project_psd(&mut fd, n, &mut PsdScratch::new());
            let block = block_at(&bending, alpha, rest, &x);
            let norm = block.iter().map(|v| v * v).sum::<f64>().sqrt();
            let diff = (block.iter().zip(&fd))
                .map(|(a, b)| (a - b).powi(2))
                .sum::<f64>()
                .sqrt();
            worst_k = worst_k.max(diff / norm);
            let p: Vec<f64> = (0..n).map(|_| rng.next()).collect();
            let mut out = vec![0.0; n];
            apply_dense(&block, Some(&p), &mut out);
            let reference = mat_vec(&block, &p);
            let mut diagonal = vec![0.0; n];
            apply_dense(&block, None, &mut diagonal);
            for i in 0..n {
                worst_apply = worst_apply.max((out[i] - reference[i]).abs() / norm);
                assert_eq!(diagonal[i], block[i * n + i]);
            }
            let w = eigenvalues(&block, n);
            assert!(w[0] >= -1e-12 * norm, "K⁺ not PSD: {w:?}");
        }
    }
    bound(
        "bending spring ∇E vs FD",
        worst_g,
        1.0,
        "Richardson + rounding model",
    );
    bound(
        "bending spring K⁺ vs P(FD Hessian), relative",
        worst_k,
        1e-5,
        "central difference h = 1e-5: O(h²) + O(ε/h)",
    );
    bound(
        "dense apply vs mat_vec",
        worst_apply,
        64.0 * EPS,
        "same sums",
    );
}

#[test]
fn an_inactive_one_sided_expression_spring_has_no_energy_and_no_curvature() {
    let expression = compiled("norm(x1 - x0)", Relation::AtMost, 2, 2);
    let x = [0.0, 0.0, 0.5, 0.0];
    let (energy, gradient) = energy_at(&expression, 0.01, 1.0, &x);
    assert_eq!(energy, 0.0);
    assert!(gradient.iter().all(|&g| g == 0.0));
    assert!(
        block_at(&expression, 0.01, 1.0, &x)
            .iter()
            .all(|&k| k == 0.0)
    );
    // ∇C undefined (coincident points): no response, never a NaN.
    let equal = compiled("norm(x1 - x0)", Relation::Equal, 2, 2);
    let (energy, gradient) = energy_at(&equal, 0.01, 1.0, &[0.0; 4]);
    assert_eq!(energy, 1.0 / 0.02);
    assert!(gradient.iter().all(|&g| g == 0.0), "{gradient:?}");
    assert!(
        block_at(&equal, 0.01, 1.0, &[0.0; 4])
            .iter()
            .all(|&k| k == 0.0)
    );
}

#[test]
fn springs_through_min_max_and_abs_match_finite_differences() {
    // Selects route each adjoint into the branch taken: ∇E against the
    // energy's finite differences, away from the ties (random points).
    let mut rng = Lcg(2903);
    let alpha = 0.05;
    let expression = compiled(
        "min(norm(x1 - x0), 2 * norm(x2 - x0)) + max(x1[0], x2[1]) - abs(x2[2] - x0[0])",
        Relation::Equal,
        3,
        3,
    );
    let mut worst: f64 = 0.0;
    for _ in 0..24 {
        let x: Vec<f64> = (0..9).map(|_| rng.next()).collect();
        let (_, gradient) = energy_at(&expression, alpha, 0.3, &x);
        worst = worst.max(jacobian_worst(
            &|y| vec![energy_at(&expression, alpha, 0.3, y).0],
            &x,
            &gradient,
            1e-5,
        ));
    }
    bound(
        "min/max/abs spring ∇E vs FD",
        worst,
        1.0,
        "Richardson + rounding model",
    );
}
