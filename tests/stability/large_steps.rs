//! Large and tiny time steps and a 1e4 m/s impact.

use super::*;

on_every_backend!(
    dt_one_second,
    dt_one_microsecond,
    fast_impact_xpbd,
    fast_moving_mesh_wall,
);

/// A 10-link rigid chain (0.1 m links, 0.1 kg) released horizontally from
/// a fixed end above a ground plane with friction, at time step `dt`.
fn swinging_chain(dt: f64, substeps: u32, iterations: u32) -> Scene {
    let mut b = SceneBuilder::new(3)
        .dt(dt)
        .substeps(substeps)
        .iterations(iterations)
        .gravity_along(1, 9.81);
    b.chain(&ChainSpec {
        start: vec![0.0, 0.5, 0.0],
        direction: vec![1.0, 0.0, 0.2],
        count: 11,
        spacing: 0.1,
        mass: 0.1,
        compliance: 0.0,
        fix_first: true,
    });
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.3);
    b.build().expect("valid")
}

/// dt = 1 s: the chain falls onto the ground and comes to rest, 30 s.
///
/// With one substep, gravity moves every particle g h² = 9.81 m per
/// substep — 100 links — and Gauss–Seidel with a fixed iteration count
/// leaves a steady residual proportional to that drift (measured: 0.40 m
/// at 8 iterations, 0.15 m at 32; bounded and dissipative, but not a
/// rigid chain). The remedy is XPBD's own: substeps, since the drift falls
/// as h². The asserted case is dt = 1 s in 200 substeps × 2 iterations;
/// the single-substep run is reported alongside (finite and dissipative
/// asserted, its residual only reported).
fn dt_one_second(kind: BackendKind) {
    let case = "dt_one_second";
    let scene = swinging_chain(1.0, 200, 2);
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 30);
    check_energy(case, kind, &m, 0.0, "dissipative: starts at rest");
    check_residual(
        case,
        kind,
        "max |C|, 200 substeps (m)",
        m.residual,
        0.001,
        "1% of the 0.1 m link",
    );
    let coarse = swinging_chain(1.0, 1, 8);
    let Some((mut backend, initial)) = start(case, kind, &coarse) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 30);
    check_energy(case, kind, &m, 0.0, "dissipative: starts at rest");
    report(
        case,
        kind,
        "bounded, not rigid",
        "max |C|, 1 substep × 8 iterations (m)",
        m.residual,
        "not asserted: steady Gauss–Seidel residual ∝ g h² = 9.81 m",
    );
}

/// dt = 1e-6 s (1 substep, 2 iterations), 2000 steps = 2 ms: the
/// per-step displacement under gravity (g dt² = 1e-11 m) is far below the
/// f32 spacing of a 1 m coordinate (6e-8 m), so in f32 the chain does not
/// move at all — stable, and wrong by at most the true displacement ½ g t²
/// = 2e-5 m. f64 resolves it.
fn dt_one_microsecond(kind: BackendKind) {
    let case = "dt_one_microsecond";
    let scene = swinging_chain(1e-6, 1, 2);
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let steps = 2000;
    let m = run(case, backend.as_mut(), &initial, steps);
    check_energy(case, kind, &m, 0.0, "dissipative: starts at rest");
    check_residual(
        case,
        kind,
        "max |C| (m)",
        m.residual,
        0.001,
        "1% of the 0.1 m link",
    );
    // The tip's fall against the CPU golden run (≈ ½ g t² = 1.96e-5 m):
    // f64 backends follow it within the rounding model; f32 cannot
    // represent a 1e-11 m step at a 1 m coordinate and moves by at most
    // the rounding model at its own ε.
    let tip = 10 * 3 + 1;
    let moved = initial.positions[tip] - m.last.positions[tip];
    let golden_fall = if kind == BackendKind::Cpu {
        moved
    } else {
        let (mut cpu, _) = start(case, BackendKind::Cpu, &scene).expect("cpu");
        run(case, cpu.as_mut(), &initial, steps).last.positions[tip]
    };
    let golden_fall = if kind == BackendKind::Cpu {
        golden_fall
    } else {
        initial.positions[tip] - golden_fall
    };
    let plan = Plan::compile(&scene).expect("valid");
    let f64_model = hyperpbd_verify::compare::ErrorModel::new(&plan, hyperpbd::Precision::F64);
    let (bound, why) = match kind {
        GPU_F32 => (
            golden_fall
                + hyperpbd_verify::compare::ErrorModel::new(&plan, hyperpbd::Precision::F32)
                    .position_bound(1.0, steps as u64),
            "f32: the true fall + its rounding model (the fall itself is below ulp)",
        ),
        _ => (
            f64_model.position_bound(1.0, steps as u64),
            "f64 rounding model at |x| ≤ 1 m",
        ),
    };
    check_residual(
        case,
        kind,
        &format!("|tip fall − golden {golden_fall:.3e}| (m)"),
        (moved - golden_fall).abs(),
        bound,
        why,
    );
}

