//! The built-in scenes in R^2 … R^5, the empty scene, one particle.

use super::*;

/// Masses (0 for fixed particles).
fn masses(scene: &hyperpbd::Scene) -> Vec<f64> {
    scene
        .particles
        .iter()
        .map(|p| if p.fixed { 0.0 } else { p.mass.unwrap_or(0.0) })
        .collect()
}

/// Kinetic + gravitational potential energy, gravity g along −e_`up`.
fn energy(masses: &[f64], st: &State, up: usize) -> f64 {
    (0..st.len())
        .map(|i| masses[i] * (0.5 * dot(st.velocity(i), st.velocity(i)) + G * st.position(i)[up]))
        .sum()
}

/// What a scene run measured.
struct SceneRun {
    /// Largest violation per family over all steps.
    worst: Vec<(String, f64)>,
    /// Largest energy seen after any step, and the initial energy.
    e_max: f64,
    e0: f64,
    /// Lowest value of (n·x − offset − r) over particles and steps for the
    /// first hyperplane (the contact gap; negative = penetration).
    min_gap: f64,
    last: State,
}

/// Runs `frames` steps, checking finiteness after every step.
fn run_scene(name: &str, scene: &hyperpbd::Scene, frames: usize, up: usize) -> SceneRun {
    let m = masses(scene);
    let mut sim = backend(scene);
    let e0 = energy(&m, &State::from_scene(scene), up);
    let mut worst: Vec<(String, f64)> = Vec::new();
    let mut e_max = e0;
    let mut min_gap = f64::INFINITY;
    let plane = scene.obstacles.first().and_then(|o| {
        let hyperpbd::Obstacle::Hyperplane { normal, offset, .. } = o else {
            return None;
        };
        Some((unit(normal), *offset))
    });
    for f in 0..frames {
        let report = step(&mut sim);
        let st = state(&mut sim);
        assert!(all_finite(&st), "{name}: non-finite state after step {f}");
        if worst.is_empty() {
            worst = report
                .residuals
                .iter()
                .map(|r| (r.label.clone(), 0.0))
                .collect();
        }
        for (w, r) in worst.iter_mut().zip(&report.residuals) {
            assert!(
                r.max_violation.is_finite(),
                "{name}: non-finite residual {r:?}"
            );
            w.1 = w.1.max(r.max_violation);
        }
        e_max = e_max.max(energy(&m, &st, up));
        if let Some((n, offset)) = &plane {
            for (i, particle) in scene.particles.iter().enumerate() {
                if m[i] > 0.0 {
                    let gap = dot(n, st.position(i)) - offset - particle.radius;
                    min_gap = min_gap.min(gap);
                }
            }
        }
    }
    SceneRun {
        worst,
        e_max,
        e0,
        min_gap,
        last: state(&mut sim),
    }
}

/// Energy bound shared by the scene checks: XPBD projection and the
/// friction/damping responses only remove energy; the discrete energy
/// (reconstructed velocity, end-of-substep position) may exceed the initial
/// one by at most the O(h) lag M·g·h·v_max, with v_max = √(2 g H) for a fall
/// height H.
fn energy_bound(masses: &[f64], h: f64, fall_height: f64) -> f64 {
    let total: f64 = masses.iter().sum();
    total * G * h * (2.0 * G * fall_height).sqrt()
}

/// Position gap tolerance for "nothing falls through": the contact family
/// is projected last in every iteration, so a particle ends each step on
/// the admissible side up to the rounding of n·x (a few u·|x|): 8u·|x|max.
fn gap_bound(st: &State) -> f64 {
    8.0 * U * max_abs(&st.positions).max(1.0)
}

