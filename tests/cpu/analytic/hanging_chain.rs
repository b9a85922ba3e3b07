//! A hanging chain converges to its compliant equilibrium.

use super::*;

/// Per-link (stretch_k − α T_k) / (α T_0) after settling, and the largest
/// position change over the final second.
fn hanging_chain_error(iterations: u32, alpha: f64, count: usize, mass: f64) -> (Vec<f64>, f64) {
    hanging_chain_error_with(iterations, alpha, count, mass, false)
}

/// [`hanging_chain_error`] with the standard update or, with
/// `primal_residual`, the update that carries the primal residual.
fn hanging_chain_error_with(
    iterations: u32,
    alpha: f64,
    count: usize,
    mass: f64,
    primal_residual: bool,
) -> (Vec<f64>, f64) {
    let dt = 1.0 / 60.0;
    let link = 0.1;
    let mut b = SceneBuilder::new(3)
        .dt(dt)
        .substeps(10)
        .iterations(iterations)
        .gravity_along(1, G)
        .damping(3.0);
    b.chain(&ChainSpec {
        start: vec![0.2, 1.5, -0.1],
        direction: vec![0.0, -1.0, 0.0],
        count: count + 1,
        spacing: link,
        mass,
        compliance: alpha,
        fix_first: true,
    });
    b.scene_mut().solver = hyperpbd::Solver::Xpbd(hyperpbd::XpbdSettings { primal_residual });
    let scene = b.build().expect("valid scene");
    let rest: Vec<f64> = (0..count)
        .map(|k| {
            norm(&sub(
                &scene.particles[k + 1].position,
                &scene.particles[k].position,
            ))
        })
        .collect();
    let mut sim = backend(&scene);
    let (settle_steps, final_window) = (600, 60);
    let mut before = State::from_scene(&scene);
    for k in 0..settle_steps {
        if k == settle_steps - final_window {
            before = state(&mut sim);
        }
        step(&mut sim);
    }
    let st = state(&mut sim);
    assert!(all_finite(&st));
    let drift = max_abs(&sub(&st.positions, &before.positions));
    let top = alpha * mass * G * count as f64;
    let errors = (0..count)
        .map(|k| {
            let stretch = norm(&sub(st.position(k + 1), st.position(k))) - rest[k];
            // Tension in link k: the weight of the count − k particles below.
            let tension = mass * G * (count - k) as f64;
            (stretch - alpha * tension) / top
        })
        .collect();
    (errors, drift)
}

/// The exact fixed point of K Gauss–Seidel sweeps per substep for the
/// vertical chain (see the test below): predicted (s − s*) / (α T_0) per
/// link.
fn hanging_chain_prediction(
    k: u32,
    alpha_tilde: f64,
    w: f64,
    h: f64,
    count: usize,
    mass: f64,
) -> Vec<f64> {
    use nalgebra::{DMatrix, DVector};
    // A = J W Jᵀ + α~ I for links (k, k+1), particle 0 fixed.
    let mut a = DMatrix::<f64>::zeros(count, count);
    for i in 0..count {
        a[(i, i)] = if i == 0 { w } else { 2.0 * w } + alpha_tilde;
        if i + 1 < count {
            a[(i, i + 1)] = -w;
            a[(i + 1, i)] = -w;
        }
    }
    // One sweep with b = 0 in the plan's color order (even links, then odd)
    // is the linear map G; build it column by column.
    let order: Vec<usize> = (0..count).step_by(2).chain((1..count).step_by(2)).collect();
    let mut g = DMatrix::<f64>::zeros(count, count);
    for j in 0..count {
        let mut l = DVector::<f64>::zeros(count);
        l[j] = 1.0;
        for &i in &order {
            let r = -(a.row(i) * &l)[(0, 0)];
            l[i] += r / a[(i, i)];
        }
        g.set_column(j, &l);
    }
    let gk = g.pow(k);
    let identity = DMatrix::<f64>::identity(count, count);
    let inv = (identity - &gk)
        .try_inverse()
        .unwrap_or_else(|| panic!("I − G^K singular"));
    let a_inv = a
        .clone()
        .try_inverse()
        .unwrap_or_else(|| panic!("A singular"));
    // s* = α T (stretches), d = C(x_pred) − C(p) = h² g on the top link.
    let alpha = alpha_tilde * h * h;
    let s_star = DVector::from_fn(count, |i, _| alpha * mass * G * (count - i) as f64);
    let mut d = DVector::<f64>::zeros(count);
    d[0] = h * h * G;
    let s = &a * inv * a_inv * (&s_star + &d) - &d;
    let top = s_star[0];
    (s - s_star).iter().map(|e| e / top).collect()
}

