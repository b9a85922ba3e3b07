//! Batches of worlds on the GPU: every world in the same dispatches, and
//! world k of a batch is world k run alone — bit for bit in f64 on
//! lavapipe (common::exact), against the CPU golden path, every frame's
//! state and residuals — for a 15-world sweep of chain2d (gravity × plane
//! offset), a 12-world sweep of the ground cloth (compliance, friction,
//! damping, plane normal), the shards of the first, and a 32-world sweep
//! whose worlds compile different stages (damping from 0, gravity, plane
//! friction and a force each including 0: one batch runs the union of the
//! stages, gpu/src/batch/union.rs), and a 4-world sweep of a quadratic-bending
//! cloth whose worlds' authored shapes, hence hinge weights (per-element
//! constants, per world in `rest`), differ; f32 within the single-world
//! per-frame bound,
//! and on lavapipe bit for bit each world's own f32 reference. A failing
//! world puts every world back and is named as its own run names it;
//! worlds a GPU batch cannot share a schedule with (another law) are
//! refused by world.

use crate::common;

use common::exact::{
    assert_f32_reference_step, assert_identical_if_claimed, check_f64, f32_identical, f64_rule,
};
use common::gpu::adapter_or_skip;
use hyperpbd::batch::{Batch, BatchError, GpuBatch};
use hyperpbd::material::Law;
use hyperpbd::sweep::Sweep;
use hyperpbd::{Backend, F32Reference, Precision, Scene, State, scenes};
use hyperpbd_verify::compare::{DivergenceModel, Frame};
use hyperpbd_verify::compare_frame::FrameErrorModel;

const CHAIN: &str = include_str!("../../scenes/chain2d.json");

/// The worlds of `axes` over the scene `text`.
fn sweep(text: &str, axes: &[&str]) -> Vec<Scene> {
    let axes = axes.iter().map(|a| a.parse().expect("axis")).collect();
    let sweep = Sweep::new(text, axes).expect("sweep");
    (0..sweep.world_count())
        .map(|w| sweep.scene(w).expect("world"))
        .collect()
}

/// 15 worlds of chain2d: 3 sideways gravities × 5 plane offsets (the
/// highest plane cuts through the hanging chain).
fn chains() -> Vec<Scene> {
    sweep(CHAIN, &["gravity[0]=-3:3:3", "obstacles[0].offset=0:1.5:5"])
}

/// 12 worlds of a 12² ground cloth: compliance × friction × damping ×
/// tilted planes — every per-world parameter of the call blocks.
fn cloths() -> Vec<Scene> {
    let text = serde_json::to_string(&scenes::cloth(12)).expect("json");
    sweep(
        &text,
        &[
            "constraints[0].compliance=0:1e-4:2",
            "obstacles[0].friction=0.1:0.8:2",
            "damping.rate=0.05:0.5:3",
        ],
    )
}

/// 4 worlds of an 8² cloth with quadratic bending over a plane, two
/// interior particles authored at 2 heights each: each world's hinge
/// weights are computed from its own authored positions.
fn quadratic_cloths() -> Vec<Scene> {
    let mut b = hyperpbd::SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .gravity_along(1, 9.81);
    let grid = b.grid(&hyperpbd::builders::GridSpec::cloth(8, 8, 0.1, 0.3));
    let model = hyperpbd::kinds::BendingModel::Quadratic;
    b.grid_bending(&grid, 1e-4, model).expect("hinges");
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.3);
    let text = serde_json::to_string(&b.build().expect("valid")).expect("json");
    sweep(
        &text,
        &[
            "particles[27].position[1]=0.3:0.36:2",
            "particles[36].position[1]=0.3:0.33:2",
        ],
    )
}

