//! The f32 reference (`hyperpbd_cpu::f32_reference`) on the CPU alone: what
//! it refuses, that a failed step loses nothing, that its origin shift is
//! exact, and that it is the golden path's physics within f32 rounding
//! (particle contact and the barrier kernels included).
//! (On lavapipe `gpu_differential` and `gpu_coverage` hold the GPU's f32
//! step to it bit for bit.)

use hyperpbd::core::builders::ChainSpec;
use hyperpbd::{
    Backend, Convergence, CpuBackend, F32Reference, IncrementalPotentialSettings, Kernel, Obstacle,
    Particle, Plan, ReferenceError, Scene, SceneBuilder, Solver, State,
};
use hyperpbd_verify::compare::max_abs_diff;

/// A 2D chain of 12 links, first particle fixed, over a frictional plane.
fn chain(shift: f64) -> Scene {
    let mut b = SceneBuilder::new(2)
        .dt(1.0 / 64.0)
        .substeps(4)
        .iterations(2)
        .gravity_along(1, 9.8125)
        .damping(0.25);
    b.chain(&ChainSpec {
        start: vec![shift, 1.0],
        direction: vec![1.0, 0.0],
        count: 12,
        spacing: 0.0625,
        mass: 0.125,
        compliance: 1e-6,
        fix_first: true,
    });
    let mut scene = b.build().expect("valid");
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: vec![0.0, 1.0],
        offset: 0.5,
        friction: 0.5,
        compliance: 0.0,
        motion: Vec::new(),
    });
    scene
}

fn reference(scene: &Scene, origin: &[f64]) -> F32Reference {
    let plan = Plan::compile(scene).expect("valid");
    F32Reference::new(plan, &State::from_scene(scene), origin).expect("supported")
}

#[test]
fn the_golden_path_within_f32_rounding() {
    let scene = chain(0.0);
    let mut r = reference(&scene, &[0.0, 0.0]);
    let plan = Plan::compile(&scene).expect("valid");
    let mut golden = CpuBackend::new(plan, &State::from_scene(&scene)).expect("cpu");
    let mut worst = 0.0f64;
    for _ in 0..60 {
        r.step().expect("reference step");
        golden.step().expect("golden step");
        let (a, b) = (r.read_state(), golden.read_state().expect("read"));
        worst = worst.max(max_abs_diff(&a.positions, &b.positions));
    }
    // ~1e-6 m: f32 rounding over a second of a falling, landing chain.
    // A wrong kernel (a sign, a dropped term) is off by centimetres.
    println!("f32 reference vs golden path, 60 frames: {worst:e} m");
    assert!(worst > 0.0, "f32 must round somewhere");
    assert!(worst < 1e-4, "{worst:e} m");
}

#[test]
fn a_scene_far_from_the_origin_runs_as_at_the_origin() {
    // 2^16 m away, shifted by an origin of the same amount: the same
    // device coordinates and plane offsets, so the same bits.
    let (near, far) = (chain(0.0), chain(65536.0));
    let mut a = reference(&near, &[0.0, 0.0]);
    let mut b = reference(&far, &[65536.0, 0.0]);
    for frame in 1..=30 {
        a.step().expect("near");
        b.step().expect("far");
        let mut moved_back = b.read_state();
        for p in moved_back.positions.chunks_exact_mut(2) {
            p[0] -= 65536.0;
        }
        let near_state = a.read_state();
        assert_eq!(near_state.positions, moved_back.positions, "frame {frame}");
        assert_eq!(
            near_state.velocities, moved_back.velocities,
            "frame {frame}"
        );
    }
}

#[test]
fn a_failed_step_leaves_the_state_as_it_was() {
    let scene = chain(0.0);
    let mut r = reference(&scene, &[0.0, 0.0]);
    r.step().expect("first step");
    let mut state = r.read_state();
    let before = state.clone();
    // 1e39 is finite in f64 and +∞ in f32: the prediction of particle 5
    // fails.
    state.velocities[5 * 2] = 1e39;
    r.write_state(&state).expect("write");
    let written = r.read_state();
    match r.step() {
        Err(ReferenceError::NonFinite {
            substep: 0,
            kernel: Kernel::Predict,
            index: 5,
        }) => {}
        other => panic!("expected a prediction failure at particle 5, got {other:?}"),
    }
    assert_eq!(r.read_state(), written, "the failed step changed the state");
    r.write_state(&before).expect("write");
    r.step().expect("a good state steps again");
}

