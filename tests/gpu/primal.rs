//! XPBD with the primal residual on the GPU (`shaders/primal.wgsl`): on
//! lavapipe gpu-f64 is the golden path (`cpu/src/consistent.rs`) bit for
//! bit — states and residuals every frame from the start, in the exact
//! and the fused schedules — for compliant distance and tether chains, a
//! cloth on a plane with friction, simplex and oriented measures, and
//! expression families of all three relations; a failed step puts the
//! carried forces back with the state, a written state starts them over;
//! what the GPU does not run yet is refused by name.

use crate::common;

use common::exact::{assert_f32_reference_step, assert_identical_if_claimed, bits};
use common::expressions::as_expressions;
use common::gpu::adapter_or_skip;
use hyperpbd::builders::{Patch, PatchSpec};
use hyperpbd::kinds::Relation;
use hyperpbd::{
    Backend, BackendError, ConstraintFamily, ConstraintKind, CpuBackend, F32Reference, Plan, Scene,
    Solver, State, XpbdSettings, scenes,
};
use hyperpbd_gpu::{GpuBackend, Precision, StepMode};

/// `scene` with the primal-residual update.
fn primal(mut scene: Scene) -> Scene {
    scene.solver = Solver::Xpbd(XpbdSettings {
        primal_residual: true,
    });
    scene
}

/// A compliant chain of `links` links hanging from a fixed end (distance
/// or tether), with gravity.
fn chain(kind: ConstraintKind, compliance: f64) -> Scene {
    let mut b = hyperpbd::SceneBuilder::new(2)
        .dt(1.0 / 60.0)
        .substeps(4)
        .iterations(3)
        .gravity_along(1, 9.81);
    for i in 0..=12 {
        let x = vec![0.1 * i as f64, 1.0];
        b.particle(match i {
            0 => hyperpbd::Particle::fixed(x),
            _ => hyperpbd::Particle::new(x, 0.05),
        });
    }
    let edges = (1..=12).map(|i| vec![i - 1, i]).collect();
    b.family(ConstraintFamily::new(kind, compliance, edges));
    b.build().expect("chain")
}

/// A strip of triangles in R³ hanging from two fixed corners, their
/// squared areas held (simplex measures) with compliant edges.
fn triangle_areas() -> Scene {
    let mut b = hyperpbd::SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(4)
        .iterations(2)
        .gravity_along(1, 9.81);
    for i in 0..10 {
        let x = vec![
            0.1 * (i / 2) as f64,
            1.0,
            0.1 * (i % 2) as f64 + 0.01 * i as f64,
        ];
        b.particle(match i {
            0 | 1 => hyperpbd::Particle::fixed(x),
            _ => hyperpbd::Particle::new(x, 0.05),
        });
    }
    let triangles: Vec<Vec<usize>> = (0..8).map(|i| vec![i, i + 1, i + 2]).collect();
    let edges: Vec<Vec<usize>> = (0..9).map(|i| vec![i, i + 1]).collect();
    b.family(ConstraintFamily::new(
        ConstraintKind::SimplexMeasure,
        1e-7,
        triangles,
    ));
    b.family(ConstraintFamily::new(ConstraintKind::Distance, 1e-5, edges));
    b.build().expect("strip")
}

/// Particles resting on a plane z = 0 under gravity tilted just past
/// their friction angle (tan θ = 1.0005 μ, μ = 0.4): each substep's
/// tangential move is 1.0005 times the static bound μ w λ, so they slide
/// (a bound off by 1e-3 would hold them).
fn friction_boundary() -> Scene {
    let mu: f64 = 0.4;
    let theta = (1.0005 * mu).atan();
    let mut b = hyperpbd::SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(4)
        .iterations(2);
    b.scene_mut().gravity = Some(vec![9.81 * theta.sin(), 0.0, -9.81 * theta.cos()]);
    for i in 0..4 {
        b.particle(hyperpbd::Particle::new(vec![0.3 * i as f64, 0.0, 0.0], 0.1));
    }
    b.hyperplane(vec![0.0, 0.0, 1.0], 0.0, mu);
    b.build().expect("valid")
}