/// One particle 1 m above the ground moving at 1e4 m/s straight at it
/// (radius 0.05, 10 substeps at 60 Hz: 16.7 m per substep, 330 times its
/// height). XPBD path: the plane is a half-space constraint, so the
/// particle is projected back to n·x = radius in the substep it crosses —
/// no tunnelling — and the contact is perfectly inelastic: it ends at
/// rest on the plane. (Barrier path: issue 8.)
fn fast_impact_xpbd(kind: BackendKind) {
    let case = "fast_impact_xpbd";
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .gravity_along(1, 9.81);
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.0);
    b.particle(
        Particle::new(vec![0.0, 1.0, 0.0], 1.0)
            .with_radius(0.05)
            .with_velocity(vec![0.0, -1e4, 0.0]),
    );
    let scene = b.build().expect("valid");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 60);
    check_energy(case, kind, &m, 0.0, "inelastic contact");
    // Penetration after the projection: rounding of one n·x at |x| ≤ 17 m
    // (the predicted position before the projection).
    check_residual(
        case,
        kind,
        "max penetration (m)",
        m.residual,
        8.0 * epsilon(kind) * 17.0,
        "rounding of n·x at the 17 m prediction: no tunnelling",
    );
    let y = m.last.positions[1];
    let vy = m.last.velocities[1];
    report(
        case,
        kind,
        "ok",
        "final height (m)",
        y,
        "= radius 0.05 (rests on the plane)",
    );
    report(
        case,
        kind,
        "ok",
        "final normal velocity (m/s)",
        vy,
        "|v| ≤ g h: inelastic, at rest",
    );
    assert!(
        (y - 0.05).abs() <= 8.0 * epsilon(kind) * 17.0,
        "{case}: y = {y}"
    );
    assert!(vy.abs() <= 9.81 / 600.0 * (1.0 + 1e-6), "{case}: vy = {vy}");
}

/// A mesh wall (two triangles in the plane x = −0.3) moving at 20 m/s
/// along +x into a resting ball (r = 0.05, no gravity).
fn wall(substeps: u32) -> Scene {
    let mut b = SceneBuilder::new(3).dt(1.0 / 60.0).substeps(substeps);
    b.particle(Particle::new(vec![0.0; 3], 1.0).with_radius(0.05));
    let mut scene = b.build().expect("valid");
    scene.obstacles.push(hyperpbd::Obstacle::SimplexMesh {
        vertices: vec![
            vec![-0.3, -1.0, -1.0],
            vec![-0.3, 1.0, -1.0],
            vec![-0.3, -1.0, 1.0],
            vec![-0.3, 1.0, 1.0],
        ],
        simplices: vec![vec![0, 1, 2], vec![1, 3, 2]],
        friction: 0.0,
        motion: vec![hyperpbd::motion::Motion::Translate {
            velocity: vec![20.0, 0.0, 0.0],
        }],
    });
    scene
}

/// The mesh wall of [`wall`] (a mesh's distance is unsigned: a ball whose
/// centre it crosses in one substep comes out behind it). With 30
/// substeps it moves 1.1 cm per substep, under the radius: it pushes the
/// ball ahead, no tunnelling, at its own speed. With 2 (16.7 cm ≥ r) the
/// step is a guard rejection (`moving_mesh`), the state unchanged; with
/// `adaptive` it is retried and runs with 8 (4.2 cm).
fn fast_moving_mesh_wall(kind: BackendKind) {
    let case = "fast_moving_mesh_wall";
    let Some((mut backend, initial)) = start(case, kind, &wall(30)) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 6);
    // After 0.1 s the wall is at x = 1.7: the ball touches it ahead.
    let (x, vx) = (m.last.positions[0], m.last.velocities[0]);
    let gap = x - 1.7 - 0.05;
    report(
        case,
        kind,
        "ok",
        "gap ahead of the wall (m)",
        gap,
        "≥ −ε·64·2: no tunnelling",
    );
    report(case, kind, "ok", "ball speed (m/s)", vx, "= the wall's 20");
    assert!(gap >= -64.0 * epsilon(kind) * 2.0, "{case}: gap {gap}");
    assert!((vx - 20.0).abs() <= 1e-3 * 20.0, "{case}: v = {vx}");
    // Too few substeps: a typed guard rejection, nothing moved.
    let Some((mut coarse, initial)) = start(case, kind, &wall(2)) else {
        return;
    };
    match coarse.step() {
        Err(BackendError::Step(hyperpbd::StepError::GuardRejected(r))) => {
            assert_eq!(r.guard, hyperpbd::GuardKind::MeshReach, "{case}: {r}");
            assert_eq!(r.subject, hyperpbd::GuardSubject::Obstacle(0), "{case}");
            assert!(
                (r.value - 20.0 / 120.0).abs() <= 1e-9 && r.limit == 0.05,
                "{case}: {r}"
            );
            report(
                case,
                kind,
                "refused",
                "wall travel per substep (m)",
                r.value,
                "≥ r = 0.05",
            );
        }
        other => panic!("{case} ({}): {other:?}", kind.name()),
    }
    let after = coarse.read_state().expect("state");
    assert_eq!(after.positions, initial.positions, "{case}: state moved");
    // Adaptive: retried with 4 and 8 substeps; 8 is accepted.
    let mut retried = wall(2);
    retried.adaptive = Some(hyperpbd::Adaptive {
        max_subdivisions: 3,
    });
    let Some((mut adaptive, _)) = start(case, kind, &retried) else {
        return;
    };
    let report_ = adaptive.step().expect("adaptive step");
    let substeps: Vec<u32> = report_.attempts.iter().map(|a| a.substeps).collect();
    assert_eq!(substeps, [2, 4, 8], "{case} ({})", kind.name());
}
