//! The plan, refusals and rollback, validation, JSON, the golden hash.

use super::*;

#[test]
fn barrier_scene_compiles_to_the_minimise_stage_only() {
    let scene = drop_scene(1.0, 0.01);
    let plan = Plan::compile(&scene).unwrap();
    assert_eq!(plan.stages, vec![StageName::Minimise]);
    assert_eq!(plan.substep_kernels, vec![Kernel::Minimise]);
    assert!(plan.families.is_empty());
    assert!(plan.incremental_potential().is_some());
    let mut xpbd = scene.clone();
    xpbd.solver = Solver::default();
    let plan = Plan::compile(&xpbd).unwrap();
    assert!(plan.incremental_potential().is_none());
    assert!(!plan.stages.contains(&StageName::Minimise));
}

#[test]
fn an_infeasible_start_is_refused_before_anything_moves() {
    let scene = drop_scene(1.0, 0.01);
    let mut b = cpu(&scene);
    b.step().unwrap();
    let mut bad = b.read_state().unwrap();
    bad.positions[1] = -1.0; // below the plane
    b.write_state(&bad).unwrap();
    let err = b.step().unwrap_err();
    match &err {
        BackendError::Step(StepError::MinimisationRefused { report, .. }) => {
            assert_eq!(report.initial_residual, None);
        }
        other => panic!("unexpected {other:?}"),
    }
    let after = b.read_state().unwrap();
    assert_eq!(after.hash(), bad.hash());
    println!("{err}");
}

/// A refusal after accepted substeps: gravity of 1e157 m/s² pointing away
/// from the plane moves the particle by h²g = 1e153 m in substep 0; every
/// substep adds as much speed, until the Newton slope −g·Δ ≈ m|Δ|² overflows
/// (|Δ| ≈ 1.3e154) and the minimisation is refused as non-finite. The state
/// has moved by then (asserted through the refusal's substep > 0), and the
/// step must restore it byte for byte.
#[test]
fn a_refusal_after_accepted_substeps_rolls_back_byte_for_byte() {
    let mut scene = drop_scene(0.0, 0.01);
    scene.dt = 0.2;
    scene.substeps = 20; // h = 0.01
    scene.gravity = Some(vec![0.0, 1e157, 0.0]);
    scene.solver = ip(
        1e3,
        0.01,
        Convergence::MaxAccelerationResidual { tolerance: 1.0 },
        4,
    );
    let mut b = cpu(&scene);
    let before = b.read_state().unwrap();
    let err = b.step().unwrap_err();
    match &err {
        BackendError::Step(StepError::MinimisationRefused {
            substep, reason, ..
        }) => {
            assert!(*substep > 0, "refused in substep {substep}: nothing moved");
            assert!(
                matches!(reason, hyperpbd::Refusal::NonFinite { particle: 0 }),
                "{reason:?}"
            );
        }
        other => panic!("unexpected {other:?}"),
    }
    assert_eq!(b.read_state().unwrap().hash(), before.hash());
    println!("{err}");
}

#[test]
fn empty_and_all_fixed_barrier_scenes_step() {
    let mut scene = drop_scene(1.0, 0.01);
    scene.particles.clear();
    let mut b = cpu(&scene);
    assert!(b.step().unwrap().minimisation.is_empty());
    let mut scene = drop_scene(1.0, 0.01);
    scene.particles = vec![Particle::fixed(vec![0.0, -1.0, 0.0])];
    let mut b = cpu(&scene);
    b.step().unwrap();
}

fn err(scene: &Scene) -> SceneError {
    scene.validate().expect_err("should be rejected")
}