/// A vertical chain (fixed top, N = 8 particles of mass m, links of
/// compliance α) with damping settles at XPBD's compliant equilibrium
/// stretch_k = α·T_k, T_k = m g (N − k); the error against it shrinks as
/// the iteration count grows, and matches the exact fixed point of K
/// Gauss–Seidel sweeps per substep.
///
/// The chain is collinear and vertical, so each substep's projection is
/// exactly linear: Gauss–Seidel on (J W Jᵀ + α~ I) λ = −C(x_pred), a
/// tridiagonal matrix A with diagonal 2w + α~ (w + α~ for the top link) and
/// off-diagonals −w, swept in the plan's color order (even links, then odd).
/// At the static fixed point the final multipliers must balance gravity
/// (λ_K = λ_g, with s* = −α~ λ_g = α T), and K sweeps from λ = 0 give
/// λ_K = (I − G^K) A⁻¹ b, so the fixed point's stretches s satisfy
///
/// ```text
/// s + d = A (I − G^K)⁻¹ A⁻¹ (s* + d)       d = h²g e_0 (prediction on link 0)
/// s − s* = −A (I − G^K)⁻¹ G^K λ_g
/// ‖G‖∞ ≤ β = 2w/(2w + α~)                  (diagonally dominant, red-black order)
/// ‖s − s*‖∞ / s*_max ≤ (4w + α~)/α~ · β^K/(1 − β^K)
/// ```
/// Here w = 10, α~ = α/h² = 9, β ≈ 0.69: the norm bound is informative only
/// at K = 16 (≈ 1.4e-2). Three checks per K:
///
/// 1. measured error ≤ the norm bound (and errors decrease strictly with K);
/// 2. measured error vector = the exact fixed point above (computed here
///    with nalgebra) to rounding: the stretch is a difference of
///    coordinates of size X ≤ 1.5 m, each a few ulps off, and the fixed
///    point of a map contracting at least by e^{−r h} per substep (damping)
///    amplifies per-substep rounding by at most 1/(1 − e^{−r h}) ≈ 200:
///    bound 4u·X·200 / (α T_0) ≈ 7e-10 relative;
/// 3. settled: ten seconds with damping 3/s leave the transient at e^{-30};
///    position change over the final second ≤ 1e-3 of the top link's
///    equilibrium stretch.
#[test]
fn hanging_chain_converges_to_compliant_equilibrium() {
    let (count, mass) = (8usize, 0.1);
    let h: f64 = 1.0 / 600.0;
    let alpha = 2.5e-5;
    let w = 1.0 / mass;
    let alpha_tilde = alpha / (h * h);
    let beta = 2.0 * w / (2.0 * w + alpha_tilde);
    let top = alpha * mass * G * count as f64;
    let x_max = 1.5;
    let fixed_point_bound = 4.0 * U * x_max / (1.0 - (-3.0 * h).exp()) / top;
    let settle_bound = 1e-3 * top;
    let mut errors = Vec::new();
    for k in [1u32, 4, 16] {
        let (per_link, drift) = hanging_chain_error(k, alpha, count, mass);
        let err = max_abs(&per_link);
        let bk = beta.powi(k as i32);
        let bound = (4.0 * w + alpha_tilde) / alpha_tilde * bk / (1.0 - bk);
        let predicted = hanging_chain_prediction(k, alpha_tilde, w, h, count, mass);
        let mismatch = max_abs(&sub(&per_link, &predicted));
        eprintln!(
            "hanging chain, {k:2} iterations: max |stretch − αT|/αT_0 = {err:e} / norm bound {bound:e} \
             ((4w+α~)/α~·β^K/(1−β^K), β = {beta:.4}); exact K-sweep fixed point predicts {:e}, \
             measured − predicted {mismatch:e} / bound {fixed_point_bound:e}; settle drift {drift:e} / {settle_bound:e}",
            max_abs(&predicted)
        );
        assert!(
            drift <= settle_bound,
            "chain not settled after 10 s ({k} iterations): moved {drift:e} in the last second"
        );
        assert!(
            err <= bound,
            "chain equilibrium error {err:e} exceeds the Gauss–Seidel bound {bound:e} at {k} iterations"
        );
        assert!(
            mismatch <= fixed_point_bound,
            "chain equilibrium at {k} iterations differs from the exact fixed point of {k} Gauss–Seidel \
             sweeps by {mismatch:e} (> {fixed_point_bound:e}): the projection is not the documented XPBD update"
        );
        errors.push((k, err));
    }
    for pair in errors.windows(2) {
        let ((k0, e0), (k1, e1)) = (pair[0], pair[1]);
        // More sweeps per substep bring the fixed point closer to the
        // converged equilibrium (G^K shrinks).
        assert!(
            e1 < e0,
            "equilibrium error did not decrease from {k0} to {k1} iterations: {e0:e} -> {e1:e}"
        );
    }
}

