//! The implicit step's hard cases past the mass ratio: dt = 1 s and 1 µs,
//! a far offset, R^8, a particle on a plane, coincident particles, a
//! material drop, empty and one-particle scenes.

use super::*;

/// dt = 1 s in ONE minimisation per step, 30 s: the chain falls onto the
/// ground and comes to rest (XPBD needs 200 substeps for 1 % of a link).
#[test]
fn implicit_dt_one_second() {
    if !on_one_lavapipe_thread(&test_name(module_path!(), "implicit_dt_one_second")) {
        return;
    }
    let case = "implicit_dt_one_second";
    for (kind, m) in chain_case(case, &swinging_chain(1.0, 0.0), 30) {
        let lowest = (0..11)
            .map(|i| m.last.position(i)[1])
            .fold(f64::INFINITY, f64::min);
        check_residual(
            case,
            kind,
            "penetration −min y (m)",
            -lowest,
            0.0,
            "the certified filter: d > 0",
        );
    }
}

/// dt = 1 µs, 1000 steps: h² = 1e-12 s², so the objective's gradient is
/// 1e-12 × the forces; the acceleration criterion does not see h.
#[test]
fn implicit_dt_one_microsecond() {
    if !on_one_lavapipe_thread(&test_name(module_path!(), "implicit_dt_one_microsecond")) {
        return;
    }
    chain_case(
        "implicit_dt_one_microsecond",
        &swinging_chain(1e-6, 0.0),
        1000,
    );
}

/// The swinging chain of `implicit_dt_one_second` at dt 1/60 s, every
/// coordinate (and the plane) moved by 1e5 m, 2 s: a link's length then
/// rounds by ~ε·1e5 = 2e-11 m, a force of 2e-3 N on 0.1 kg. On gpu-f32 the
/// chain's impact squeezes a bead to within the f32 filter's certified
/// rounding of the plane (δd ≈ 2e-6 m at local coordinates ~1 m, the
/// plane at local y = −1 after the origin shift): the filter then admits
/// no motion and the step is refused (`NoDescent`, rolled back), which
/// this case allows and reports (docs/implicit.md §12).
#[test]
fn implicit_far_offset_1e5() {
    if !on_one_lavapipe_thread(&test_name(module_path!(), "implicit_far_offset_1e5")) {
        return;
    }
    chain_case_with(
        "implicit_far_offset_1e5",
        &swinging_chain(1.0 / 60.0, 1e5),
        120,
        true,
    );
}

/// R^8: five balls (radius 0.1 m, 1 kg) in a column 0.05 m apart, each
/// offset along a different axis, falling onto the plane x_1 = 0 with
/// μ = 0.3 and ball friction 0.2, 2 s: ball pairs, plane barriers and
/// both frictions in eight dimensions; on gpu-f64 in lockstep, bit for
/// bit on lavapipe after every step.
#[test]
fn implicit_eight_dimensions() {
    if !on_one_lavapipe_thread(&test_name(module_path!(), "implicit_eight_dimensions")) {
        return;
    }
    let case = "implicit_eight_dimensions";
    let dim = 8;
    let mut b = SceneBuilder::new(dim).dt(1.0 / 60.0).gravity_along(1, 9.81);
    for k in 0..5 {
        let mut x = vec![0.0; dim];
        x[1] = 0.3 + 0.25 * k as f64;
        x[(k + 2) % dim] = 0.03 * k as f64;
        b.particle(Particle::new(x, 1.0).with_radius(0.1));
    }
    let mut up = vec![0.0; dim];
    up[1] = 1.0;
    b.hyperplane(up, 0.0, 0.3);
    b.scene_mut().collisions = Some(Collisions {
        friction: 0.2,
        margin: 0.0,
    });
    b.scene_mut().solver = implicit(1e4, 1e-2, 1e-3);
    let scene = b.build().expect("valid");
    let (mut backend, initial) = cpu(case, &scene);
    let mut single = adapter_or_skip(case, Precision::F32).map(|(adapter, _)| {
        let plan = Plan::compile(&scene).expect("compiles");
        let loaded = hyperpbd::load_on_adapter(&adapter, plan.clone(), &initial, Precision::F32)
            .unwrap_or_else(|e| panic!("{case} (gpu-f32): {e}"));
        (loaded, F32Check::new(&plan, &initial))
    });
    let mut gpu = adapter_or_skip(case, Precision::F64).map(|(adapter, summary)| {
        let plan = Plan::compile(&scene).expect("compiles");
        let loaded = hyperpbd::load_on_adapter(&adapter, plan, &initial, Precision::F64)
            .unwrap_or_else(|e| panic!("{case} (gpu-f64): {e}"));
        (loaded, f64_identical(&summary))
    });
    let closest_gap = |s: &State| {
        let mut closest = f64::INFINITY;
        for i in 0..5 {
            closest = closest.min(s.position(i)[1] - 0.1);
            for j in i + 1..5 {
                let d: f64 = (0..dim)
                    .map(|a| (s.position(i)[a] - s.position(j)[a]).powi(2))
                    .sum();
                closest = closest.min(d.sqrt() - 0.2);
            }
        }
        closest
    };
    let mut closest = f64::INFINITY;
    let mut gpu_closest = f64::INFINITY;
    let mut m: Option<Measured> = None;
    for step in 0..120 {
        let measured = run(case, backend.as_mut(), &initial, 1);
        closest = closest.min(closest_gap(&measured.last));
        if let Some((loaded, exact)) = gpu.as_mut() {
            let other = run(case, loaded.as_mut(), &initial, 1);
            gpu_closest = gpu_closest.min(closest_gap(&other.last));
            assert!(
                !*exact || bits(&measured.last) == bits(&other.last),
                "{case}: step {step}: the gpu-f64 state differs from the golden path"
            );
        }
        if let Some((loaded, check)) = single.as_mut() {
            let before = loaded.read_state().expect("gpu-f32 state");
            let other = run(case, loaded.as_mut(), &initial, 1);
            check.step(case, &before, &other.last);
        }
        let gain = measured.energy_gain;
        m = Some(match m {
            None => measured,
            Some(previous) => Measured {
                energy_gain: gain.max(previous.energy_gain),
                energy_scale: measured.energy_scale.max(previous.energy_scale),
                ..measured
            },
        });
    }
    if gpu.is_some() {
        check_residual(
            case,
            GPU_F64,
            "−(smallest ball or plane gap) (m)",
            -gpu_closest,
            0.0,
            "the certified filter over planes and ball pairs: d > 0",
        );
    }
    if let Some((_, check)) = &single {
        report_f32(case, check);
        check_residual(
            case,
            GPU_F32,
            "−(smallest ball or plane gap) (m)",
            -check.closest,
            0.0,
            "the certified filter at ε32, radii stored outward: d > 0",
        );
    }
    let m = m.expect("steps ran");
    let kind = BackendKind::Cpu;
    check_energy(case, kind, &m, 0.0, "dissipative: starts at rest, apart");
    check_residual(
        case,
        kind,
        "−(smallest ball or plane gap) (m)",
        -closest,
        0.0,
        "the certified filter over planes and ball pairs: d > 0",
    );
}