#[test]
fn barrier_validation_names_the_field() {
    let base = drop_scene(1.0, 0.01);
    let mut s = base.clone();
    s.solver = ip(
        0.0,
        0.01,
        Convergence::PackedGradient { tolerance: 1e-8 },
        5,
    );
    assert!(
        matches!(err(&s), SceneError::NonPositive { path, .. } if path == "solver.barrier_stiffness")
    );
    s.solver = ip(
        1.0,
        -1.0,
        Convergence::PackedGradient { tolerance: 1e-8 },
        5,
    );
    assert!(
        matches!(err(&s), SceneError::NonPositive { path, .. } if path == "solver.activation_distance")
    );
    s.solver = ip(1.0, 0.1, Convergence::PackedGradient { tolerance: 0.0 }, 5);
    assert!(
        matches!(err(&s), SceneError::NonPositive { path, .. } if path == "solver.convergence.tolerance")
    );
    s.solver = ip(
        1.0,
        0.1,
        Convergence::PackedGradient {
            tolerance: f64::NAN,
        },
        5,
    );
    assert!(matches!(err(&s), SceneError::NonFinite { .. }));
    s.solver = ip(1.0, 0.1, Convergence::PackedGradient { tolerance: 1.0 }, 0);
    assert!(
        matches!(err(&s), SceneError::NonPositive { path, .. } if path == "solver.max_iterations")
    );

    let mut s = base.clone();
    s.particles[0].position[1] = 0.05; // exactly the radius: d = 0
    assert!(matches!(
        err(&s),
        SceneError::BarrierInfeasible { obstacle: 0, .. }
    ));

    let mut s = base.clone();
    s.damping = Some(hyperpbd::Damping { rate: 1.0 });
    assert!(matches!(err(&s), SceneError::UnsupportedBySolver { path, .. } if path == "damping"));

    let mut s = base.clone();
    s.collisions = Some(hyperpbd::Collisions {
        friction: 0.0,
        margin: 0.0,
    });
    // Ball–ball barriers are terms of the coupled step (issue 16).
    let coupled = |s: &Scene| {
        Plan::compile(s)
            .expect("compiles")
            .incremental_potential()
            .is_some_and(|ip| ip.coupled.is_some())
    };
    assert!(coupled(&s));

    let mut s = base.clone();
    s.obstacles[0] = Obstacle::Hyperplane {
        normal: vec![0.0, 1.0, 0.0],
        offset: 0.0,
        friction: 0.3,
        compliance: 0.0,
        motion: Vec::new(),
    };
    // Lagged friction is a term of the coupled step (issue 16).
    assert!(coupled(&s));

    let mut s = base.clone();
    s.particles.push(Particle::new(vec![0.0, 3.0, 0.0], 1.0));
    s.constraints.push(hyperpbd::ConstraintFamily::new(
        hyperpbd::ConstraintKind::Distance,
        0.0,
        vec![vec![0, 1]],
    ));
    // A spring needs α > 0 (issue 16): the refusal names the field.
    assert!(
        matches!(err(&s), SceneError::UnsupportedBySolver { path, .. } if path == "constraints[0].compliance")
    );

    let mesh = |vertices: Vec<Vec<f64>>, simplices: Vec<Vec<usize>>| {
        let mut s = base.clone();
        s.obstacles.push(Obstacle::SimplexMesh {
            vertices,
            simplices,
            friction: 0.0,
            motion: Vec::new(),
        });
        s
    };
    let square = vec![
        vec![0.0, -1.0, 0.0],
        vec![1.0, -1.0, 0.0],
        vec![0.0, -1.0, 1.0],
        vec![2.0, -1.0, 0.0],
    ];
    // Collinear triangle.
    assert!(matches!(
        err(&mesh(square.clone(), vec![vec![0, 1, 3]])),
        SceneError::DegenerateSimplex { path, .. } if path == "obstacles[1].simplices[0]"
    ));
    assert!(matches!(
        err(&mesh(square.clone(), vec![vec![0, 1, 2], vec![0, 1, 7]])),
        SceneError::VertexOutOfRange { path, index: 7, count: 4 } if path == "obstacles[1].simplices[1][2]"
    ));
    assert!(matches!(
        err(&mesh(square.clone(), vec![vec![0, 0]])),
        SceneError::DegenerateSimplex { .. }
    ));
    assert!(matches!(
        err(&mesh(square.clone(), vec![vec![0, 1, 2], vec![0, 1]])),
        SceneError::WrongSimplexArity { .. }
    ));
    assert!(matches!(
        err(&mesh(vec![vec![0.0, 1.0]], vec![])),
        SceneError::WrongLength { .. }
    ));
    // A simplex mesh under XPBD is a contact (tests/cpu/xpbd_mesh.rs), but not
    // with the primal residual yet.
    let mut s = mesh(square, vec![vec![0, 1, 2]]);
    s.validate().expect("valid barrier scene");
    s.solver = Solver::default();
    s.obstacles.remove(0);
    s.validate().expect("a simplex mesh is an XPBD contact");
    s.solver = Solver::Xpbd(hyperpbd::XpbdSettings {
        primal_residual: true,
    });
    assert!(matches!(
        err(&s),
        SceneError::UnsupportedBySolver { solver: "xpbd", path, .. } if path == "obstacles[0]"
    ));
}