/// StVK triangles crushed to a tenth of their height, one free node
/// each, at one long substep: M + K/α~ is indefinite at the first update,
/// so the Newton matrix is built again from the PSD-projected frame
/// Hessian.
fn crushed_triangles() -> Scene {
    let mut b = hyperpbd::SceneBuilder::new(2)
        .dt(1.0 / 60.0)
        .substeps(1)
        .iterations(3);
    let (mut triangles, mut upright) = (Vec::new(), Vec::new());
    for t in 0..3 {
        let x = 0.5 * t as f64;
        let first = b.scene_mut().particles.len();
        b.particle(hyperpbd::Particle::fixed(vec![x, 0.0]));
        b.particle(hyperpbd::Particle::fixed(vec![x + 0.1, 0.0]));
        b.particle(hyperpbd::Particle::new(vec![x + 0.05, 0.0087], 0.05));
        triangles.push(vec![first, first + 1, first + 2]);
        upright.extend([vec![x, 0.0], vec![x + 0.1, 0.0], vec![x + 0.05, 0.087]]);
    }
    let mut family = ConstraintFamily::new(ConstraintKind::Stvk, 0.0, triangles);
    family.youngs_modulus = Some(1e5);
    family.poisson_ratio = Some(0.3);
    family.rest_positions = Some(upright);
    b.family(family);
    b.build().expect("valid")
}

fn cases() -> Vec<(&'static str, Scene, usize)> {
    // A cloth (distance, fixed corners) falling on a plane with friction.
    let mut cloth = scenes::cloth(8);
    if let Some(hyperpbd::Obstacle::Hyperplane { friction, .. }) = cloth.obstacles.first_mut() {
        *friction = 0.4;
    }
    let tesseract = scenes::tesseract();
    let plane = as_expressions(
        &scenes::cloth(6),
        ConstraintKind::Distance,
        "norm(x1 - x0)",
        Relation::Equal,
    );
    let mut tethers = chain(ConstraintKind::Tether, 0.0);
    tethers.constraints[0].kind = ConstraintKind::Tether;
    let tether_expression = as_expressions(
        &tethers,
        ConstraintKind::Tether,
        "norm(x1 - x0)",
        Relation::AtMost,
    );
    let mut floor = chain(ConstraintKind::Distance, 1e-6);
    floor.constraints.push(
        ConstraintFamily::expression("x0[1]", 0.0, (1..=12).map(|i| vec![i]).collect())
            .with_relation(Relation::AtLeast),
    );
    floor.constraints[1].rest = Some(vec![0.3; 12]);
    vec![
        (
            "compliant distance chain",
            chain(ConstraintKind::Distance, 1e-4),
            30,
        ),
        ("tether chain", tethers, 30),
        ("cloth 8² on a plane, friction 0.4", cloth, 30),
        ("tesseract (oriented measure)", tesseract, 12),
        ("triangle areas (simplex measure)", triangle_areas(), 20),
        ("cloth 6² distance expressions", plane, 20),
        ("tether expressions", tether_expression, 20),
        ("chain on an x1 ≥ 0.3 expression floor", floor, 30),
        (
            "particles past their friction angle",
            friction_boundary(),
            20,
        ),
        (
            "crushed StVK triangles (PSD projection)",
            crushed_triangles(),
            6,
        ),
    ]
    .into_iter()
    .map(|(name, scene, frames)| (name, primal(scene), frames))
    .collect()
}

fn residual_bits(report: &hyperpbd::StepReport) -> Vec<u64> {
    (report.residuals.iter())
        .map(|r| r.max_violation.to_bits())
        .collect()
}

/// Runs `scene` from `state` on the CPU and on gpu-f64 in the exact and
/// fused schedules for `frames` frames; asserts every frame's state and
/// residuals bit for bit where the adapter claims it. Returns the frames
/// checked.
fn assert_golden(
    adapter: &wgpu::Adapter,
    summary: &hyperpbd_gpu::AdapterSummary,
    (name, scene, state): (&str, &Scene, &State),
    frames: usize,
) -> usize {
    let plan = Plan::compile(scene).expect("compiles");
    let mut cpu = CpuBackend::new(plan.clone(), state).expect("cpu");
    let mut gpus: Vec<(StepMode, GpuBackend)> = [StepMode::Exact, StepMode::Fused]
        .into_iter()
        .map(|mode| {
            let gpu = common::gpu::in_mode(adapter, (&plan, state), Precision::F64, mode)
                .unwrap_or_else(|e| panic!("{name} {mode:?}: {e}"));
            (mode, gpu)
        })
        .collect();
    let mut checked = 0;
    for frame in 0..frames {
        let a = cpu
            .step()
            .unwrap_or_else(|e| panic!("{name} cpu {frame}: {e}"));
        let sa = cpu.read_state().expect("cpu");
        for (mode, gpu) in &mut gpus {
            let b = gpu
                .step()
                .unwrap_or_else(|e| panic!("{name} {mode:?} {frame}: {e}"));
            let sb = gpu.read_state().expect("gpu");
            let what = format!("{name} {mode:?} frame {frame}");
            if assert_identical_if_claimed(summary, &what, &sa, &sb) {
                assert_eq!(residual_bits(&a), residual_bits(&b), "{what}: residuals");
                checked += 1;
            }
        }
    }
    assert!(
        bits(&cpu.read_state().expect("s")) != bits(state),
        "{name}: moved"
    );
    checked
}