/// `on_hyperplane` on this path: a particle exactly on a plane (d = 0) is
/// outside the barrier's domain, so the scene is refused by validation,
/// naming the particle and the obstacle.
#[test]
fn implicit_on_hyperplane_is_refused() {
    let mut b = SceneBuilder::new(3).dt(1.0 / 60.0).gravity_along(1, 9.81);
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.5);
    b.particle(Particle::new(vec![5.0, 0.0, 0.2], 1.0));
    b.scene_mut().solver = implicit(1e3, 1e-3, 1e-2);
    let error = b.build().expect_err("d = 0 is infeasible for a barrier");
    let refused = matches!(
        &error,
        SceneError::BarrierInfeasible { path, obstacle: 0, .. } if path == "particles[0].position"
    );
    report(
        "implicit_on_hyperplane",
        BackendKind::Cpu,
        "refused (typed)",
        "d (m)",
        0.0,
        &format!("{error}"),
    );
    assert!(refused, "{error:?}");
}

/// `coincident_distance` on this path: two springs (rest 0.5 m,
/// compliance 1e-3 m/N) whose particles start coincident, pair A at rest
/// (ℓ = 0: no direction, no force — it stays violated by exactly 0.5 m
/// and falls as one), pair B with one particle at 1 m/s (the prediction
/// gives a direction and the spring restores its length), 1 s.
#[test]
fn implicit_coincident_distance() {
    if !on_one_lavapipe_thread(&test_name(module_path!(), "implicit_coincident_distance")) {
        return;
    }
    let case = "implicit_coincident_distance";
    let mut b = SceneBuilder::new(3).dt(1.0 / 60.0).gravity_along(1, 9.81);
    b.particle(Particle::new(vec![0.0, 1.0, 0.0], 1.0));
    b.particle(Particle::new(vec![0.0, 1.0, 0.0], 1.0));
    b.particle(Particle::new(vec![2.0, 1.0, 0.0], 1.0));
    b.particle(Particle::new(vec![2.0, 1.0, 0.0], 1.0).with_velocity(vec![1.0, 0.0, 0.0]));
    for pair in [[0, 1], [2, 3]] {
        let mut f = ConstraintFamily::new(ConstraintKind::Distance, 1e-3, vec![pair.to_vec()]);
        f.rest = Some(vec![0.5]);
        b.family(f);
    }
    b.scene_mut().solver = implicit(1e3, 1e-3, 1e-3);
    let scene = b.build().expect("coincident particles are valid input");
    for (kind, m) in on_cpu_and_gpu(case, &scene, 60) {
        // Both springs start at C = −0.5 m: U_el(0) = 2 · 0.5² / (2 · 1e-3).
        check_energy(
            case,
            kind,
            &m,
            250.0,
            "may release the springs' stored 250 J",
        );
        let length = |i: usize, j: usize| -> f64 {
            (0..3)
                .map(|a| (m.last.position(i)[a] - m.last.position(j)[a]).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        check_residual(
            case,
            kind,
            "pair A |ℓ| after 1 s (m)",
            length(0, 1),
            0.0,
            "no direction at ℓ = 0: no invented force",
        );
        check_residual(
            case,
            kind,
            "pair B |ℓ − 0.5| after 1 s (m)",
            (length(2, 3) - 0.5).abs(),
            0.01,
            "restored (a 1e-3 m/N spring, dissipated by backward Euler)",
        );
    }
}

/// A 2D Neo-Hookean block (tests/common/guarded.rs: 3 × 3 cells of 0.1 m,
/// E = 2e5 Pa, 0.1 kg nodes) thrown at 10 m/s onto a plane from 0.2 m
/// under gravity, one minimisation per 1/30 s (the first prediction is
/// 0.13 m below the plane), 2 s: trials that would invert an element or
/// cross the plane are rejected, and it comes to rest on the plane. On
/// gpu-f64 in lockstep, bit for bit on lavapipe; gpu-f32 refuses it
/// (material families are not built there yet).
#[test]
fn implicit_material_drop() {
    if !on_one_lavapipe_thread(&test_name(module_path!(), "implicit_material_drop")) {
        return;
    }
    let case = "implicit_material_drop";
    let mut scene =
        common::guarded::material_block(2, 10.0, ConstraintKind::NeoHookean, None, None);
    // (The guard tests' block has gravity +9.81 along y; this one falls.)
    scene.gravity = Some(vec![0.0, -9.81]);
    scene.solver = implicit(1e4, 1e-3, 1e-2);
    for (kind, m) in lockstep(case, &scene, 60, false, false) {
        check_energy(
            case,
            kind,
            &m,
            0.0,
            "dissipative: starts unstressed, above d^",
        );
        let lowest = (0..scene.particles.len())
            .map(|i| m.last.position(i)[1])
            .fold(f64::INFINITY, f64::min);
        check_residual(
            case,
            kind,
            "penetration −min y (m)",
            -lowest,
            0.0,
            "the certified filter: d > 0",
        );
        let speed = m.last.velocities.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        check_residual(
            case,
            kind,
            "max |v| after 2 s (m/s)",
            speed,
            1e-3,
            "at rest on the plane",
        );
    }
}

/// The coupled step with nothing to couple (an explicit warm start makes
/// it run): an empty scene steps, and one free particle falls exactly as
/// backward Euler says, x_n = x_0 − g h² n(n + 1)/2.
#[test]
fn implicit_empty_and_one_particle() {
    if !on_one_lavapipe_thread(&test_name(
        module_path!(),
        "implicit_empty_and_one_particle",
    )) {
        return;
    }
    let case = "implicit_one_particle";
    let solver = |warm_start| {
        let Solver::IncrementalPotential(mut s) = implicit(1e3, 1e-3, 1e-9) else {
            unreachable!()
        };
        s.warm_start = Some(warm_start);
        Solver::IncrementalPotential(s)
    };
    let mut empty = Scene::new(3, 1.0 / 60.0, 1, 1);
    empty.solver = solver(WarmStart::Inertial);
    on_cpu_and_gpu("implicit_empty_scene", &empty, 10);
    for warm_start in [WarmStart::Inertial, WarmStart::Previous] {
        let mut scene = Scene::new(3, 1.0 / 60.0, 1, 1);
        scene.gravity = Some(vec![0.0, -9.81, 0.0]);
        scene
            .particles
            .push(Particle::new(vec![0.0, 10.0, 0.0], 2.0));
        scene.solver = solver(warm_start);
        let h: f64 = 1.0 / 60.0;
        let exact = 10.0 - 9.81 * h * h * 60.0 * 61.0 / 2.0;
        for (kind, m) in on_cpu_and_gpu(case, &scene, 60) {
            // f32: every step rounds x~, the iterate and v = (x − x^t)/h at
            // coordinates ≤ X = 10 m (4 roundings of the position, 4 of
            // the velocity that every later step integrates): after n
            // steps u₃₂ X (4n + 4 n(n + 1)/2).
            let n = 60.0;
            let (bound, why) = if kind == GPU_F32 {
                (
                    f64::from(f32::EPSILON) / 2.0 * 10.0 * (4.0 * n + 2.0 * n * (n + 1.0)),
                    "one free particle in f32: u32 X (4n + 4 n(n+1)/2), X = 10 m, n = 60",
                )
            } else {
                (
                    1e-12,
                    "one free particle: one Newton step per step, exact to rounding",
                )
            };
            check_residual(
                case,
                kind,
                &format!("|y − backward Euler| after 60 steps, {warm_start:?} (m)"),
                (m.last.position(0)[1] - exact).abs(),
                bound,
                why,
            );
        }
    }
}