/// R^2: `scenes::chain2d()` (a rope bridge: 21 particles, both ends fixed
/// 2 m apart, 20 rigid links, 2 iterations, damping 1/s) for 5 s. Checks:
/// finite; link residual ≤ 5% of the link length (a sanity bound — a
/// visibly stretched rope; two Gauss–Seidel sweeps per substep on 20 rigid
/// links leave far less); energy never above E0 + M g h v_max with v_max
/// from the largest possible drop (2 m: the ends' height above the ground);
/// no particle below the ground.
#[test]
fn scene_chain2d_runs_with_bounded_residual() {
    let scene = hyperpbd::scenes::chain2d();
    let h = scene.dt / f64::from(scene.substeps);
    let run = run_scene("chain2d", &scene, 300, 1);
    let link = 0.1; // the links are chords of the authored parabola: ≥ 0.1
    let (label, stretch) = &run.worst[0];
    let bound = 0.05 * link;
    eprintln!("chain2d: {label} max residual {stretch:e} m / bound {bound:e} (5% of 0.1 m)");
    assert!(
        *stretch <= bound,
        "chain2d links stretched by {stretch:e} > {bound:e}"
    );
    let e_bound = energy_bound(&masses(&scene), h, 2.0);
    eprintln!(
        "chain2d: energy max − E0 = {:e} J / bound {e_bound:e} J (M g h v_max)",
        run.e_max - run.e0
    );
    assert!(
        run.e_max - run.e0 <= e_bound,
        "chain2d gained energy: {} > E0 {} + {e_bound}",
        run.e_max,
        run.e0
    );
    let gap = gap_bound(&run.last);
    eprintln!(
        "chain2d: min contact gap {:e} / bound −{gap:e}",
        run.min_gap
    );
    assert!(
        run.min_gap >= -gap,
        "chain2d went through the ground: gap {}",
        run.min_gap
    );
}

/// R^3: `scenes::cloth(16)` dropped on the ground for 2 s. Checks: finite;
/// edge residual ≤ 5% of the spacing (sanity bound as for the chain; one
/// iteration leaves ~1%); energy never above E0 + M g h v_max (friction and
/// damping dissipate); every particle ends on or above the plane at its
/// radius (gap ≥ −8u|x|) and the cloth has landed (every particle touching
/// within 1e-9 m at the end: it fell 0.5–0.7 m in 2 s).
#[test]
fn scene_cloth_runs_with_bounded_residual() {
    let n = 16;
    let scene = hyperpbd::scenes::cloth(n);
    let h = scene.dt / f64::from(scene.substeps);
    let run = run_scene("cloth", &scene, 120, 1);
    let spacing = 1.0 / (n - 1) as f64;
    let (label, stretch) = &run.worst[0];
    let bound = 0.05 * spacing;
    eprintln!("cloth: {label} max residual {stretch:e} m / bound {bound:e} (5% of the spacing)");
    assert!(
        *stretch <= bound,
        "cloth edges stretched by {stretch:e} > {bound:e}"
    );
    let e_bound = energy_bound(&masses(&scene), h, 0.7);
    eprintln!(
        "cloth: energy max − E0 = {:e} J / bound {e_bound:e} J (M g h v_max)",
        run.e_max - run.e0
    );
    assert!(run.e_max - run.e0 <= e_bound, "cloth gained energy");
    let gap = gap_bound(&run.last);
    eprintln!("cloth: min contact gap {:e} / bound −{gap:e}", run.min_gap);
    assert!(
        run.min_gap >= -gap,
        "cloth went through the ground: gap {}",
        run.min_gap
    );
    let highest_gap = (0..run.last.len())
        .map(|i| run.last.position(i)[1] - scene.particles[i].radius)
        .fold(0.0, f64::max);
    eprintln!("cloth: largest gap at the end {highest_gap:e} / bound 1e-9 (landed flat)");
    assert!(
        highest_gap <= 1e-9,
        "cloth has not landed after 2 s: gap {highest_gap}"
    );
}

/// R^4: `scenes::tesseract()` (soft Kuhn block, 384 oriented 4-simplices,
/// compliance 1e-6) dropped on x_3 = 0 for 2 s. Checks: finite; every
/// oriented measure within half its rest value |V_rest| = s⁴/4! (no element
/// inverted or halved: an inversion needs |C| ≥ |V_rest|); energy never
/// above E0 + M g h v_max; nothing falls through the plane.
#[test]
fn scene_tesseract_keeps_volumes_and_stays_above_the_plane() {
    let scene = hyperpbd::scenes::tesseract();
    let h = scene.dt / f64::from(scene.substeps);
    let run = run_scene("tesseract", &scene, 120, 3);
    let spacing: f64 = 0.5;
    let v_rest = spacing.powi(4) / 24.0;
    let (label, dv) = &run.worst[0];
    let bound = 0.5 * v_rest;
    eprintln!(
        "tesseract: {label} max |V − V_rest| {dv:e} ({:.1}% of |V_rest| = {v_rest:e}) / bound {bound:e} (half the rest measure)",
        100.0 * dv / v_rest
    );
    assert!(
        *dv <= bound,
        "tesseract elements lost {dv:e} > {bound:e} of volume"
    );
    let e_bound = energy_bound(&masses(&scene), h, 1.3);
    eprintln!(
        "tesseract: energy max − E0 = {:e} J / bound {e_bound:e} J (M g h v_max)",
        run.e_max - run.e0
    );
    assert!(run.e_max - run.e0 <= e_bound, "tesseract gained energy");
    let (contact_label, contact) = run
        .worst
        .iter()
        .find(|(label, _)| label.starts_with("obstacles"))
        .expect("the tesseract has a ground plane");
    let gap = gap_bound(&run.last);
    eprintln!(
        "tesseract: {contact_label} max penetration {contact:e}, min gap {:e} / bound −{gap:e}",
        run.min_gap
    );
    assert!(
        run.min_gap >= -gap,
        "tesseract went through the plane: gap {}",
        run.min_gap
    );
    assert!(
        *contact <= gap,
        "tesseract contact residual {contact:e} > {gap:e}"
    );
}

