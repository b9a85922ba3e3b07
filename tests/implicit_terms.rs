//! The terms of the coupled implicit step (`hyperpbd::core::implicit`),
//! checked on their own (no backend): finite-difference gradients and
//! Hessians of springs, materials, the ball–ball barrier and lagged
//! friction in N = 1..4 and 8; PSD projection; the block reduction tree;
//! preconditioned CG on known SPD systems; the certified step filters
//! against exact rational arithmetic (near touching, far from the origin);
//! friction regimes; the closed forms. Every bound prints as
//! `BOUND | name | measured | bound | rationale`.
//!
//! ```text
//! central differences of a vector function f, step h, coordinate i:
//!   D_h = (f(x + h e_i) − f(x − h e_i)) / 2h,  D_2h likewise
//!   truncation of D_h ≈ (D_2h − D_h)/3 (Richardson), taken ×4;  rounding 1.5 δf/h, taken ×2
//!   tolerance = (4/3)|D_2h − D_h| + 3 δf/h
//! δf (rounding of one evaluation): 64 n ε (|f|∞ + |∇f|∞ |x|∞), n the coordinate count
//! ```

// Index loops mirror the math they check.
#![allow(clippy::needless_range_loop)]

mod common;

use common::Lcg;
use hyperpbd::ConstraintKind;
use hyperpbd::core::barrier::{BarrierLaw, BarrierObstacles, SIMPLEX_SLOTS, filter_fraction};
use hyperpbd::core::implicit::certified_filter::{
    fraction, obstacle_time, pair_time, plane_time, simplex_time,
};
use hyperpbd::core::implicit::closed_forms::{
    backward_euler_slide, barrier_gap_under_load, hanging_chain_stretch, incline_acceleration,
    stacked_ball_heights, sticking_creep_speed,
};
use hyperpbd::core::implicit::{
    FrictionRegime, MaterialHessianScratch, PcgSettings, PcgStatus, PcgWorkspace, PsdScratch,
    RadialCurvature, SpringCurvature, ball_pair_barrier, block_tree_max, block_tree_sum,
    evaluate_spring, material_curvature_diagonal, material_hessian_block, material_term, mollifier,
    normal_force, obstacle_friction, pair_friction, pcg, project_psd, tree_dot,
};
use hyperpbd::core::material::{Law, Material, MaterialScratch, RestView, rest_element};
use hyperpbd::geometry::Scratch;
use num_rational::BigRational;

const EPS: f64 = f64::EPSILON;
const DIMS: [usize; 5] = [1, 2, 3, 4, 8];

fn bound(name: &str, measured: f64, limit: f64, why: &str) {
    println!("BOUND | {name} | {measured:.3e} | {limit:.3e} | {why}");
    assert!(
        measured <= limit,
        "{name}: {measured:e} > {limit:e} ({why})"
    );
}

