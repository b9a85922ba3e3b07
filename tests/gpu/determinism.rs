//! GPU determinism, dispatch counts and fault injection.
//!
//! - Two `GpuBackend`s on one adapter, same plan and state, N steps: the
//!   states are bit-identical after every step (`State::hash()` and the f64
//!   bit patterns), and so are the step reports. No floating-point atomics,
//!   colors instead of scatter, a fixed-shape reduction: nothing may depend
//!   on scheduling.
//! - Dispatch counts: a stage the scene does not use is not dispatched. The
//!   kernel calls a step reports equal `Plan::kernel_counts()` on both
//!   backends; without gravity, forces, obstacles and damping there is no
//!   friction or damping stage at all; with them, there is.
//! - Faults: a NaN/Inf force makes `step()` fail in `Predict` naming the
//!   particle; an overflowing distance makes it fail in `Project` naming the
//!   family label and the authored element index. Either way the state read
//!   back is byte-identical to the state before the step, on the CPU and on
//!   the GPU in f32 and f64, and the backend keeps working: after the force
//!   is repaired it steps bit-identically with a twin that never failed.

use crate::common;

use common::gpu::adapter_or_skip;
use hyperpbd::core::builders::ChainSpec;
use hyperpbd::{
    Backend, BackendError, ConstraintFamily, ConstraintKind, CpuBackend, Kernel, Particle, Plan,
    Scene, SceneBuilder, StageName, State, StepError,
};
use hyperpbd_gpu::{GpuBackend, Precision};

const PRECISIONS: [Precision; 2] = [Precision::F32, Precision::F64];

fn build(b: SceneBuilder) -> Scene {
    b.build().expect("test scene is valid")
}

fn gpu(adapter: &wgpu::Adapter, scene: &Scene, precision: Precision) -> GpuBackend {
    let plan = Plan::compile(scene).expect("compiles");
    GpuBackend::with_adapter(adapter, plan, &State::from_scene(scene), precision)
        .expect("GPU backend")
}

fn cpu(scene: &Scene) -> CpuBackend {
    CpuBackend::new(
        Plan::compile(scene).expect("compiles"),
        &State::from_scene(scene),
    )
    .expect("CPU backend")
}

/// Bit patterns of a state, for byte-for-byte comparison (NaN-safe).
fn bits(state: &State) -> (usize, Vec<u64>, Vec<u64>) {
    (
        state.dim,
        state.positions.iter().map(|x| x.to_bits()).collect(),
        state.velocities.iter().map(|x| x.to_bits()).collect(),
    )
}

/// A 3D chain of `n` particles (first fixed) over a plane with friction,
/// gravity and damping: contacts, friction and all colors.
fn chain_on_plane(n: usize) -> Scene {
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(6)
        .iterations(2)
        .gravity_along(1, 9.81)
        .damping(0.3);
    b.chain(&ChainSpec {
        start: vec![0.0, 0.2, 0.0],
        direction: vec![1.0, 0.1, 0.3],
        count: n,
        spacing: 0.05,
        mass: 0.1,
        compliance: 1e-6,
        fix_first: true,
    });
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.5);
    build(b)
}

// ------------------------------------------------------------ determinism

fn twins_are_bit_identical(test: &str, name: &str, scene: &Scene, steps: usize) {
    for precision in PRECISIONS {
        let Some((adapter, _)) = adapter_or_skip(test, precision) else {
            return;
        };
        let mut a = gpu(&adapter, scene, precision);
        let mut b = gpu(&adapter, scene, precision);
        for step in 1..=steps {
            let ra = a.step().expect("step a");
            let rb = b.step().expect("step b");
            assert_eq!(ra, rb, "{name} {precision} step {step}: reports differ");
            let (sa, sb) = (a.read_state().unwrap(), b.read_state().unwrap());
            assert_eq!(
                sa.hash(),
                sb.hash(),
                "{name} {precision} step {step}: two GPU runs on one adapter are not bit-identical; \
                 something depends on scheduling (float atomics, racy scatter, reduction order)"
            );
            assert_eq!(bits(&sa), bits(&sb));
        }
        let hash = a.read_state().unwrap().hash();
        println!("DETERMINISM | {name} | {steps} steps | {precision} | hash {hash:016x}");
    }
}