/// The bottom 96 grains of sandpile2d (16 per row): a small pile on a
/// rough floor, ball–ball friction 0.6.
fn small_pile() -> Scene {
    let mut scene = hyperpbd::scenes::sandpile2d();
    scene.particles.truncate(96);
    scene
}

#[test]
fn particle_contact_is_the_golden_path_within_f32_rounding() {
    let scene = small_pile();
    let mut r = reference(&scene, &[0.0, 0.0]);
    let plan = Plan::compile(&scene).expect("valid");
    let families = plan.families.len();
    let mut golden = CpuBackend::new(plan, &State::from_scene(&scene)).expect("cpu");
    let (mut worst, mut overlap, mut active) = (0.0f64, 0.0f64, 0usize);
    for _ in 0..20 {
        // Each frame from the reference's own state (f32 values, exact in
        // f64): the difference is one frame's f32 rounding.
        golden.write_state(&r.read_state()).expect("write");
        r.step().expect("reference step");
        let report = golden.step().expect("golden step");
        let (a, b) = (r.read_state(), golden.read_state().expect("read"));
        worst = worst.max(max_abs_diff(&a.positions, &b.positions));
        let (residuals, contacts) = r.residuals();
        // The families' residuals, then the deepest particle overlap.
        assert_eq!(residuals.len(), families + 1);
        assert_eq!(report.residuals.len(), families + 1);
        overlap =
            overlap.max((residuals[families] - report.residuals[families].max_violation).abs());
        active = active.max(contacts);
    }
    // Grains landing and settling onto each other, one frame at a time:
    // f32 rounding only. A wrong contact kernel (a sign, a missed pair, no
    // averaging) is off by a fraction of the 0.02 m radius.
    println!(
        "f32 reference vs golden path, small pile, 20 frames of one frame each: x {worst:e} m, \
         overlap {overlap:e} m, up to {active} active contacts"
    );
    assert!(active > 0, "the pile must touch");
    assert!(worst > 0.0, "f32 must round somewhere");
    assert!(worst < 1e-5, "{worst:e} m");
    assert!(overlap < 1e-5, "{overlap:e} m");
}

#[test]
fn what_it_does_not_run_is_refused_by_name() {
    // The incremental-potential step (Minimise).
    let mut ball = Scene::new(2, 1.0 / 60.0, 1, 1);
    ball.particles.push(Particle::new(vec![0.0, 1.0], 1.0));
    ball.gravity = Some(vec![0.0, -9.81]);
    ball.solver = Solver::IncrementalPotential(IncrementalPotentialSettings {
        barrier_stiffness: 1e3,
        activation_distance: 0.01,
        convergence: Convergence::PackedGradient { tolerance: 1e-8 },
        max_iterations: 50,
        cg_iterations: None,
        warm_start: None,
        friction_slip_velocity: None,
    });
    let plan = Plan::compile(&ball).expect("valid");
    let refused = F32Reference::new(plan, &State::from_scene(&ball), &[0.0, 0.0]);
    assert!(
        matches!(&refused, Err(ReferenceError::Unsupported(what)) if what == "Minimise"),
        "{:?}",
        refused.err()
    );
    // XPBD with the primal residual: run, material families too.
    let mut carried = chain(0.0);
    carried.solver = Solver::Xpbd(hyperpbd::XpbdSettings {
        primal_residual: true,
    });
    let plan = Plan::compile(&carried).expect("valid");
    assert!(F32Reference::new(plan, &State::from_scene(&carried), &[0.0, 0.0]).is_ok());
    let mut jelly = hyperpbd::scenes::jelly4d();
    jelly.solver = carried.solver.clone();
    let plan = Plan::compile(&jelly).expect("valid");
    assert!(F32Reference::new(plan, &State::from_scene(&jelly), &[0.0; 4]).is_ok());
    // Particle contact and material families are run, not refused.
    let balls = hyperpbd::scenes::by_name("sandpile2d").expect("scene");
    let plan = Plan::compile(&balls).expect("valid");
    assert!(F32Reference::new(plan, &State::from_scene(&balls), &[0.0, 0.0]).is_ok());
    let jelly = hyperpbd::scenes::jelly4d();
    let plan = Plan::compile(&jelly).expect("valid");
    assert!(F32Reference::new(plan, &State::from_scene(&jelly), &[0.0; 4]).is_ok());
    // Wrong lengths.
    let scene = chain(0.0);
    let mut r = reference(&scene, &[0.0, 0.0]);
    assert!(matches!(
        r.set_forces(&[0.0; 3]),
        Err(ReferenceError::Length {
            what: "forces",
            got: 3,
            expected: 24
        })
    ));
}