#[test]
fn gpu_f64_is_the_golden_primal_update_bit_for_bit() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_primal f64", Precision::F64) else {
        return;
    };
    let mut frames_checked = 0;
    for (name, scene, frames) in cases() {
        let state = State::from_scene(&scene);
        frames_checked += assert_golden(&adapter, &summary, (name, &scene, &state), frames);
    }
    println!("gpu_primal f64: {frames_checked} frames bit-identical");
}

/// gpu-f32 is the f32 reference (`cpu/src/f32_reference/primal.rs`) bit
/// for bit: states, residuals and active contacts every frame — the scenes
/// above and the stressed patches (materials: the Newton step in f32).
#[test]
fn gpu_f32_is_the_f32_reference_primal_update_bit_for_bit() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_primal f32", Precision::F32) else {
        return;
    };
    if !common::exact::f32_identical(&summary) {
        eprintln!("gpu_primal f32: not an exact adapter ({summary}); nothing to assert");
        return;
    }
    let mut frames_checked = 0;
    let mut runs: Vec<(String, Scene, State, usize)> = (cases().into_iter())
        .map(|(name, scene, frames)| {
            let state = State::from_scene(&scene);
            (name.to_string(), scene, state, frames)
        })
        .collect();
    for (dim, law) in [(2, ConstraintKind::Stvk), (3, ConstraintKind::NeoHookean)] {
        let patch = Patch::new(&PatchSpec::stressed(dim, law), 1.0 / 60.0, 10, 10);
        let name = format!("{dim}D {} patch", law.as_str());
        runs.push((name, primal(patch.scene.clone()), patch.state(false), 8));
    }
    let patch = Patch::new(
        &PatchSpec::stressed(2, ConstraintKind::Stvk),
        1.0 / 60.0,
        1,
        3,
    );
    let name = "2D stvk patch, 1 × 3 (halved steps)".to_string();
    runs.push((name, primal(patch.scene.clone()), patch.state(false), 6));
    for (name, scene, state, frames) in &runs {
        let name = name.as_str();
        let plan = Plan::compile(scene).expect("compiles");
        let gpu = GpuBackend::with_adapter(&adapter, plan.clone(), state, Precision::F32);
        let mut gpu = gpu.unwrap_or_else(|e| panic!("{name}: {e}"));
        let origin = gpu.origin().as_slice().to_vec();
        let mut reference = F32Reference::new(plan, state, &origin).expect("reference");
        for frame in 0..*frames as u64 {
            let report = gpu
                .step()
                .unwrap_or_else(|e| panic!("{name} gpu {frame}: {e}"));
            let s = gpu.read_state().expect("gpu");
            assert_f32_reference_step(name, frame, &mut reference, &report, &s);
            frames_checked += 1;
        }
    }
    assert!(frames_checked >= 200, "{frames_checked}");
    println!("gpu_primal f32: {frames_checked} frames bit-identical");
}

/// Material elements: the Newton step with the law's Hessian, its factor
/// kept over the substep's sweeps — the stressed patches of
/// docs/equilibria.md (both laws, 2D and 3D).
#[test]
fn gpu_f64_runs_the_golden_material_update_bit_for_bit() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_primal materials", Precision::F64) else {
        return;
    };
    let mut frames_checked = 0;
    for (dim, law) in [
        (2, ConstraintKind::Stvk),
        (2, ConstraintKind::NeoHookean),
        (3, ConstraintKind::NeoHookean),
    ] {
        let spec = PatchSpec::stressed(dim, law);
        let patch = Patch::new(&spec, 1.0 / 60.0, 10, 10);
        let scene = primal(patch.scene.clone());
        let name = format!("{dim}D {} patch", law.as_str());
        let state = patch.state(false);
        frames_checked += assert_golden(&adapter, &summary, (&name, &scene, &state), 8);
    }
    // One substep of three sweeps: the chord steps overshoot, and the
    // step is halved (or the element keeps its point) as on the CPU.
    let patch = Patch::new(
        &PatchSpec::stressed(2, ConstraintKind::Stvk),
        1.0 / 60.0,
        1,
        3,
    );
    let (scene, state) = (primal(patch.scene.clone()), patch.state(false));
    let name = "2D stvk patch, 1 × 3 (halved steps)";
    frames_checked += assert_golden(&adapter, &summary, (name, &scene, &state), 6);
    println!("gpu_primal materials: {frames_checked} frames bit-identical");
}

