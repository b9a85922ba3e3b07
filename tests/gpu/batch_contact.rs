//! Particle contact in a GPU batch (issue 35, item 2): the hashed-grid
//! broadphase, the contact lists and the collide iterations of W worlds in
//! the same dispatches, each world with its own grid, lists and outcome.
//!
//! ```text
//! f64   3 pits of 48 balls (μ = 0 and 0.6 on one start, 0.3 on another):
//!       world k, every frame, bit for bit its own single gpu-f64 run and
//!       its golden-path run (states, residuals, active contacts, list
//!       slots); μ = 0 is the frictionless branch of its own run (an exact
//!       identity)
//! f32   the same worlds: each world bit for bit its own f32 reference from
//!       the batch's origin (llvmpipe)
//! grow  3 clusters of 96 discs, only world 1's box margin long enough to
//!       overflow the 32 list slots: world 1's lists grow, the others' stay,
//!       and every world is still its own run from the first step
//! fail  a world whose contact distance overflows: the batch step fails,
//!       every world is put back, the error is the world's own single run's
//! ```
//! Bit-for-bit claims hold on llvmpipe (common::exact); elsewhere f64 is
//! held to 1e-9 of the golden path.

use crate::common;

use common::exact::{
    assert_f32_reference_step, assert_identical_if_claimed, check_f64, f32_identical, f64_identical,
};
use common::gpu::adapter_or_skip;
use hyperpbd::batch::{Batch, GpuBatch};
use hyperpbd::{Backend, Collisions, F32Reference, Plan, Precision, Scene, State, StepReport};
use hyperpbd_gpu::GpuBackend;

use crate::batch::max_difference;
use crate::contact_step::{cluster, huge_pair};

/// A pit of 4 × 3 × 4 balls with ball–ball friction `mu`, thrown sideways
/// (so contacts slide and friction matters); `shift` moves alternate
/// balls sideways by less than the lattice gap (another start).
fn pit(mu: f64, shift: f64) -> Scene {
    let mut scene = hyperpbd::scenes::pit3d(4, 3);
    for (i, p) in scene.particles.iter_mut().enumerate() {
        let side = if i % 2 == 0 { 1.0 } else { -1.0 };
        p.position[0] += side * shift;
        p.velocity = Some(vec![side * 0.8, -1.5, 0.3 * side]);
    }
    scene.collisions = Some(Collisions {
        friction: mu,
        margin: 0.01,
    });
    scene
}

/// A friction sweep from zero on one start, and a third world from
/// another start.
fn pits() -> Vec<Scene> {
    vec![pit(0.0, 0.0), pit(0.6, 0.0), pit(0.3, 0.002)]
}

fn residual_bits(report: &StepReport) -> Vec<u64> {
    report
        .residuals
        .iter()
        .map(|r| r.max_violation.to_bits())
        .collect()
}

/// Every world of `scenes` batched on gpu-f64 for `frames` frames against
/// its golden-path run and, for the worlds `alone`, its own single gpu-f64
/// run, every frame (a backend costs lavapipe ~2 s of pipeline builds:
/// the single runs are of the worlds that matter); the batch's list slots
/// per world (those of `alone` equal to their single run's) and the
/// worlds' final positions (`None`: no adapter).
fn f64_worlds_are_their_own_runs(
    test: &str,
    scenes: &[Scene],
    (frames, alone): (usize, &[usize]),
) -> Option<(Vec<usize>, Vec<Vec<f64>>)> {
    let (adapter, summary) = adapter_or_skip(test, Precision::F64)?;
    let batch = Batch::new(scenes).expect("one topology");
    let mut gpu = GpuBatch::on_adapter(&adapter, &batch, Precision::F64).expect("gpu batch");
    let mut cpus: Vec<_> = scenes
        .iter()
        .map(|s| hyperpbd::cpu_backend(s).expect("cpu"))
        .collect();
    let mut singles: Vec<(usize, GpuBackend)> = alone
        .iter()
        .map(|&k| {
            let s = &scenes[k];
            let plan = Plan::compile(s).expect("plan");
            let single =
                GpuBackend::with_adapter(&adapter, plan, &State::from_scene(s), Precision::F64)
                    .expect("single gpu-f64");
            (k, single)
        })
        .collect();
    let exact = f64_identical(&summary);
    for frame in 0..frames {
        let reports = gpu.step().expect("batch step");
        let states = gpu.read_states().expect("states");
        for k in 0..scenes.len() {
            let name = format!("{test}: world {k}, frame {frame}");
            let golden_report = cpus[k].step().expect("cpu step");
            let golden = cpus[k].read_state().expect("state");
            assert!(assert_identical_if_claimed(
                &summary, &name, &golden, &states[k]
            ));
            if exact {
                assert_eq!(residual_bits(&golden_report), residual_bits(&reports[k]));
            }
            assert_eq!(golden_report.active_contacts, reports[k].active_contacts);
            if let Some((_, single)) = singles.iter_mut().find(|(j, _)| *j == k) {
                let single_report = single.step().expect("single step");
                let single = single.read_state().expect("single state");
                if exact {
                    assert_eq!(single.hash(), states[k].hash(), "{name}: vs its gpu run");
                    assert_eq!(residual_bits(&single_report), residual_bits(&reports[k]));
                }
                assert_eq!(single_report.active_contacts, reports[k].active_contacts);
            }
            let dx = max_difference(&golden.positions, &states[k].positions);
            check_f64(&summary, &format!("{name} position"), dx, 1e-9);
        }
    }
    let slots = gpu.contact_list_slots().expect("contact");
    for (k, single) in &singles {
        let own = single.contact_list_slots().expect("contact");
        assert_eq!(
            slots[*k], own,
            "{test}: world {k}'s list slots vs its own run"
        );
    }
    let finals = gpu
        .read_states()
        .expect("states")
        .into_iter()
        .map(|s| s.positions)
        .collect();
    Some((slots, finals))
}