#[test]
fn a_material_scene_runs_within_f32_rounding_of_the_golden_path() {
    // jelly4d: a 4D Neo-Hookean tesseract on a plane (stvk and the
    // membrane case are held to the GPU bit for bit in gpu_materials).
    let jelly = hyperpbd::scenes::jelly4d();
    let mut r = reference(&jelly, &[0.0; 4]);
    let plan = Plan::compile(&jelly).expect("valid");
    let mut golden = CpuBackend::new(plan, &State::from_scene(&jelly)).expect("cpu");
    let mut worst = 0.0f64;
    for _ in 0..10 {
        r.step().expect("reference step");
        golden.step().expect("golden step");
        let (a, b) = (r.read_state(), golden.read_state().expect("read"));
        worst = worst.max(max_abs_diff(&a.positions, &b.positions));
    }
    println!("f32 reference vs golden path, jelly4d 10 frames: {worst:e} m");
    assert!(worst > 0.0 && worst < 1e-4, "{worst:e} m");
    let (residuals, _) = r.residuals();
    assert!(residuals.iter().all(|r| r.is_finite()), "{residuals:?}");
}

#[test]
fn an_element_the_law_refuses_fails_its_projection() {
    // Two Neo-Hookean triangles; the shared corner thrown through the
    // opposite edge in one step (x2 = (1, 1) + 0.01·(−300, −300)): J < 0,
    // the law refuses, the step fails in Project and changes nothing.
    let mut scene = hyperpbd::Scene::new(2, 0.01, 1, 1);
    for p in [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]] {
        scene
            .particles
            .push(hyperpbd::Particle::new(p.to_vec(), 1.0));
    }
    scene.particles[2].velocity = Some(vec![-300.0, -300.0]);
    scene.constraints.push(hyperpbd::ConstraintFamily::material(
        hyperpbd::ConstraintKind::NeoHookean,
        100.0,
        0.3,
        vec![vec![0, 1, 2], vec![0, 2, 3]],
    ));
    let mut r = reference(&scene, &[0.0, 0.0]);
    let before = r.read_state();
    match r.step() {
        Err(ReferenceError::NonFinite {
            kernel: Kernel::Project { family: 0, .. },
            ..
        }) => {}
        other => panic!("expected a refused material projection, got {other:?}"),
    }
    assert_eq!(r.read_state(), before);
}

