//! The material families (stvk, neo_hookean) on the GPU against the CPU
//! golden path, frame by frame (`common::differential`): gpu-f64 bit for
//! bit from the start on lavapipe (positions, velocities, reports), gpu-f32
//! on lavapipe bit for bit from the start to the f32 reference (every scene
//! here is one it runs) and within the per-frame FrameErrorModel; and a
//! Neo-Hookean refusal named exactly as the CPU names it, with the state
//! unchanged.
//!
//! ```text
//! soft block 2D/3D   Kuhn block (3 cells of 0.1 m per axis, 0.1 kg nodes)
//!                    dropped at 2 m/s onto y = 0 (μ = 0.3), 4 substeps ×
//!                    4 iterations, E = 2e5 Pa, ν = 0.3, both laws
//! membrane 3D        a 4 × 4 grid of stvk triangles (k = 2 < N = 3) hanging
//!                    from two fixed corners, rest shape authored flat
//! lumped square 2D   two neo_hookean triangles with density 3 (no masses)
//! jelly4d            scenes/jelly4d.json (4D Neo-Hookean tesseract, density)
//! ```

use crate::common;

use common::differential::both;
use common::gpu::load_or_skip;
use hyperpbd::{
    Backend, BackendError, BackendKind, ConstraintFamily, ConstraintKind, CpuBackend, F32Reference,
    Kernel, Obstacle, Particle, Plan, Precision, ReferenceError, Scene, State, StepError,
};
use hyperpbd_gpu::SceneOrigin;

/// The Kuhn block of common::guarded at 2 m/s, its simplices one `law`
/// family, 4 substeps × 4 iterations, friction on the plane.
fn soft_block(dim: usize, law: ConstraintKind) -> Scene {
    let mut scene = common::guarded::material_block(dim, 2.0, law, None, None);
    scene.substeps = 4;
    scene.iterations = 4;
    if let Obstacle::Hyperplane { friction, .. } = &mut scene.obstacles[0] {
        *friction = 0.3;
    }
    scene.validate().expect("valid block");
    scene
}

/// A 4 × 4 membrane of stvk triangles in R^3, hanging from two corners.
fn membrane() -> Scene {
    let n = 5;
    let mut scene = Scene::new(3, 1.0 / 60.0, 4, 4);
    scene.gravity = Some(vec![0.0, -9.81, 0.0]);
    for j in 0..n {
        for i in 0..n {
            let mut p = Particle::new(vec![0.1 * i as f64, 1.0, 0.1 * j as f64], 0.01);
            p.fixed = j == 0 && (i == 0 || i == n - 1);
            scene.particles.push(p);
        }
    }
    let mut elements = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = j * n + i;
            elements.push(vec![a, a + 1, a + n + 1]);
            elements.push(vec![a, a + n + 1, a + n]);
        }
    }
    scene.constraints.push(ConstraintFamily::material(
        ConstraintKind::Stvk,
        5e3,
        0.3,
        elements,
    ));
    scene.validate().expect("valid membrane");
    scene
}

/// `common::materials::lumped_square` 0.2 m above y = 0 (μ = 0.2), under
/// gravity, 4 substeps × 4 iterations of 1/60 s.
fn lumped_square() -> Scene {
    let mut scene = common::materials::lumped_square();
    for p in &mut scene.particles {
        p.position[1] += 0.2;
    }
    scene.dt = 1.0 / 60.0;
    scene.substeps = 4;
    scene.iterations = 4;
    scene.gravity = Some(vec![0.0, -9.81]);
    let mut builder = hyperpbd::SceneBuilder::new(2);
    *builder.scene_mut() = scene;
    builder.hyperplane(vec![0.0, 1.0], 0.0, 0.2);
    builder.build().expect("valid square")
}