#[test]
fn two_gpu_runs_are_bit_identical_chain_and_contacts() {
    twins_are_bit_identical(
        "two_gpu_runs_are_bit_identical_chain_and_contacts",
        "chain on plane 3D (129)",
        &chain_on_plane(129),
        30,
    );
}

#[test]
fn two_gpu_runs_are_bit_identical_cloth() {
    twins_are_bit_identical(
        "two_gpu_runs_are_bit_identical_cloth",
        "cloth 24x24 3D",
        &hyperpbd::scenes::cloth(24),
        30,
    );
}

#[test]
fn two_gpu_runs_are_bit_identical_tesseract() {
    twins_are_bit_identical(
        "two_gpu_runs_are_bit_identical_tesseract",
        "tesseract 4D",
        &hyperpbd::scenes::tesseract(),
        2,
    );
}

#[test]
fn two_gpu_runs_are_bit_identical_incline5d() {
    twins_are_bit_identical(
        "two_gpu_runs_are_bit_identical_incline5d",
        "incline5d 5D",
        &hyperpbd::scenes::incline5d(),
        30,
    );
}

// ------------------------------------------------------------ dispatch counts

/// A free 2D chain with initial velocities: no gravity, no force, no
/// obstacle, no damping.
fn bare_chain() -> Scene {
    let mut b = SceneBuilder::new(2)
        .dt(1.0 / 60.0)
        .substeps(5)
        .iterations(3);
    for i in 0..37 {
        let v = vec![0.0, if i % 2 == 0 { 0.5 } else { -0.5 }];
        b.particle(Particle::new(vec![0.1 * i as f64, 0.0], 1.0).with_velocity(v));
    }
    b.family(ConstraintFamily::new(
        ConstraintKind::Distance,
        0.0,
        (1..37).map(|i| vec![i - 1, i]).collect(),
    ));
    build(b)
}

/// The same chain with gravity, an authored force, a frictional plane, a
/// frictionless plane and damping.
fn full_chain() -> Scene {
    let mut scene = bare_chain();
    scene.gravity = Some(vec![0.0, -9.81]);
    scene.particles[3].force = Some(vec![1.0, 0.0]);
    scene.damping = Some(hyperpbd::Damping { rate: 0.5 });
    scene.obstacles.push(hyperpbd::Obstacle::Hyperplane {
        normal: vec![0.0, 1.0],
        offset: -1.0,
        friction: 0.4,
        compliance: 0.0,
        motion: Vec::new(),
    });
    scene.obstacles.push(hyperpbd::Obstacle::Hyperplane {
        normal: vec![1.0, 0.0],
        offset: -1.0,
        friction: 0.0,
        compliance: 0.0,
        motion: Vec::new(),
    });
    scene.validate().expect("valid");
    scene
}

fn stages(counts: &[(StageName, u64)]) -> Vec<StageName> {
    counts.iter().map(|(s, _)| *s).collect()
}

fn check_counts(
    name: &str,
    scene: &Scene,
    expected_stages: &[StageName],
    adapter: Option<(&wgpu::Adapter, Precision)>,
) {
    let plan = Plan::compile(scene).unwrap();
    let counts = plan.kernel_counts();
    assert_eq!(stages(&counts), expected_stages, "{name}: plan stages");
    let mut backends: Vec<Box<dyn Backend>> = vec![Box::new(cpu(scene))];
    if let Some((adapter, precision)) = adapter {
        backends.push(Box::new(gpu(adapter, scene, precision)));
    }
    for backend in &mut backends {
        for _ in 0..3 {
            let report = backend.step().expect("step");
            assert_eq!(
                report.kernel_calls,
                counts,
                "{name} on {}: kernel calls per stage vs Plan::kernel_counts()",
                backend.name()
            );
        }
    }
}