/// The same chain with `"primal_residual": true` settles on the compliant
/// equilibrium stretch α·T_k itself, for any number of sweeps: the forces
/// carry over between substeps, so a chain at rest in equilibrium starts
/// each substep at its solution, and the fixed point is backward Euler's
/// (cpu/src/consistent.rs). Bound: the rounding floor of the check above
/// (4u·X / (1 − e^{−r h}) / (α T_0)), against the standard update's
/// K-sweep error printed beside it.
#[test]
fn the_primal_residual_chain_settles_on_the_compliant_stretch_for_any_sweep_count() {
    let (count, mass) = (8usize, 0.1);
    let h: f64 = 1.0 / 600.0;
    let alpha = 2.5e-5;
    let top = alpha * mass * G * count as f64;
    let bound = 4.0 * U * 1.5 / (1.0 - (-3.0 * h).exp()) / top;
    for k in [1u32, 4] {
        let (per_link, drift) = hanging_chain_error_with(k, alpha, count, mass, true);
        let (standard, _) = hanging_chain_error(k, alpha, count, mass);
        let err = max_abs(&per_link);
        super::bound::print_bound(
            format_args!("hanging chain, {k} sweeps, primal_residual: max |stretch − αT|/αT_0"),
            format_args!("{err:.3e}"),
            format_args!("{bound:.3e}"),
            format_args!(
                "rounding floor; the standard update: {:.3e}",
                max_abs(&standard)
            ),
        );
        assert!(drift <= 1e-3 * top, "not settled ({k} sweeps): {drift:e}");
        assert!(err <= bound, "{k} sweeps: {err:e} > {bound:e}");
    }
}