fn max_abs(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// Worst |D_h − J| / tolerance over every entry of the Jacobian `jac`
/// (rows = outputs of f, columns = coordinates of x; module docs).
fn jacobian_worst(f: &dyn Fn(&[f64]) -> Vec<f64>, x: &[f64], jac: &[f64], h: f64) -> f64 {
    let n = x.len();
    let f0 = f(x);
    let m = f0.len();
    let delta_f = 64.0 * n as f64 * EPS * (max_abs(&f0) + max_abs(jac) * max_abs(x).max(1.0));
    let mut y = x.to_vec();
    let mut at = |i: usize, step: f64| {
        y[i] = x[i] + step;
        let v = f(&y);
        y[i] = x[i];
        v
    };
    let mut worst: f64 = 0.0;
    for i in 0..n {
        let (p1, m1, p2, m2) = (at(i, h), at(i, -h), at(i, 2.0 * h), at(i, -2.0 * h));
        for r in 0..m {
            let d1 = (p1[r] - m1[r]) / (2.0 * h);
            let d2 = (p2[r] - m2[r]) / (4.0 * h);
            let tolerance = 4.0 / 3.0 * (d2 - d1).abs() + 3.0 * delta_f / h;
            worst = worst.max((d1 - jac[r * n + i]).abs() / tolerance);
        }
    }
    worst
}

/// Eigenvalues (ascending) of the symmetric row-major n × n `a` (nalgebra).
fn eigenvalues(a: &[f64], n: usize) -> Vec<f64> {
    let m = nalgebra::DMatrix::from_row_slice(n, n, a);
    let mut w: Vec<f64> = nalgebra::SymmetricEigen::new(m)
        .eigenvalues
        .iter()
        .copied()
        .collect();
    w.sort_by(f64::total_cmp);
    w
}

/// y = A x, A row-major with `x.len()` columns.
fn mat_vec(a: &[f64], x: &[f64]) -> Vec<f64> {
    let n = x.len();
    a.chunks(n)
        .map(|row| row.iter().zip(x).map(|(p, q)| p * q).sum())
        .collect()
}

/// A random orthogonal n × n matrix (the Q of a QR factorisation), row-major.
fn rotation(n: usize, rng: &mut Lcg) -> Vec<f64> {
    let m = nalgebra::DMatrix::from_fn(n, n, |_, _| rng.next())
        + nalgebra::DMatrix::identity(n, n) * 2.0;
    let q = m.qr().q();
    (0..n * n).map(|i| q[(i / n, i % n)]).collect()
}

fn unit(dim: usize, rng: &mut Lcg) -> Vec<f64> {
    loop {
        let v: Vec<f64> = (0..dim).map(|_| rng.next()).collect();
        let len = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if len > 0.1 {
            return v.iter().map(|x| x / len).collect();
        }
    }
}

/// A well-shaped k-simplex in R^dim around a random origin: vertex j is
/// origin + Q (e_j + jitter) (e_0 = 0) for a random rotation Q.
fn simplex(dim: usize, k: usize, rng: &mut Lcg) -> Vec<f64> {
    let rotate = rotation(dim, rng);
    let origin: Vec<f64> = (0..dim).map(|_| 0.5 * rng.next()).collect();
    (0..=k)
        .flat_map(|j| {
            let local: Vec<f64> = (0..dim)
                .map(|a| {
                    if a < k {
                        0.2 * rng.next() + f64::from(u8::from(j == a + 1))
                    } else {
                        0.0
                    }
                })
                .collect();
            let rotated = mat_vec(&rotate, &local);
            rotated
                .iter()
                .zip(&origin)
                .map(|(x, o)| x + o)
                .collect::<Vec<f64>>()
        })
        .collect()
}

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

/// The rest data and a deformed state of one element.
fn material_case(dim: usize, k: usize, amount: f64, rng: &mut Lcg) -> (Vec<f64>, f64, Vec<f64>) {
    let rest = simplex(dim, k, rng);
    let mut frame = vec![0.0; k * k];
    let measure = rest_element(&rest, dim, &mut frame, &mut MaterialScratch::new()).expect("rest");
    let mut a: Vec<f64> = (0..dim * dim).map(|_| amount * rng.next()).collect();
    for i in 0..dim {
        a[i * dim + i] += 1.0;
    }
    let mut x = Vec::new();
    for point in rest.chunks(dim) {
        x.extend(mat_vec(&a, point).iter().map(|v| v + 0.01 * rng.next()));
    }
    (frame, measure, x)
}

#[test]
fn material_hessians_match_finite_differences_and_project_in_frame_coordinates() {
    let mut rng = Lcg(1603);
    let (mut worst_h, mut worst_psd, mut worst_diag) = (0.0f64, 0.0f64, 0.0f64);
    let (mut clipped_cases, mut kept_cases) = (0, 0);
    for law in [Law::StVenantKirchhoff, Law::NeoHookean] {
        for dim in [1, 2, 3, 4, 8] {
            let mut orders = vec![1, dim];
            if dim >= 3 {
                orders.push(2);
            }
            orders.dedup();
            for k in orders {
                for amount in [0.02, 0.35] {
                    let material = Material::new(law, k, 5.0, 0.3 / k as f64).expect("material");
                    let (frame, measure, x) = material_case(dim, k, amount, &mut rng);
                    let rest = RestView {
                        frame: &frame,
                        measure,
                    };
                    let count = (k + 1) * dim;
                    let size = dim * k;
                    let mut hs = MaterialHessianScratch::new();
                    let term = |y: &[f64], hf: &mut Vec<f64>| {
                        let mut g = vec![0.0; count];
                        hf.resize(size * size, 0.0);
                        let mut s = MaterialScratch::new();
                        let mut h = MaterialHessianScratch::new();
                        material_term(&material, y, dim, rest, &mut g, hf, &mut s, &mut h)
                            .map(|_| g)
                    };
                    let mut frame_hessian = Vec::new();
                    let Ok(_) = term(&x, &mut frame_hessian) else {
                        continue;
                    };
                    let mut exact = vec![0.0; count * count];
                    material_hessian_block(&frame_hessian, rest, dim, k + 1, &mut exact, &mut hs);
                    let gradient = |y: &[f64]| term(y, &mut Vec::new()).expect("law");
                    worst_h = worst_h.max(jacobian_worst(&gradient, &x, &exact, 1e-4));
                    // Project H_F; the vertex block is PSD; unchanged when PSD.
                    let mut projected = frame_hessian.clone();
                    let report = project_psd(&mut projected, size, &mut PsdScratch::new());
                    assert!(report.finite && report.eigen.converged, "{report:?}");
                    if report.clipped == 0 {
                        kept_cases += 1;
                        assert_eq!(projected, frame_hessian);
                    } else {
                        clipped_cases += 1;
                    }
                    let mut block = vec![0.0; count * count];
                    material_hessian_block(&projected, rest, dim, k + 1, &mut block, &mut hs);
                    let scale = max_abs(&block).max(1e-300);
                    worst_psd = worst_psd.max(-eigenvalues(&block, count)[0] / scale);
                    let mut diagonal = vec![0.0; count];
                    material_curvature_diagonal(&projected, rest, dim, &mut diagonal, &mut hs);
                    for i in 0..count {
                        worst_diag =
                            worst_diag.max((diagonal[i] - block[i * count + i]).abs() / scale);
                    }
                }
            }
        }
    }
    println!("material cases: {kept_cases} PSD as is, {clipped_cases} clipped");
    assert!(
        kept_cases > 0 && clipped_cases > 0,
        "both branches must be exercised"
    );
    bound(
        "material exact Hessian vs FD",
        worst_h,
        1.0,
        "Richardson + rounding model",
    );
    bound(
        "material projected block min eigenvalue / max entry",
        worst_psd,
        1e-13,
        "PSD to rounding (Nk ≤ 64)",
    );
    bound(
        "material diagonal vs dense / max entry",
        worst_diag,
        1e-13,
        "same sums, other order",
    );
}

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

/// The halving tree of one block, written recursively (reference).
fn halving(mut s: Vec<f64>, op: fn(f64, f64) -> f64) -> f64 {
    if s.len() == 1 {
        return s[0];
    }
    let half = s.len() / 2;
    let next: Vec<f64> = (0..half).map(|t| op(s[t], s[t + half])).collect();
    s.truncate(0);
    halving(next, op)
}

fn reference_tree(values: &[f64], pad: f64, op: fn(f64, f64) -> f64) -> f64 {
    if values.is_empty() {
        return pad;
    }
    let partials: Vec<f64> = values
        .chunks(64)
        .map(|c| {
            let mut s = c.to_vec();
            s.resize(64, pad);
            halving(s, op)
        })
        .collect();
    if partials.len() == 1 {
        partials[0]
    } else {
        reference_tree(&partials, pad, op)
    }
}

#[test]
fn block_reduction_tree_is_the_documented_one() {
    let mut rng = Lcg(1606);
    let mut scratch = Vec::new();
    for n in [
        0, 1, 2, 63, 64, 65, 127, 128, 129, 4095, 4096, 4097, 300_001,
    ] {
        let values: Vec<f64> = (0..n).map(|_| rng.next() * 10f64.powi(n % 7)).collect();
        let sum = block_tree_sum(&values, &mut scratch);
        assert_eq!(
            sum.to_bits(),
            reference_tree(&values, 0.0, |a, b| a + b).to_bits(),
            "n = {n}"
        );
        let abs: Vec<f64> = values.iter().map(|v| v.abs()).collect();
        let max = block_tree_max(&abs, &mut scratch);
        assert_eq!(max, abs.iter().fold(0.0f64, |m, v| m.max(*v)));
        let levels = (n.max(2) as f64).log2().ceil() + 6.0;
        let exact: f64 = values.iter().map(|v| v.abs()).sum();
        let naive: f64 = values.iter().sum();
        assert!(
            (sum - naive).abs() <= 2.0 * levels * EPS * exact + 1e-300,
            "n = {n}"
        );
    }
    let a: Vec<f64> = (0..30).map(|i| i as f64).collect();
    let dot = tree_dot(&a, &a, 3, &mut Vec::new(), &mut scratch);
    assert_eq!(dot, (0..30).map(|i| (i * i) as f64).sum::<f64>());
}

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

fn q(x: f64) -> BigRational {
    BigRational::from_float(x).expect("finite")
}

/// Exact |y_j − y_i|² − (r_i + r_j)².
fn exact_pair_gap(yi: &[f64], yj: &[f64], radii: (f64, f64)) -> BigRational {
    let mut s = q(0.0);
    for a in 0..yi.len() {
        let e = q(yj[a]) - q(yi[a]);
        s += &e * &e;
    }
    let r = q(radii.0) + q(radii.1);
    s - &r * &r
}

/// fl(x + fl(t Δ)), the trial point of the documented formula.
fn trial(x: &[f64], delta: &[f64], t: f64) -> Vec<f64> {
    x.iter().zip(delta).map(|(x, d)| x + t * d).collect()
}

/// Trial fractions a line search may use from the filter fraction `t`.
fn trial_fractions(t: f64, rng: &mut Lcg) -> Vec<f64> {
    let mut ts = vec![t, t * (1.0 - EPS), t * 0.5, t * 0.25];
    ts.push(t * 0.5 * (1.0 + rng.next()));
    ts
}

#[test]
fn pair_filter_never_admits_contact_in_exact_arithmetic() {
    let mut rng = Lcg(1608);
    let (mut trials, mut admitted, mut violations, mut uncertified_violations) =
        (0u32, 0u32, 0u32, 0u32);
    let (mut worst_tightness, mut tightness_cases) = (0.0f64, 0u32);
    for case in 0..4000 {
        let dim = DIMS[case % DIMS.len()];
        let far = 10f64.powi([0, 3, 6, 9, 12][(case / 5) % 5]);
        let n = unit(dim, &mut rng);
        let center: Vec<f64> = (0..dim).map(|_| far * rng.next()).collect();
        let radii = (0.5 + 0.4 * rng.next(), 0.5 + 0.4 * rng.next());
        let rounding = (dim as f64 + 4.0) * EPS * (far + 2.0) * 4.0;
        let gap = rounding * 10f64.powf(6.0 * rng.next());
        let xi = center.clone();
        let xj: Vec<f64> = (0..dim)
            .map(|a| xi[a] + (radii.0 + radii.1 + gap) * n[a])
            .collect();
        if exact_pair_gap(&xi, &xj, radii) <= q(0.0) {
            continue;
        }
        let speed = gap * 10f64.powf(3.0 * rng.next());
        let mut steps = Vec::new();
        for side in [1.0, -1.0] {
            let tangent = unit(dim, &mut rng);
            steps.extend((0..dim).map(|a| speed * (side * 0.5 * n[a] + 0.5 * tangent[a])));
        }
        let mut points = xi.clone();
        points.extend(&xj);
        let t = fraction(pair_time(&points, radii, &steps, dim, EPS));
        // Uncertified control: the computed distance and approach alone.
        let length = (0..dim)
            .map(|a| (xj[a] - xi[a]).powi(2))
            .sum::<f64>()
            .sqrt();
        let d0 = length - radii.0 - radii.1;
        let closing: f64 = (0..dim)
            .map(|a| -(xj[a] - xi[a]) / length * (steps[dim + a] - steps[a]))
            .sum();
        let naive = if closing > 0.0 {
            (0.9 * d0 / closing).min(1.0)
        } else {
            1.0
        };
        let yi = trial(&xi, &steps[..dim], naive);
        let yj = trial(&xj, &steps[dim..], naive);
        if exact_pair_gap(&yi, &yj, radii) <= q(0.0) {
            uncertified_violations += 1;
        }
        if t > 0.0 {
            admitted += 1;
            if d0 > 1e3 * rounding && closing > 0.0 && naive < 1.0 {
                // The certified cut costs the stated rounding and no more:
                // 1 − t/t_naive ≤ δd/d0 + γ|δ|/closing (first order).
                let gamma = (dim as f64 + 4.0) * EPS;
                let norm = |v: &[f64]| max_abs(v);
                let delta_d = gamma * (length + radii.0 + radii.1)
                    + dim as f64
                        * EPS
                        * (norm(&xi)
                            + norm(&xj)
                            + 2.0 * norm(&steps[..dim])
                            + 2.0 * norm(&steps[dim..]));
                let relative: f64 = (0..dim)
                    .map(|a| (steps[dim + a] - steps[a]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                let predicted = delta_d / d0 + gamma * relative / closing;
                tightness_cases += 1;
                worst_tightness = worst_tightness.max((1.0 - t / naive) / predicted);
            }
        }
        for s in trial_fractions(t, &mut rng) {
            trials += 1;
            let yi = trial(&xi, &steps[..dim], s);
            let yj = trial(&xj, &steps[dim..], s);
            if exact_pair_gap(&yi, &yj, radii) <= q(0.0) {
                violations += 1;
            }
        }
    }
    println!(
        "pair filter: {trials} trials, {admitted} cases admitted motion, {tightness_cases} far from contact; uncertified control violated {uncertified_violations}"
    );
    assert!(
        admitted > 1000 && tightness_cases > 100,
        "the certificate must not be vacuous"
    );
    assert!(
        uncertified_violations > 0,
        "the cases must be hard enough to defeat an uncertified filter"
    );
    bound(
        "pair filter: trials with exact d ≤ 0",
        violations as f64,
        0.0,
        "certified in floating point",
    );
    bound(
        "pair filter: (1 − t/t_uncertified) / (δd/d0 + γ|δ|/closing)",
        worst_tightness,
        1.01,
        "the cut is the stated rounding",
    );
}

/// Exact squared distance from p to the simplex `vertices` (rational
/// enumeration of faces: Gram solve, λ ≥ 0, minimum).
fn exact_simplex_distance_squared(p: &[f64], vertices: &[f64], dim: usize) -> BigRational {
    let count = vertices.len() / dim;
    let v = |j: usize, a: usize| q(vertices[j * dim + a]);
    let mut best: Option<BigRational> = None;
    for face in 1u32..(1 << count) {
        let members: Vec<usize> = (0..count).filter(|j| face & (1 << j) != 0).collect();
        let anchor = members[0];
        let rest = &members[1..];
        let m = rest.len();
        let mut g = vec![vec![q(0.0); m + 1]; m];
        for (s, &js) in rest.iter().enumerate() {
            for (t, &jt) in rest.iter().enumerate() {
                g[s][t] = (0..dim)
                    .map(|a| (v(js, a) - v(anchor, a)) * (v(jt, a) - v(anchor, a)))
                    .sum();
            }
            g[s][m] = (0..dim)
                .map(|a| (v(js, a) - v(anchor, a)) * (q(p[a]) - v(anchor, a)))
                .sum();
        }
        let mut singular = false;
        for c in 0..m {
            let Some(pivot_row) = (c..m).find(|&r| g[r][c] != q(0.0)) else {
                singular = true;
                break;
            };
            g.swap(c, pivot_row);
            for r in 0..m {
                if r != c {
                    let factor = g[r][c].clone() / g[c][c].clone();
                    for col in c..=m {
                        let sub = factor.clone() * g[c][col].clone();
                        g[r][col] -= sub;
                    }
                }
            }
        }
        if singular {
            continue;
        }
        let mu: Vec<BigRational> = (0..m).map(|s| g[s][m].clone() / g[s][s].clone()).collect();
        let anchor_weight = q(1.0) - mu.iter().cloned().sum::<BigRational>();
        if anchor_weight < q(0.0) || mu.iter().any(|x| *x < q(0.0)) {
            continue;
        }
        let mut d2 = q(0.0);
        for a in 0..dim {
            let mut r = q(p[a]) - anchor_weight.clone() * v(anchor, a);
            for (s, &js) in rest.iter().enumerate() {
                r -= mu[s].clone() * v(js, a);
            }
            d2 += &r * &r;
        }
        if best.as_ref().is_none_or(|b| d2 < *b) {
            best = Some(d2);
        }
    }
    best.expect("the closest vertex is always a candidate")
}

#[test]
fn obstacle_filters_are_certified_for_planes_and_simplices() {
    let mut rng = Lcg(1609);
    let (mut trials, mut admitted, mut violations, mut uncertified_violations) =
        (0u32, 0u32, 0u32, 0u32);
    for case in 0..1500 {
        let dim = [1, 2, 3, 4][case % 4];
        let far = 10f64.powi([0, 3, 6, 9][(case / 4) % 4]);
        let radius = 0.3 + 0.2 * rng.next();
        let normal = unit(dim, &mut rng);
        let mut obstacles = BarrierObstacles {
            plane_normals: normal.clone(),
            plane_offsets: vec![far * rng.next()],
            plane_source: vec![0],
            ..BarrierObstacles::default()
        };
        // A simplex (segment / triangle / tetrahedron, arity ≤ dim + 1) near the plane.
        let arity = (2 + case % 3).min(dim + 1);
        let base: Vec<f64> = (0..dim)
            .map(|a| normal[a] * obstacles.plane_offsets[0] + far * 1e-3 * rng.next())
            .collect();
        let mut vertices = Vec::new();
        for slot in 0..SIMPLEX_SLOTS {
            if slot < arity {
                vertices.extend(
                    (0..dim).map(|a| base[a] + rng.next() + if a + 1 == slot { 1.0 } else { 0.0 }),
                );
            } else {
                vertices.extend(std::iter::repeat_n(0.0, dim));
            }
        }
        obstacles.simplex_vertices = vertices;
        obstacles.simplex_arity = vec![arity as u32];
        obstacles.simplex_source = vec![(1, 0)];
        let rounding = (dim as f64 + 4.0) * EPS * (far + 4.0) * 8.0;
        let gap = rounding * 10f64.powf(3.0 * rng.next());
        // A particle just off the plane, or just off the simplex.
        let mut offset = vec![0.0; dim];
        let x: Vec<f64> = if case % 2 == 0 {
            (0..dim)
                .map(|a| base[a] + normal[a] * (radius + gap) + 0.0)
                .collect()
        } else {
            let simplex = obstacles.simplex(0, dim).to_vec();
            let centroid: Vec<f64> = (0..dim)
                .map(|a| (0..arity).map(|j| simplex[j * dim + a]).sum::<f64>() / arity as f64)
                .collect();
            let away = unit(dim, &mut rng);
            let mut x: Vec<f64> = (0..dim).map(|a| centroid[a] + 2.0 * away[a]).collect();
            let d = hyperpbd::geometry::closest_point_on_simplex(&x, &simplex, dim, &mut offset)
                .distance;
            for a in 0..dim {
                x[a] -= offset[a] / d * (d - radius - gap);
            }
            x
        };
        let side = (0..dim)
            .map(|a| q(normal[a]) * q(x[a]))
            .sum::<BigRational>()
            - q(obstacles.plane_offsets[0])
            - q(radius);
        if side <= q(0.0) {
            obstacles.plane_normals.iter_mut().for_each(|c| *c = -*c);
            obstacles.plane_offsets[0] = -obstacles.plane_offsets[0] - 1e3 * far.max(1.0);
        }
        let normal = obstacles.plane_normals.clone();
        let simplex_gap = |y: &[f64]| -> BigRational {
            exact_simplex_distance_squared(y, obstacles.simplex(0, dim), dim)
                - q(radius) * q(radius)
        };
        let plane_gap = |y: &[f64]| -> BigRational {
            (0..dim)
                .map(|a| q(normal[a]) * q(y[a]))
                .sum::<BigRational>()
                - q(obstacles.plane_offsets[0])
                - q(radius)
        };
        if plane_gap(&x) <= q(0.0) || simplex_gap(&x) <= q(0.0) {
            continue;
        }
        let speed = gap * 10f64.powf(3.0 * rng.next());
        let toward = unit(dim, &mut rng);
        let delta: Vec<f64> = (0..dim)
            .map(|a| speed * (toward[a] - 0.7 * normal[a]))
            .collect();
        let uncertified = filter_fraction(&obstacles, &x, radius, &delta);
        let y = trial(&x, &delta, uncertified);
        if plane_gap(&y) <= q(0.0) || simplex_gap(&y) <= q(0.0) {
            uncertified_violations += 1;
        }
        let t = fraction(obstacle_time(&obstacles, &x, radius, &delta, EPS));
        let single = plane_time(&obstacles, 0, &x, radius, &delta, EPS).min(simplex_time(
            &obstacles,
            0,
            &x,
            radius,
            &delta,
            EPS,
            &mut offset,
        ));
        assert_eq!(fraction(single), t);
        if t > 0.0 {
            admitted += 1;
        }
        for s in trial_fractions(t, &mut rng) {
            trials += 1;
            let y = trial(&x, &delta, s);
            if plane_gap(&y) <= q(0.0) || simplex_gap(&y) <= q(0.0) {
                violations += 1;
            }
        }
    }
    println!(
        "obstacle filter: {trials} trials, {admitted} cases admitted motion; barrier::filter_fraction violated {uncertified_violations}"
    );
    assert!(admitted > 300, "the certificate must not be vacuous");
    assert!(
        uncertified_violations > 0,
        "the cases must be hard enough to defeat the uncertified filter"
    );
    bound(
        "obstacle filter: trials with exact d ≤ 0",
        violations as f64,
        0.0,
        "certified in floating point",
    );
}

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

#[test]
fn closed_forms_are_consistent_with_the_terms() {
    let law = BarrierLaw {
        stiffness: 1e4,
        activation_distance: 0.01,
    };
    let gap = barrier_gap_under_load(&law, 9.81).expect("gap");
    let force = normal_force(&law, gap);
    bound(
        "barrier gap under load: |−b'(d) − W| / W",
        (force - 9.81).abs() / 9.81,
        1e-9,
        "bisection to adjacent floats",
    );
    let heights = stacked_ball_heights(&law, 0.0, 0.5, 1.0, 9.81, 10).expect("stack");
    assert!(
        heights
            .windows(2)
            .all(|w| w[1] - w[0] > 1.0 && w[1] - w[0] < 1.0 + 0.01)
    );
    // Lower contacts carry more, so they sit closer.
    assert!(heights[1] - heights[0] - 1.0 < heights[9] - heights[8] - 1.0);
    let stretch = hanging_chain_stretch(&[1.0, 1e-6, 1.0, 1e-6], 1e-8, 9.81);
    assert_eq!(stretch[3], 1e-8 * 9.81 * 1e-6);
    assert!((stretch[0] - 1e-8 * 9.81 * (2.0 + 2e-6)).abs() < 1e-22);
    let a = incline_acceleration(9.81, 0.5, 0.2);
    let s = backward_euler_slide(a, 1.0 / 60.0, 60);
    bound(
        "backward Euler slide vs ½at², 1 s at 60 Hz",
        s / (0.5 * a) - 1.0,
        1.0 / 60.0 + 1e-12,
        "h/t exactly",
    );
    // The creep speed puts the sticking force at the load: μλ f₁(y) = m g sin θ.
    let (mu, theta, slip_velocity, h) = (0.8, 0.4, 1e-3, 1.0 / 60.0);
    let speed = sticking_creep_speed(slip_velocity, theta, mu).expect("sticks");
    let (_, f1, _) = mollifier(speed * h, slip_velocity * h);
    bound(
        "creep: μ f₁(y) cos θ − sin θ",
        (mu * f1 * libm::cos(theta) - libm::sin(theta)).abs(),
        1e-12,
        "steady sticking slip",
    );
    assert!(sticking_creep_speed(slip_velocity, 0.9, 0.5).is_none());
}