#[test]
fn unused_stages_are_never_dispatched() {
    use StageName::*;
    let bare = bare_chain();
    let full = full_chain();
    let bare_plan = Plan::compile(&bare).unwrap();
    assert!(!bare_plan.predict.gravity && !bare_plan.predict.force);
    assert_eq!(
        bare_plan.kernel_counts(),
        vec![(Predict, 5), (Project, 5 * 3 * 2), (Velocity, 5)],
        "bare chain: 5 substeps, 3 iterations × 2 colors"
    );
    let full_plan = Plan::compile(&full).unwrap();
    assert!(full_plan.predict.gravity && full_plan.predict.force);
    // Projections: 3 iterations × (2 link colors + 2 planes); friction only
    // for the plane with μ > 0.
    assert_eq!(
        full_plan.kernel_counts(),
        vec![
            (Predict, 5),
            (Project, 5 * 3 * 4),
            (Velocity, 5),
            (Friction, 5),
            (Damping, 5)
        ]
    );
    // Nothing dynamic: nothing at all.
    let mut frozen = bare.clone();
    for p in &mut frozen.particles {
        p.fixed = true;
        p.velocity = None;
    }
    frozen.gravity = Some(vec![0.0, -9.81]);
    frozen.damping = Some(hyperpbd::Damping { rate: 1.0 });

    check_counts(
        "bare chain (cpu)",
        &bare,
        &[Predict, Project, Velocity],
        None,
    );
    check_counts(
        "full chain (cpu)",
        &full,
        &[Predict, Project, Velocity, Friction, Damping],
        None,
    );
    check_counts("frozen (cpu)", &frozen, &[], None);
    for precision in PRECISIONS {
        let Some((adapter, _)) = adapter_or_skip("unused_stages_are_never_dispatched", precision)
        else {
            return;
        };
        let with = Some((&adapter, precision));
        check_counts("bare chain", &bare, &[Predict, Project, Velocity], with);
        check_counts(
            "full chain",
            &full,
            &[Predict, Project, Velocity, Friction, Damping],
            with,
        );
        check_counts("frozen", &frozen, &[], with);
        // A kernel the plan does not schedule is refused, not run.
        let mut g = gpu(&adapter, &bare, precision);
        for k in [Kernel::Damping, Kernel::Friction { family: 0 }] {
            assert!(
                matches!(g.run_kernel(k), Err(BackendError::InvalidCall(_))),
                "{precision}: {k:?} on a plan without it"
            );
        }
    }
}

// ------------------------------------------------------------ fault injection

/// 129 particles on a plane with friction, an authored force on particle 5
/// (so the plan has a force term), gravity and damping.
fn forced_scene() -> Scene {
    let mut scene = chain_on_plane(129);
    scene.particles[5].force = Some(vec![0.5, 0.0, 0.0]);
    scene.validate().expect("valid");
    scene
}

/// Steps `backend` 5 times, injects `bad` into the forces of `particles`,
/// and checks the failure and the rollback; then repairs the forces and
/// checks that the backend steps on exactly like `twin`.
fn force_fault(
    what: &str,
    backend: &mut dyn Backend,
    twin: &mut dyn Backend,
    particles: &[usize],
    bad: f64,
) {
    for _ in 0..5 {
        backend.step().expect("healthy step");
        twin.step().expect("healthy twin step");
    }
    let before = backend.read_state().unwrap();
    let plan = backend.plan().clone();
    let mut forces = plan.force.clone();
    for &p in particles {
        forces[p * plan.dim + 1] = bad;
    }
    backend.set_forces(&forces).expect("set_forces");
    let err = backend
        .step()
        .expect_err("a non-finite force must fail the step");
    let first = *particles.iter().min().unwrap();
    match &err {
        BackendError::Step(StepError::NonFiniteParticle {
            stage,
            substep,
            particle,
        }) => {
            assert_eq!(*stage, StageName::Predict, "{what}: stage");
            assert_eq!(*substep, 0, "{what}: substep");
            assert_eq!(*particle, first, "{what}: the lowest bad particle is named");
        }
        other => panic!("{what}: expected NonFiniteParticle in Predict, got {other:?}"),
    }
    let after = backend.read_state().unwrap();
    assert_eq!(
        bits(&after),
        bits(&before),
        "{what}: state not rolled back byte for byte"
    );
    // The failure is repeatable and changes nothing.
    assert_eq!(backend.step().unwrap_err(), err, "{what}: second attempt");
    assert_eq!(bits(&backend.read_state().unwrap()), bits(&before));
    // Repaired, it goes on exactly like a twin that never failed.
    backend.set_forces(&plan.force).expect("set_forces");
    for step in 0..3 {
        backend.step().expect("repaired step");
        twin.step().expect("twin step");
        assert_eq!(
            bits(&backend.read_state().unwrap()),
            bits(&twin.read_state().unwrap()),
            "{what}: after repair, step {step} differs from the twin"
        );
    }
    println!("FAULT | {what} | {err}");
}