#[test]
fn barrier_scene_json_round_trips() {
    let text = r#"{
      "dim": 2, "dt": 0.01,
      "gravity": [0.0, -9.81],
      "particles": [{"position": [0.5, 1.0], "mass": 1.0}],
      "obstacles": [
        {"type": "hyperplane", "normal": [0.0, 1.0]},
        {"type": "simplex_mesh", "vertices": [[0.0, 0.5], [1.0, 0.5]], "simplices": [[0, 1]]}
      ],
      "solver": {"type": "incremental_potential", "barrier_stiffness": 100.0,
                 "activation_distance": 0.05,
                 "convergence": {"kind": "max_acceleration_residual", "tolerance": 1e-6},
                 "max_iterations": 30}
    }"#;
    let scene = Scene::from_json_str(text).expect("parses");
    assert_eq!(
        scene.solver,
        ip(
            100.0,
            0.05,
            Convergence::MaxAccelerationResidual { tolerance: 1e-6 },
            30
        )
    );
    let again = Scene::from_json_str(&scene.to_json_string()).expect("round trip");
    assert_eq!(again, scene);
    let xpbd =
        Scene::from_json_str(r#"{"dim": 1, "dt": 0.1, "solver": {"type": "xpbd"}}"#).unwrap();
    assert_eq!(xpbd.solver, Solver::default());
    assert!(!xpbd.to_json_string().contains("solver"));
    for bad in [
        r#"{"dim": 1, "dt": 0.1, "solver": {"type": "incremental_potential", "barrier_stiffness": 1, "activation_distance": 1, "convergence": {"kind": "packed_gradient", "tolerance": 1}, "max_iterations": 3, "extra": 1}}"#,
        r#"{"dim": 1, "dt": 0.1, "solver": {"type": "incremental_potential", "barrier_stiffness": 1, "activation_distance": 1, "convergence": {"kind": "energy", "tolerance": 1}, "max_iterations": 3}}"#,
        r#"{"dim": 1, "dt": 0.1, "obstacles": [{"type": "simplex_mesh", "vertices": [[0.0]]}]}"#,
        r#"{"dim": 1, "dt": 0.1, "obstacles": [{"type": "hyperplane", "normal": [1.0], "simplices": []}]}"#,
    ] {
        let e = Scene::from_json_str(bad).expect_err(bad);
        assert!(matches!(e, SceneError::Json { .. }), "{e}");
    }
}

/// 200 particles of mixed mass hitting a plane at up to 100 m/s with an
/// acceleration tolerance of 1e-4 m/s²: deep in the barrier (d ~ 1e-5,
/// b'' ~ 1e9 N/m) the f64 residual's rounding floor b'' u X / m can exceed
/// the tolerance. Those minimisations end `RoundingFloor` (typed, accepted)
/// — never refused, never at d ≤ 0.
#[test]
fn many_fast_particles_end_converged_or_at_the_rounding_floor() {
    let mut scene = Scene::new(3, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, -9.81, 0.0]);
    let mut rng = Lcg(203);
    for _ in 0..200 {
        scene.particles.push(
            Particle::new(
                vec![0.3 * rng.next(), 1.0 + 0.5 * rng.next(), 0.3 * rng.next()],
                1.0 + 0.5 * rng.next(),
            )
            .with_velocity(vec![0.0, -100.0 * (0.5 + 0.5 * rng.next()), 0.0])
            .with_radius(0.05),
        );
    }
    scene.obstacles.push(plane(vec![0.0, 1.0, 0.0], 0.0));
    scene.solver = ip(
        1e3,
        0.01,
        Convergence::MaxAccelerationResidual { tolerance: 1e-4 },
        200,
    );
    let mut b = cpu(&scene);
    let (mut converged, mut floor) = (0, 0);
    let mut smallest = f64::INFINITY;
    for _ in 0..120 {
        let report = b.step().expect("accepted");
        for m in &report.minimisation {
            match m.status {
                MinimisationStatus::Converged => converged += 1,
                MinimisationStatus::RoundingFloor => floor += 1,
                ref other => panic!("unexpected {other:?}"),
            }
        }
        let d = min_distance(&scene, &b.read_state().unwrap());
        assert!(d > 0.0);
        smallest = smallest.min(d);
    }
    println!(
        "200 particles at up to 100 m/s: {converged} converged, {floor} at the rounding floor, smallest d {smallest:e}"
    );
}

/// Golden: the CPU barrier path is bit-identical across runs and machines
/// (the arithmetic ln of `material::ln`, which `shaders/ln_f64.wgsl`
/// reproduces bit for bit; no contraction; fixed reduction tree). If this hash
/// changes, the barrier path's arithmetic changed: say why in the commit
/// and update the constant.
#[test]
fn barrier4d_golden_hash() {
    let scene = hyperpbd::scenes::barrier4d();
    let run = || {
        let mut b = cpu(&scene);
        for _ in 0..60 {
            b.step().expect("step");
        }
        b.read_state().expect("state").hash()
    };
    let first = run();
    assert_eq!(first, run(), "two runs differ");
    println!("barrier4d after 60 steps: {first:016x}");
    assert_eq!(
        first, BARRIER4D_HASH,
        "barrier4d golden hash changed: {first:016x}"
    );
}

/// Re-pinned when `BarrierLaw::evaluate` moved from `libm::log` to
/// `material::ln` (issue 16: the GPU coupled step reproduces every barrier
/// value in f64 only with the ln both sides compute by the same arithmetic);
/// was 0x1e50_ebc2_b2ec_adce.
const BARRIER4D_HASH: u64 = 0xb6c9_8c92_c498_0e1c;