/// The soft tesseract should behave like a soft solid for longer than the
/// 2 s above: over 5 s it must not gain energy (bound E0 + M g h v_max, as
/// above) and the landed block must keep its shape (its largest distance
/// from the x_3 axis stays within 2× the authored 0.5·√3 m).
///
/// A regression guard: with volume constraints only (no shear stiffness)
/// the block flowed like a liquid — extent 0.87 m → ~10 m within 2 s, slivers
/// whose tiny |∇V| made −C/Σw|∇C|² inject energy (≈ 196 J at 8 s from
/// E0 = 31.8 J). `soft_block` now adds the simplices' edges as a distance
/// family (`BlockSpec::edge_compliance`), and the tesseract uses it.
#[test]
fn scene_tesseract_keeps_its_shape_and_energy_for_5s() {
    let scene = hyperpbd::scenes::tesseract();
    let h = scene.dt / f64::from(scene.substeps);
    let m = masses(&scene);
    let e0 = energy(&m, &State::from_scene(&scene), 3);
    let e_bound = energy_bound(&m, h, 1.3);
    let extent_bound = 2.0 * 0.5 * 3f64.sqrt();
    let mut sim = backend(&scene);
    for f in 0..300 {
        step(&mut sim);
        let st = state(&mut sim);
        assert!(
            all_finite(&st),
            "tesseract: non-finite state after step {f}"
        );
        let e = energy(&m, &st, 3);
        let extent = (0..st.len())
            .map(|i| norm(&st.position(i)[..3]))
            .fold(0.0, f64::max);
        if f % 60 == 59 {
            eprintln!(
                "tesseract t = {:.0} s: energy − E0 = {:e} J / bound {e_bound:e}; extent {extent:.3} m / bound {extent_bound:.3} m",
                (f + 1) as f64 / 60.0,
                e - e0
            );
        }
        assert!(
            extent <= extent_bound,
            "tesseract lost its shape at step {f}: extent {extent} m > {extent_bound} m"
        );
        assert!(
            e - e0 <= e_bound,
            "tesseract gained energy at step {f}: {e} J > E0 {e0} J + {e_bound} J"
        );
    }
}

/// R^5: `scenes::incline5d()` — four particles on a 20° incline with
/// μ = 0.2 slide down x_0 at g (sin θ − μ cos θ): 2% bound (issue) and the
/// 1e-6 exact-discrete bound of `incline_slides_with_coulomb_acceleration`.
/// Coordinates x_2…x_4 are exactly unchanged (bound 0): normal and gravity
/// have zero components there, so every update adds exactly zero.
#[test]
fn scene_incline5d_slides_at_the_coulomb_rate() {
    let scene = hyperpbd::scenes::incline5d();
    let theta: f64 = 20f64.to_radians();
    let mu = 0.2;
    let downhill = [theta.cos(), -theta.sin(), 0.0, 0.0, 0.0];
    let expected = G * (theta.sin() - mu * theta.cos());
    let mut sim = backend(&scene);
    let count = scene.particles.len();
    let mut times = Vec::new();
    let mut s: Vec<Vec<f64>> = vec![Vec::new(); count];
    for k in 1..=120 {
        let report = step(&mut sim);
        assert_eq!(report.active_contacts, count, "a particle left the incline");
        let st = state(&mut sim);
        assert!(all_finite(&st));
        times.push(k as f64 * scene.dt);
        for (i, si) in s.iter_mut().enumerate() {
            si.push(dot(
                &downhill,
                &sub(st.position(i), &scene.particles[i].position),
            ));
            assert_eq!(
                &st.position(i)[2..],
                &scene.particles[i].position[2..],
                "incline5d particle {i} moved off its x_2..x_4 coordinates"
            );
        }
    }
    for (i, si) in s.iter().enumerate() {
        let (_, _, a) = fit_quadratic(&times, si);
        let rel = (a - expected).abs() / expected;
        eprintln!(
            "incline5d particle {i}: acceleration {a:.9} vs g(sin θ − μ cos θ) = {expected:.9}: relative error {rel:e} / bound 2e-2 (tight 1e-6)"
        );
        assert!(
            rel <= 0.02,
            "incline5d particle {i}: acceleration off by {rel:e}"
        );
        assert!(
            rel <= 1e-6,
            "incline5d particle {i}: acceleration off by {rel:e} (exact discrete value)"
        );
    }
}