/// The 4D Neo-Hookean jelly dropped on a floor with friction (4-simplices:
/// 20 × 20 Newton systems).
#[test]
fn gpu_f64_runs_the_golden_4d_material_update_bit_for_bit() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_primal jelly4d", Precision::F64) else {
        return;
    };
    let jelly = primal(scenes::jelly4d());
    let state = State::from_scene(&jelly);
    let checked = assert_golden(&adapter, &summary, ("jelly4d", &jelly, &state), 2);
    println!("gpu_primal jelly4d: {checked} frames bit-identical");
}

/// The carried forces are part of the state: a step that fails puts them
/// back with x and v (the next steps are the CPU's again), and a written
/// state starts them over from zero on both backends.
#[test]
fn the_carried_forces_roll_back_and_restart_with_the_state() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_primal rollback", Precision::F64) else {
        return;
    };
    let mut scene = primal(chain(ConstraintKind::Distance, 1e-4));
    // A force term (set_forces needs one authored).
    scene.particles[12].force = Some(vec![0.0, 0.1]);
    let plan = Plan::compile(&scene).expect("compiles");
    let state = State::from_scene(&scene);
    let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
    let mut gpu =
        hyperpbd::load_on_adapter(&adapter, plan.clone(), &state, Precision::F64).expect("gpu");
    let backends: [&mut dyn Backend; 2] = [&mut cpu, gpu.as_mut()];
    let mut after = Vec::new();
    for backend in backends {
        for _ in 0..5 {
            backend.step().expect("step");
        }
        let good = backend.read_state().expect("state");
        // A force that is not finite fails the next step, which leaves
        // the state (and the carried forces) as they were.
        let mut forces = vec![0.0; plan.particle_count() * plan.dim];
        forces[25] = 0.1;
        let steady = forces.clone();
        forces[7] = f64::INFINITY;
        backend.set_forces(&forces).expect("forces");
        assert!(matches!(backend.step(), Err(BackendError::Step(_))));
        assert_eq!(bits(&backend.read_state().expect("state")), bits(&good));
        backend.set_forces(&steady).expect("forces");
        for _ in 0..5 {
            backend.step().expect("step");
        }
        let continued = backend.read_state().expect("state");
        // The initial state written back: the forces start over, so the
        // next five steps are the first five again.
        backend.write_state(&state).expect("write");
        for _ in 0..5 {
            backend.step().expect("step");
        }
        let restarted = backend.read_state().expect("state");
        assert_eq!(bits(&restarted), bits(&good), "a written state starts over");
        after.push((continued, restarted));
    }
    assert_identical_if_claimed(&summary, "after the rollback", &after[0].0, &after[1].0);
    assert_identical_if_claimed(&summary, "after the restart", &after[0].1, &after[1].1);
}

/// What the GPU does not run of the update yet is refused by name.
#[test]
fn what_the_gpu_does_not_run_yet_is_refused_by_name() {
    let Some((adapter, _)) = adapter_or_skip("gpu_primal refusals", Precision::F64) else {
        return;
    };
    let chain = primal(chain(ConstraintKind::Distance, 1e-4));
    let load = |scene: &Scene, precision| {
        let plan = Plan::compile(scene).expect("compiles");
        let state = State::from_scene(scene);
        match hyperpbd::load_on_adapter(&adapter, plan, &state, precision) {
            Ok(_) => String::new(),
            Err(e) => e.to_string(),
        }
    };
    let mut adaptive = chain.clone();
    adaptive.adaptive = Some(hyperpbd::Adaptive {
        max_subdivisions: 2,
    });
    adaptive.guards = Some(hyperpbd::Guards {
        max_speed: Some(1e3),
        ..hyperpbd::Guards::default()
    });
    let refused = load(&adaptive, Precision::F64);
    assert!(refused.contains("adaptive"), "{refused}");
}