#[test]
fn soft_blocks_of_both_laws_match_the_golden_path() {
    for dim in [2, 3] {
        for (law, name) in [
            (ConstraintKind::NeoHookean, "neo_hookean"),
            (ConstraintKind::Stvk, "stvk"),
        ] {
            both(
                "soft_blocks_of_both_laws_match_the_golden_path",
                &format!("soft block {dim}D {name}"),
                &soft_block(dim, law),
                20,
            );
        }
    }
}

#[test]
fn an_embedded_stvk_membrane_matches_the_golden_path() {
    both(
        "an_embedded_stvk_membrane_matches_the_golden_path",
        "stvk membrane 3D (k = 2)",
        &membrane(),
        30,
    );
}

#[test]
fn a_density_lumped_neo_hookean_square_matches_the_golden_path() {
    both(
        "a_density_lumped_neo_hookean_square_matches_the_golden_path",
        "lumped neo_hookean square 2D",
        &lumped_square(),
        30,
    );
}

#[test]
fn jelly4d_matches_the_golden_path() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/jelly4d.json");
    let scene = Scene::from_json_file(&path).expect("jelly4d");
    both("jelly4d_matches_the_golden_path", "jelly4d", &scene, 3);
}

#[test]
fn the_f32_reference_runs_every_material_scene() {
    // `common::differential` holds gpu-f32 to the f32 reference only where
    // F32Reference::new accepts the plan: every scene above must be one.
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/jelly4d.json");
    let mut scenes = vec![
        membrane(),
        lumped_square(),
        Scene::from_json_file(&path).expect("jelly4d"),
    ];
    for dim in [2, 3] {
        for law in [ConstraintKind::NeoHookean, ConstraintKind::Stvk] {
            scenes.push(soft_block(dim, law));
        }
    }
    for scene in &scenes {
        let plan = Plan::compile(scene).expect("plan");
        let state = State::from_scene(scene);
        let origin = SceneOrigin::for_state(plan.dim, &state.positions, Precision::F32);
        if let Err(e) = F32Reference::new(plan, &state, origin.as_slice()) {
            panic!("the f32 reference refuses a material scene: {e}");
        }
    }
}

#[test]
fn an_inverting_neo_hookean_step_is_refused_as_on_the_cpu() {
    // The 40 m/s drop of tests/materials/guards.rs, without guards: the
    // law refuses a collapsed element inside the one substep.
    let scene = common::guarded::material_block(2, 40.0, ConstraintKind::NeoHookean, None, None);
    let plan = Plan::compile(&scene).expect("plan");
    let state = State::from_scene(&scene);
    let mut cpu = CpuBackend::with_threads(plan.clone(), &state, 1).expect("cpu");
    let golden = cpu.step().expect_err("the CPU refuses");
    println!("cpu: {golden}");
    assert!(matches!(
        golden,
        BackendError::Step(StepError::MaterialRefused { .. })
    ));
    // The f32 reference (gpu-f32's bits on lavapipe) fails the projection
    // of a refused element too, and keeps its state.
    let origin = SceneOrigin::for_state(plan.dim, &state.positions, Precision::F32);
    let mut reference =
        F32Reference::new(plan.clone(), &state, origin.as_slice()).expect("reference");
    let start = reference.read_state();
    let failed = reference.step();
    println!("f32 reference: {failed:?}");
    assert!(matches!(
        failed,
        Err(ReferenceError::NonFinite {
            kernel: Kernel::Project { family: 0, .. },
            ..
        })
    ));
    assert_eq!(reference.read_state(), start);
    let test = "an_inverting_neo_hookean_step_is_refused_as_on_the_cpu";
    let Some(mut gpu) =
        load_or_skip(test, BackendKind::Gpu(Precision::F64), plan, &state).expect("gpu backend")
    else {
        return;
    };
    let before = gpu.read_state().expect("state");
    let refused = gpu.step().expect_err("the GPU refuses");
    println!("gpu-f64: {refused}");
    assert_eq!(refused.to_string(), golden.to_string());
    let after = gpu.read_state().expect("state");
    assert_eq!(common::exact::bits(&after), common::exact::bits(&before));
}