/// 32 worlds of chain2d over a plane cutting through it (offset 1.5 or
/// 1.55): damping rate 0 or 1, gravity 0 or −9.81, plane friction 0 or 0.3,
/// a sideways force of 0 or 1 N on the middle bead. World 0 has none of
/// the four stages, the last world all of them.
fn zero_sweep() -> Vec<Scene> {
    sweep(
        CHAIN,
        &[
            "damping.rate=0:1:2",
            "gravity[1]=0:-9.81:2",
            "obstacles[0].friction=0:0.3:2",
            "particles[10].force[0]=0:1:2",
            "obstacles[0].offset=1.5:1.55:2",
        ],
    )
}

pub(crate) fn max_difference(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// Every world of `scenes`, batched on gpu-f64, against its own CPU run
/// after `frames` frames (and the reports' residuals likewise); the
/// worlds' final positions (`None`: no adapter, skipped).
pub(crate) fn f64_worlds_are_their_own_runs(
    test: &str,
    scenes: &[Scene],
    frames: usize,
) -> Option<Vec<Vec<f64>>> {
    let (adapter, summary) = adapter_or_skip(test, Precision::F64)?;
    let batch = Batch::new(scenes).expect("one topology");
    let mut gpu = GpuBatch::on_adapter(&adapter, &batch, Precision::F64).expect("gpu batch");
    assert_eq!(gpu.len(), scenes.len());
    let mut cpus: Vec<_> = scenes
        .iter()
        .map(|s| hyperpbd::cpu_backend(s).expect("cpu"))
        .collect();
    for frame in 0..frames {
        let reports = gpu.step().expect("batch step");
        // On lavapipe every frame's state too, bit for bit (−0 ≠ +0).
        let states = match common::exact::f64_identical(&summary) {
            true => gpu.read_states().expect("states"),
            false => Vec::new(),
        };
        for (k, cpu) in cpus.iter_mut().enumerate() {
            let report = cpu.step().expect("cpu step");
            if let Some(state) = states.get(k) {
                let golden = cpu.read_state().expect("state");
                let name = format!("{test}: world {k}, frame {frame}");
                assert!(assert_identical_if_claimed(&summary, &name, &golden, state));
            }
            for (a, b) in report.residuals.iter().zip(&reports[k].residuals) {
                assert_eq!(
                    a.max_violation.to_bits(),
                    b.max_violation.to_bits(),
                    "{test}: world {k}, frame {frame}, {}",
                    a.label
                );
            }
            assert_eq!(report.active_contacts, reports[k].active_contacts);
        }
    }
    let states = gpu.read_states().expect("states");
    let mut finals = Vec::new();
    for (k, (cpu, state)) in cpus.iter_mut().zip(&states).enumerate() {
        let golden = cpu.read_state().expect("state");
        let dx = max_difference(&golden.positions, &state.positions);
        let dv = max_difference(&golden.velocities, &state.velocities);
        check_f64(&summary, &format!("{test} world {k} position"), dx, 1e-9);
        check_f64(&summary, &format!("{test} world {k} velocity"), dv, 1e-9);
        finals.push(state.positions.clone());
    }
    eprintln!("{test}: {} worlds, {}", scenes.len(), f64_rule(&summary));
    // The parameters reach the physics: worlds end in different places.
    assert!(finals.windows(2).any(|w| w[0] != w[1]));
    assert_ne!(finals[0], finals[finals.len() - 1]);
    Some(finals)
}

#[test]
fn every_chain_of_a_gpu_batch_is_its_own_cpu_run() {
    f64_worlds_are_their_own_runs("gpu_batch chains", &chains(), 60);
}

#[test]
fn every_cloth_of_a_gpu_batch_is_its_own_cpu_run() {
    f64_worlds_are_their_own_runs("gpu_batch cloths", &cloths(), 30);
}

#[test]
fn every_world_of_a_sweep_from_zero_is_its_own_cpu_run() {
    let scenes = zero_sweep();
    // The worlds compile different stages: world 0 none of damping,
    // gravity, friction and force, the last all of them.
    let plans: Vec<_> = scenes
        .iter()
        .map(|s| hyperpbd::Plan::compile(s).expect("plan"))
        .collect();
    let last = &plans[plans.len() - 1];
    assert!(plans[0].substep_kernels.len() < last.substep_kernels.len());
    assert!(!plans[0].predict.gravity && !plans[0].predict.force);
    assert!(last.predict.gravity && last.predict.force && last.damping.is_some());
    let Some(finals) = f64_worlds_are_their_own_runs("gpu_batch sweep from zero", &scenes, 60)
    else {
        return;
    };
    // Each stage reaches the physics (so a world that skipped it, or ran
    // it where it should not, would differ from its CPU run): the worlds
    // that differ only in its parameter (world index bit `stride`) end in
    // different places.
    for (stage, stride) in [
        ("damping", 16),
        ("gravity", 8),
        ("friction", 4),
        ("force", 2),
    ] {
        let differ = (0..scenes.len())
            .filter(|w| w & stride == 0)
            .all(|w| finals[w] != finals[w + stride]);
        assert!(differ, "{stage}: some worlds end alike with and without it");
    }
}

#[test]
fn one_world_and_the_shards_of_a_sweep_are_the_whole_batch() {
    let Some((adapter, _)) = adapter_or_skip("gpu_batch shards", Precision::F64) else {
        return;
    };
    let scenes = chains();
    let run = |worlds: &[Scene]| {
        let batch = Batch::new(worlds).expect("batch");
        let mut gpu = GpuBatch::on_adapter(&adapter, &batch, Precision::F64).expect("gpu batch");
        for _ in 0..30 {
            gpu.step().expect("step");
        }
        gpu.read_states().expect("states")
    };
    let whole = run(&scenes);
    let mut shards = Vec::new();
    for shard in scenes.chunks(4) {
        shards.extend(run(shard));
    }
    shards.extend(run(&scenes[14..15]));
    for (k, (a, b)) in whole.iter().zip(&shards).enumerate() {
        assert_eq!(a.hash(), b.hash(), "world {k}");
    }
}

#[test]
fn every_quadratic_bending_cloth_of_a_gpu_batch_is_its_own_cpu_run() {
    let worlds = quadratic_cloths();
    let weights = |s: &Scene| {
        let plan = hyperpbd::Plan::compile(s).expect("compiles");
        match &plan.families[1].kind {
            hyperpbd::FamilyKind::Expression(kind) => kind.constants.clone(),
            other => panic!("bending is an expression family, not {other:?}"),
        }
    };
    assert_ne!(
        weights(&worlds[0]),
        weights(&worlds[3]),
        "the worlds' weights differ"
    );
    f64_worlds_are_their_own_runs("gpu_batch quadratic bending", &worlds, 20);
}

#[test]
fn f32_worlds_stay_within_the_single_world_frame_bound() {
    f32_worlds_are_their_own_references("gpu_batch chains f32", &chains());
}

#[test]
fn f32_worlds_of_a_sweep_from_zero_are_their_own_references() {
    f32_worlds_are_their_own_references("gpu_batch sweep from zero f32", &zero_sweep());
}

/// Every world of `scenes`, batched on gpu-f32 for 30 frames: within the
/// single-world per-frame bound of its CPU run each frame, and on lavapipe
/// its own f32 reference (from the batch's origin) bit for bit.
fn f32_worlds_are_their_own_references(test: &str, scenes: &[Scene]) {
    let Some((adapter, summary)) = adapter_or_skip(test, Precision::F32) else {
        return;
    };
    let batch = Batch::new(scenes).expect("batch");
    let mut gpu = GpuBatch::on_adapter(&adapter, &batch, Precision::F32).expect("gpu batch");
    let origin = gpu.origin().as_slice().to_vec();
    let mut cpus: Vec<_> = scenes
        .iter()
        .map(|s| hyperpbd::cpu_backend(s).expect("cpu"))
        .collect();
    let mut models: Vec<_> = cpus
        .iter()
        .map(|c| FrameErrorModel::new(c.plan(), Precision::F32, &origin).expect("model"))
        .collect();
    // llvmpipe: each world is also its own f32 reference from the start
    // (the batch's shared origin), bit for bit.
    let mut references: Vec<F32Reference> = if f32_identical(&summary) {
        scenes
            .iter()
            .zip(&cpus)
            .map(|(s, c)| {
                F32Reference::new(c.plan().clone(), &State::from_scene(s), &origin)
                    .expect("reference")
            })
            .collect()
    } else {
        Vec::new()
    };
    let (mut worst_x, mut worst_v): (f64, f64) = (0.0, 0.0);
    for frame in 1..=30 {
        // Each frame the golden path restarts from the batch's state (the
        // per-frame model's rule, verify/src/compare_frame.rs).
        let starts = gpu.read_states().expect("states");
        let reports = gpu.step().expect("batch step");
        let ends = gpu.read_states().expect("states");
        for (k, r) in references.iter_mut().enumerate() {
            let name = format!("{test} world {k}");
            assert_f32_reference_step(&name, frame, r, &reports[k], &ends[k]);
        }
        for (k, cpu) in cpus.iter_mut().enumerate() {
            cpu.write_state(&starts[k]).expect("write");
            let report = cpu.step().expect("cpu step");
            let golden = cpu.read_state().expect("state");
            let (bx, bv) = models[k]
                .frame_bounds(Frame {
                    start: &starts[k],
                    golden: (&report, &golden),
                    other: (&reports[k], &ends[k]),
                })
                .expect("bounds");
            let dx = max_difference(&golden.positions, &ends[k].positions);
            let dv = max_difference(&golden.velocities, &ends[k].velocities);
            assert!(
                dx <= bx && dv <= bv,
                "world {k}: {dx:e} > {bx:e} or {dv:e} > {bv:e}"
            );
            worst_x = worst_x.max(dx / bx);
            worst_v = worst_v.max(dv / bv);
        }
    }
    let worlds = scenes.len();
    common::bound::print_bound(
        format!("{test} ({worlds} worlds, 30 frames), worst measured/bound"),
        format_args!("position {worst_x:.3}, velocity {worst_v:.3}"),
        "1 (each frame, each world)",
        "the single-world per-frame model (DivergenceModel::frame_bounds)",
    );
    if !references.is_empty() {
        common::bound::print_bound(
            format!("{test} ({worlds} worlds, 30 frames) vs each world's f32 reference"),
            "0 (bit-identical: states, residuals, active contacts)",
            "exact",
            "llvmpipe (common::exact::f32_identical)",
        );
    }
}

#[test]
fn a_world_written_or_pushed_mid_run_is_its_own_run_so_treated() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_batch write", Precision::F64) else {
        return;
    };
    // A force on the chain's middle bead (every world has one: 0.5 to 2 N).
    let scenes = sweep(
        CHAIN,
        &[
            "particles[10].force[0]=0.5:2:3",
            "obstacles[0].offset=0:1.5:5",
        ],
    );
    let batch = Batch::new(&scenes).expect("batch");
    let mut gpu = GpuBatch::on_adapter(&adapter, &batch, Precision::F64).expect("gpu batch");
    let mut cpus: Vec<_> = scenes
        .iter()
        .map(|s| hyperpbd::cpu_backend(s).expect("cpu"))
        .collect();
    let step_all = |gpu: &mut GpuBatch, cpus: &mut Vec<hyperpbd::CpuBackend>| {
        for _ in 0..10 {
            gpu.step().expect("batch step");
            for cpu in cpus.iter_mut() {
                cpu.step().expect("cpu step");
            }
        }
    };
    step_all(&mut gpu, &mut cpus);
    // World 3 restarts from world 7's state; world 5's force turns.
    let moved = cpus[7].read_state().expect("state");
    gpu.write_state(3, &moved).expect("write");
    cpus[3].write_state(&moved).expect("write");
    let mut forces = vec![0.0; 21 * 2];
    forces[2 * 10 + 1] = -3.0;
    gpu.set_forces(5, &forces).expect("forces");
    cpus[5].set_forces(&forces).expect("forces");
    // Bad input is refused and changes nothing.
    let before = gpu.read_states().expect("states");
    assert!(gpu.set_forces(2, &forces[1..]).is_err());
    let e = gpu
        .write_state(15, &moved)
        .expect_err("no world 15")
        .to_string();
    assert!(e.starts_with("worlds[15]: "), "{e}");
    assert_eq!(gpu.read_states().expect("states"), before);
    step_all(&mut gpu, &mut cpus);
    let states = gpu.read_states().expect("states");
    for (k, (cpu, state)) in cpus.iter_mut().zip(&states).enumerate() {
        let golden = cpu.read_state().expect("state");
        let dx = max_difference(&golden.positions, &state.positions);
        let dv = max_difference(&golden.velocities, &state.velocities);
        check_f64(
            &summary,
            &format!("gpu_batch write world {k} position"),
            dx,
            1e-9,
        );
        check_f64(
            &summary,
            &format!("gpu_batch write world {k} velocity"),
            dv,
            1e-9,
        );
    }
}