#[test]
fn every_pit_of_a_contact_batch_is_its_own_gpu_and_golden_run() {
    let scenes = pits();
    let Some((_, finals)) =
        f64_worlds_are_their_own_runs("batch_contact pits", &scenes, (6, &[0, 1, 2]))
    else {
        return;
    };
    // The parameters reach the physics: each friction, and the other
    // start, end elsewhere (a world run with another world's μ or
    // positions would differ from its own run above).
    for (a, b) in [(0, 1), (1, 2), (0, 2)] {
        assert_ne!(finals[a], finals[b], "worlds {a} and {b} end alike");
    }
}

#[test]
fn f32_pits_of_a_contact_batch_are_their_own_f32_references() {
    let Some((adapter, summary)) = adapter_or_skip("batch_contact f32", Precision::F32) else {
        return;
    };
    let scenes = pits();
    let batch = Batch::new(&scenes).expect("one topology");
    let mut gpu = GpuBatch::on_adapter(&adapter, &batch, Precision::F32).expect("gpu batch");
    if !f32_identical(&summary) {
        eprintln!("batch_contact f32: not llvmpipe, the f32 reference is not claimed");
        return;
    }
    let origin = gpu.origin().as_slice().to_vec();
    let mut references: Vec<F32Reference> = scenes
        .iter()
        .map(|s| {
            let plan = Plan::compile(s).expect("plan");
            F32Reference::new(plan, &State::from_scene(s), &origin).expect("reference")
        })
        .collect();
    for frame in 1..=6 {
        let reports = gpu.step().expect("batch step");
        let states = gpu.read_states().expect("states");
        for (k, r) in references.iter_mut().enumerate() {
            let name = format!("batch_contact f32 world {k}");
            assert_f32_reference_step(&name, frame, r, &reports[k], &states[k]);
        }
    }
    let states = gpu.read_states().expect("states");
    assert_ne!(states[0].positions, states[2].positions);
}

#[test]
fn a_world_whose_lists_overflow_grows_them_alone_and_loses_no_step() {
    // World 1's margin makes its boxes meet ~80 others; worlds 0 and 2
    // (margin 0.01) meet a handful.
    let scenes = vec![cluster(0.01, 0.0), cluster(0.5, 0.3), cluster(0.01, 0.3)];
    let Some((slots, _)) =
        f64_worlds_are_their_own_runs("batch_contact growth", &scenes, (2, &[1]))
    else {
        return;
    };
    assert!(slots[1] > 32, "world 1's lists grew: {slots:?}");
    assert_eq!((slots[0], slots[2]), (32, 32), "the others' did not");
}

#[test]
fn a_world_whose_contact_fails_is_named_as_alone_and_every_world_put_back() {
    let Some((adapter, _)) = adapter_or_skip("batch_contact failure", Precision::F64) else {
        return;
    };
    let scenes = [huge_pair(3e200), huge_pair(1e200), huge_pair(3e200)];
    let batch = Batch::new(&scenes).expect("one topology");
    let mut gpu = GpuBatch::on_adapter(&adapter, &batch, Precision::F64).expect("gpu batch");
    let before = gpu.read_states().expect("states");
    let e = gpu.step().expect_err("world 1's contact is not finite");
    let hyperpbd::batch::BatchError::Backend { world, source } = &e else {
        panic!("not a world's error: {e}");
    };
    assert_eq!(*world, 1, "{e}");
    let mut alone = hyperpbd::cpu_backend(&scenes[1]).expect("cpu");
    let expected = alone.step().expect_err("fails alone").to_string();
    assert_eq!(source.to_string(), expected);
    let after = gpu.read_states().expect("states");
    for (k, (a, b)) in before.iter().zip(&after).enumerate() {
        assert_eq!(a.hash(), b.hash(), "world {k} not put back");
    }
}