/// A column of 6 particles (0.1 kg) joined by compliant links (α = 2.5e-5)
/// standing on a compliant plane (α_p = 1e-5, μ = 0.5: static friction
/// runs too) under gravity: at rest, link k is compressed by α·m g (N − 1 − k)
/// and the bottom particle sinks α_p·N m g into the plane. With the
/// primal residual (4 sweeps per substep, 10 s) the column settles there to the
/// rounding floor of the chain check (relative to the plane's sink); the
/// standard update's error is printed beside it.
#[test]
fn a_column_on_a_compliant_plane_settles_exactly_with_the_primal_residual() {
    let (count, mass, alpha, alpha_plane) = (6usize, 0.1, 2.5e-5, 1e-5);
    let h: f64 = 1.0 / 600.0;
    let settle = |primal_residual: bool| {
        let mut b = SceneBuilder::new(2)
            .dt(1.0 / 60.0)
            .substeps(10)
            .iterations(4)
            .gravity_along(1, G)
            .damping(3.0);
        b.chain(&ChainSpec {
            start: vec![0.0, 0.0],
            direction: vec![0.0, 1.0],
            count,
            spacing: 0.1,
            mass,
            compliance: alpha,
            fix_first: false,
        });
        b.hyperplane(vec![0.0, 1.0], 0.0, 0.5);
        if let Some(hyperpbd::Obstacle::Hyperplane { compliance, .. }) =
            b.scene_mut().obstacles.get_mut(0)
        {
            *compliance = alpha_plane;
        }
        b.scene_mut().solver = hyperpbd::Solver::Xpbd(hyperpbd::XpbdSettings { primal_residual });
        let scene = b.build().expect("valid scene");
        let mut sim = backend(&scene);
        for _ in 0..600 {
            step(&mut sim);
        }
        let st = state(&mut sim);
        let weight = mass * G;
        let sink = alpha_plane * weight * count as f64;
        let mut err = (st.position(0)[1] + sink).abs();
        for k in 0..count - 1 {
            let length = norm(&sub(st.position(k + 1), st.position(k)));
            let compression = 0.1 - length;
            let expected = alpha * weight * (count - 1 - k) as f64;
            err = err.max((compression - expected).abs());
        }
        err / sink
    };
    let bound = 4.0 * U * 1.0 / (1.0 - (-3.0 * h).exp()) / (alpha_plane * mass * G * count as f64);
    let standard = settle(false);
    let carried = settle(true);
    super::bound::print_bound(
        "standing column on a compliant plane, 4 sweeps, primal_residual: max error / plane sink",
        format_args!("{carried:.3e}"),
        format_args!("{bound:.3e}"),
        format_args!("rounding floor; the standard update: {standard:.3e}"),
    );
    assert!(carried <= bound, "{carried:e} > {bound:e}");
}

/// The carried forces are force · h²: when a step runs with more substeps
/// (an adaptive retry, `Subdivided::attempt`), they are rescaled by
/// (h'/h)² before the warm start. A chain at rest in its compliant
/// equilibrium then stays at rest through a step of twice the substeps
/// (moves ≤ 1e-9 of its top link's stretch), where forces carried at the
/// old scale would jolt it by about h²g/4.
#[test]
fn a_subdivided_step_rescales_the_carried_forces() {
    use hyperpbd::core::adaptive::Subdivided;
    let (count, mass, alpha) = (8usize, 0.1, 2.5e-5);
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(4)
        .gravity_along(1, G)
        .damping(3.0);
    b.chain(&ChainSpec {
        start: vec![0.2, 1.5, -0.1],
        direction: vec![0.0, -1.0, 0.0],
        count: count + 1,
        spacing: 0.1,
        mass,
        compliance: alpha,
        fix_first: true,
    });
    b.scene_mut().solver = hyperpbd::Solver::Xpbd(hyperpbd::XpbdSettings {
        primal_residual: true,
    });
    let scene = b.build().expect("valid scene");
    let mut sim = backend(&scene);
    for _ in 0..600 {
        step(&mut sim);
    }
    let before = state(&mut sim);
    sim.attempt(1).expect("a step of 20 substeps");
    let after = state(&mut sim);
    let moved = max_abs(&sub(&after.positions, &before.positions));
    let top = alpha * mass * G * count as f64;
    super::bound::check_bound(
        "chain at rest, primal_residual, one step at twice the substeps: max move / αT_0",
        moved / top,
        1e-9,
        "rescaled forces keep the equilibrium; unscaled ones jolt it by ~h²g/4",
    );
}