/// The barrier kernels' reference (`f32_reference::barrier`) against the
/// golden path in 3D over a plane, a triangle and a tetrahedron: the
/// smallest distance within δd = 16 (N + 4) ε S, the energy within the
/// spread of the law over d ± δd plus 16 ε |b| and the f32 ln's error, the
/// fraction certified (d > 0 along the cut step, in f64) above 9 δd, and
/// a particle at d ≤ 0 reads energy f32::MAX (+∞) and fraction 0. (On
/// lavapipe `gpu_barrier` holds the kernels to it bit for bit.)
#[test]
fn barrier_kernels_are_the_golden_path_within_f32_rounding() {
    use hyperpbd::barrier::{
        BarrierLaw, BarrierObstacles, ParticleBarrier, evaluate_particle_barrier,
    };
    use hyperpbd_cpu::f32_reference::barrier as reference;

    let mut scene = Scene::new(3, 0.01, 1, 1);
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: vec![0.0, 0.0, 1.0],
        offset: -0.1,
        friction: 0.0,
        compliance: 0.0,
        motion: Vec::new(),
    });
    scene.obstacles.push(Obstacle::SimplexMesh {
        vertices: vec![
            vec![0.0, 0.0, -0.05],
            vec![1.0, 0.0, -0.05],
            vec![0.0, 1.0, -0.05],
            vec![0.3, 0.3, -0.4],
        ],
        simplices: vec![vec![0, 1, 2], vec![0, 1, 2, 3]],
        friction: 0.0,
        motion: Vec::new(),
    });
    let geometry = BarrierObstacles::compile(&scene);
    let law = BarrierLaw {
        stiffness: 50.0,
        activation_distance: 0.25,
    };
    let inputs = reference::BarrierInputs::new(3, &law, &geometry);
    let e = f64::from(f32::EPSILON);
    let mut golden = ParticleBarrier::new(3);
    let mut n = [0.0; 3];
    let (mut compared, mut cut) = (0, 0);
    for k in 0..8 * 8 * 8 {
        let x = [
            -0.2 + 0.2 * (k % 8) as f64,
            -0.2 + 0.2 * (k / 8 % 8) as f64,
            0.01 + 0.04 * (k / 64) as f64,
        ];
        let r = 0.01;
        let step = [0.05, -0.1, -0.3];
        let d: Vec<f64> = (0..geometry.len())
            .map(|o| geometry.distance(o, &x, r, &mut n))
            .collect();
        let delta_d = 16.0 * 7.0 * e * (1.5 + r);
        let smallest = d.iter().copied().fold(f64::INFINITY, f64::min);
        let x32 = x.map(|c| c as f32);
        let step32 = step.map(|c| c as f32);
        let terms = reference::evaluate(&inputs, &x32, r as f32);
        let fraction = f64::from(reference::filter_fraction(&inputs, &x32, r as f32, &step32));
        if smallest <= 9.0 * delta_d {
            continue; // the f32 floor
        }
        compared += 1;
        evaluate_particle_barrier(&law, &geometry, &x, r, &mut golden);
        let dd = (f64::from(terms.min_distance) - golden.min_distance).abs();
        assert!(dd <= delta_d, "{x:?}: distance {dd:e} > {delta_d:e}");
        let mut bound = 0.0;
        for &di in &d {
            if di - delta_d >= law.activation_distance {
                continue;
            }
            let b = law.evaluate(di).0;
            let spread = [di - delta_d, di + delta_d]
                .map(|t| (law.evaluate(t).0 - b).abs())
                .into_iter()
                .fold(0.0, f64::max);
            let gap = (di - law.activation_distance).abs();
            bound += spread + 16.0 * e * b.abs() + law.stiffness * gap * gap * 2f64.powi(-21);
        }
        let de = (f64::from(terms.energy) - golden.energy).abs();
        assert!(de <= bound, "{x:?}: energy {de:e} > {bound:e}");
        if fraction < 1.0 {
            cut += 1;
        }
        for s in 0..=16 {
            let y: Vec<f64> = (0..3)
                .map(|a| x[a] + fraction * s as f64 / 16.0 * step[a])
                .collect();
            for o in 0..geometry.len() {
                let after = geometry.distance(o, &y, r, &mut n);
                assert!(after > 0.0, "{x:?}: fraction {fraction} crosses {o}");
            }
        }
    }
    eprintln!("barrier reference vs golden: {compared} particles compared, {cut} steps cut");
    assert!(compared > 100 && cut > 0, "{compared} compared, {cut} cut");
    // Inside the tetrahedron and below the plane: d ≤ 0.
    let inside = [0.1f32, 0.1, -0.2];
    let terms = reference::evaluate(&inputs, &inside, 0.01);
    assert_eq!(terms.energy, f32::MAX, "infeasible reads +∞");
    assert!(terms.min_distance < 0.0);
    let fraction = reference::filter_fraction(&inputs, &inside, 0.01, &[0.0, 0.0, 1.0]);
    assert_eq!(fraction, 0.0, "infeasible admits no step");
}