/// The empty scene, in several dimensions and with every optional stage
/// authored, steps fine and reports nothing; a single fixed particle never
/// moves (no kernels run: bit-exact).
#[test]
fn empty_scene_steps() {
    for dim in [1usize, 2, 3, 4, 5] {
        let mut b = SceneBuilder::new(dim)
            .substeps(3)
            .iterations(2)
            .gravity_along(dim - 1, G)
            .damping(0.5);
        let mut normal = vec![0.0; dim];
        normal[dim - 1] = 1.0;
        b.hyperplane(normal, 0.0, 0.3);
        let scene = b.build().expect("valid scene");
        let mut sim = backend(&scene);
        for _ in 0..10 {
            let report = step(&mut sim);
            assert!(
                report.residuals.is_empty(),
                "empty scene reported residuals"
            );
            assert_eq!(report.active_contacts, 0);
            assert_eq!(report.max_violation(), 0.0);
        }
        let st = state(&mut sim);
        assert!(st.is_empty() && st.dim == dim);
        eprintln!("empty scene R^{dim}: 10 steps, no residuals, empty state");

        // One fixed particle: nothing may change, bit for bit.
        let mut b = SceneBuilder::new(dim).gravity_along(dim - 1, G);
        let x0: Vec<f64> = (0..dim).map(|a| 0.1 * a as f64 - 0.3).collect();
        b.particle(Particle::fixed(x0.clone()));
        let scene = b.build().expect("valid scene");
        let mut sim = backend(&scene);
        for _ in 0..10 {
            step(&mut sim);
        }
        let st = state(&mut sim);
        assert_eq!(st.position(0), &x0[..], "a fixed particle moved");
        assert_eq!(
            st.velocity(0),
            &vec![0.0; dim][..],
            "a fixed particle gained velocity"
        );
    }
}

/// One dynamic particle in R^1 … R^5 falls onto a hyperplane (normal along
/// the last axis), and comes to rest on it: after 2 s the gap to
/// offset + r is ≤ 8u|x| (contact projected last), and the residual
/// velocity is only reconstruction rounding, ≤ 8u|x|/h.
#[test]
fn one_particle_scene_lands_and_rests() {
    for dim in [1usize, 2, 3, 4, 5] {
        let (offset, r) = (-0.2, 0.05);
        let mut b = SceneBuilder::new(dim)
            .dt(1.0 / 60.0)
            .substeps(4)
            .gravity_along(dim - 1, G);
        let mut x0 = vec![0.25; dim];
        x0[dim - 1] = 0.6;
        b.particle(Particle::new(x0, 0.5).with_radius(r));
        let mut normal = vec![0.0; dim];
        normal[dim - 1] = 1.0;
        b.hyperplane(normal, offset, 0.5);
        let scene = b.build().expect("valid scene");
        let h = scene.dt / f64::from(scene.substeps);
        let mut sim = backend(&scene);
        let mut report = step(&mut sim);
        for _ in 1..120 {
            report = step(&mut sim);
        }
        let st = state(&mut sim);
        assert!(all_finite(&st));
        let height = st.position(0)[dim - 1];
        let gap = (height - (offset + r)).abs();
        let x_max = max_abs(&st.positions);
        let v = max_abs(st.velocity(0));
        eprintln!(
            "one particle R^{dim}: gap {gap:e} / bound {:e}; |v| {v:e} / bound {:e}; active contacts {}",
            8.0 * U * x_max,
            8.0 * U * x_max / h,
            report.active_contacts
        );
        assert_eq!(
            report.active_contacts, 1,
            "the particle is not resting on the plane"
        );
        assert!(
            gap <= 8.0 * U * x_max,
            "one particle R^{dim}: not at rest height (gap {gap:e})"
        );
        assert!(
            v <= 8.0 * U * x_max / h,
            "one particle R^{dim}: still moving ({v:e})"
        );
    }
}