#[test]
fn non_finite_force_fails_in_predict_and_rolls_back() {
    let scene = forced_scene();
    for (label, bad) in [
        ("NaN", f64::NAN),
        ("+Inf", f64::INFINITY),
        ("-Inf", f64::NEG_INFINITY),
    ] {
        for particles in [&[100][..], &[100, 70]] {
            force_fault(
                &format!("cpu {label} at {particles:?}"),
                &mut cpu(&scene),
                &mut cpu(&scene),
                particles,
                bad,
            );
        }
    }
    for precision in PRECISIONS {
        let Some((adapter, _)) = adapter_or_skip(
            "non_finite_force_fails_in_predict_and_rolls_back",
            precision,
        ) else {
            return;
        };
        for (label, bad) in [("NaN", f64::NAN), ("+Inf", f64::INFINITY)] {
            for particles in [&[100][..], &[100, 70]] {
                force_fault(
                    &format!("gpu {precision} {label} at {particles:?}"),
                    &mut gpu(&adapter, &scene, precision),
                    &mut gpu(&adapter, &scene, precision),
                    particles,
                    bad,
                );
            }
        }
    }
}

/// Two distance families: constraints[0] a short chain that stays healthy,
/// constraints[1] a chain of 9 particles whose links are authored out of
/// order, so color order, plan order and authored order all differ.
fn two_families() -> Scene {
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(2)
        .iterations(1)
        .gravity_along(1, 9.81);
    for i in 0..4 {
        b.particle(Particle::new(vec![0.1 * i as f64, 1.0, 0.0], 1.0));
    }
    b.family(ConstraintFamily::new(
        ConstraintKind::Distance,
        0.0,
        (1..4).map(|i| vec![i - 1, i]).collect(),
    ));
    for i in 0..9 {
        b.particle(Particle::new(vec![0.1 * i as f64, 0.0, 0.0], 1.0));
    }
    // Links (4+a, 4+a+1), authored as a = 7, 6, 5, 4, 3, 2, 1, 0.
    let links: Vec<Vec<usize>> = (0..8).rev().map(|a| vec![4 + a, 5 + a]).collect();
    b.family(ConstraintFamily::new(ConstraintKind::Distance, 0.0, links));
    build(b)
}