#[test]
fn a_failing_world_puts_every_world_back_and_is_named_as_alone() {
    let Some((adapter, _)) = adapter_or_skip("gpu_batch failure", Precision::F64) else {
        return;
    };
    let mut scenes = chains();
    // World 9's first link flies off at 1e300 m/s: its predict overflows.
    scenes[9].particles[1].velocity = Some(vec![0.0, 1e300]);
    let batch = Batch::new(&scenes).expect("batch");
    let mut gpu = GpuBatch::on_adapter(&adapter, &batch, Precision::F64).expect("gpu batch");
    let before = gpu.read_states().expect("states");
    let e = gpu.step().expect_err("world 9 fails");
    let BatchError::Backend { world, source } = &e else {
        panic!("not a world's error: {e}");
    };
    assert_eq!(*world, 9, "{e}");
    let mut single = hyperpbd::cpu_backend(&scenes[9]).expect("cpu");
    let expected = single.step().expect_err("fails alone").to_string();
    assert_eq!(source.to_string(), expected);
    let after = gpu.read_states().expect("states");
    for (k, (a, b)) in before.iter().zip(&after).enumerate() {
        assert_eq!(a.hash(), b.hash(), "world {k} not put back");
    }
}

#[test]
fn worlds_that_cannot_share_a_schedule_are_refused_by_world() {
    let Some((adapter, _)) = adapter_or_skip("gpu_batch refusal", Precision::F32) else {
        return;
    };
    // Four stretched bars of one topology; world 2's material obeys
    // another law, which no parameter of a call block turns into StVK.
    let bar = |law, traction| hyperpbd::scenes::stretched_bar(law, 2, traction, 4, 4);
    let scenes = [
        bar(Law::StVenantKirchhoff, 10.0),
        bar(Law::StVenantKirchhoff, 20.0),
        bar(Law::NeoHookean, 20.0),
        bar(Law::StVenantKirchhoff, 30.0),
    ];
    let batch = Batch::new(&scenes).expect("one topology");
    let e = match GpuBatch::on_adapter(&adapter, &batch, Precision::F32) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("a world of another law was accepted"),
    };
    assert!(e.starts_with("worlds[2]: "), "{e}");
    assert!(
        e.contains("call 1 (Project { family: 0, color: 0 }): its kernel and flags differ"),
        "{e}"
    );
    assert!(e.contains("one schedule"), "{e}");
    // Without it the three StVK bars (different forces) share one batch.
    let same = [scenes[0].clone(), scenes[1].clone(), scenes[3].clone()];
    let batch = Batch::new(&same).expect("one topology");
    assert!(GpuBatch::on_adapter(&adapter, &batch, Precision::F32).is_ok());
}