/// Writes a state with particle 9 (chain 2, link a = 4 and a = 5) at
/// `far` along x and checks the Project failure and the rollback.
fn constraint_fault(what: &str, backend: &mut dyn Backend, far: f64) {
    let mut state = backend.read_state().unwrap();
    state.positions[9 * 3] = far;
    backend.write_state(&state).unwrap();
    let before = backend.read_state().unwrap();
    let plan = backend.plan().clone();
    let family = &plan.families[1];
    assert_eq!(family.label, "constraints[1]");
    // Greedy colors in authored order: authored elements 0, 2, 4, 6 (links
    // a = 7, 5, 3, 1) are color 0, the others color 1. Particle 9 is in
    // links a = 4 (authored 3, color 1) and a = 5 (authored 2, color 0):
    // color 0 is projected first, so authored element 2 fails.
    assert_eq!(family.color(0).len(), 4);
    let err = backend
        .step()
        .expect_err("an overflowing distance must fail the step");
    match &err {
        BackendError::Step(StepError::NonFiniteConstraint {
            stage,
            substep,
            family,
            family_label,
            element,
        }) => {
            assert_eq!(*stage, StageName::Project, "{what}: stage");
            assert_eq!(*substep, 0, "{what}: substep");
            assert_eq!(*family, 1, "{what}: family index in the plan");
            assert_eq!(family_label, "constraints[1]", "{what}: family label");
            assert_eq!(*element, 2, "{what}: authored element index");
        }
        other => panic!("{what}: expected NonFiniteConstraint, got {other:?}"),
    }
    assert_eq!(
        bits(&backend.read_state().unwrap()),
        bits(&before),
        "{what}: state not rolled back byte for byte"
    );
    println!("FAULT | {what} | {err}");
}

#[test]
fn overflowing_distance_fails_in_project_naming_family_and_element() {
    let scene = two_families();
    // f64 (CPU and GPU): 1e300 is finite, its square overflows to +Inf, so
    // |d| = +Inf, C = +Inf, Δλ = −Inf.
    constraint_fault("cpu x = 1e300", &mut cpu(&scene), 1e300);
    for precision in PRECISIONS {
        let Some((adapter, _)) = adapter_or_skip(
            "overflowing_distance_fails_in_project_naming_family_and_element",
            precision,
        ) else {
            return;
        };
        // f32 cannot hold 1e300 (it would be +Inf on upload and fail in
        // Predict); 1e30 is its analogue: finite, square overflows in f32.
        let far = match precision {
            Precision::F32 => 1e30,
            Precision::F64 => 1e300,
        };
        constraint_fault(
            &format!("gpu {precision} x = {far:e}"),
            &mut gpu(&adapter, &scene, precision),
            far,
        );
    }
}

/// FORMER MISMATCH (fixed; this test keeps the two agreeing). A contact whose
/// n·x overflows to +Inf (a particle astronomically far on the free side):
/// Δλ_raw = (−C − α~λ)/(w + α~) = −Inf.
///
/// - CPU (`cpu/src/project.rs`, `contact`): clamps first,
///   `dl = (l + dl).max(0.0) - l` = 0 (f64::max drops −Inf/NaN against 0),
///   then checks `dl.is_finite()`: passes, the step succeeds.
/// - GPU (`shaders/project.wgsl`, `project_contact`): checks
///   `finite(raw)` before the clamp: fails with NonFiniteConstraint
///   (obstacles[0], element 0).
///
/// Measured before the fix (lavapipe, f64): CPU `Ok`, GPU
/// `Err(NonFiniteConstraint { stage: Project, substep: 0, family: 0,
/// family_label: "obstacles[0]", element: 0 })`. One of the two checks must
/// move so both backends agree; this test asserts only that they agree.
#[test]
fn contact_overflow_fails_alike_on_cpu_and_gpu() {
    let mut b = SceneBuilder::new(3).dt(1.0 / 60.0);
    b.hyperplane(vec![1.0, 1.0, 0.0], 0.0, 0.0);
    // n·x = 0.707·1.7e308 + 0.707·1.7e308 = +Inf; each coordinate finite.
    b.particle(Particle::new(vec![1.7e308, 1.7e308, 0.0], 1.0));
    b.particle(Particle::new(vec![1.0, 1.0, 0.0], 1.0));
    let scene = build(b);
    let cpu_result = cpu(&scene).step().map(|r| r.active_contacts);
    let Some((adapter, _)) = adapter_or_skip(
        "contact_overflow_fails_alike_on_cpu_and_gpu",
        Precision::F64,
    ) else {
        return;
    };
    let gpu_result = gpu(&adapter, &scene, Precision::F64)
        .step()
        .map(|r| r.active_contacts);
    assert_eq!(
        cpu_result, gpu_result,
        "CPU vs GPU f64 on an overflowing contact"
    );
}
