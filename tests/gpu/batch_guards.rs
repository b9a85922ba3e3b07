//! Guards and adaptive steps in a GPU batch (issue 35 item 3): worlds of
//! the guarded Neo-Hookean drop of common::guarded (2D, 3×3 cells, one
//! substep of 1/30 s) at different speeds and guard limits, so that some
//! worlds' steps are rejected and retried with more substeps while the
//! others are accepted at once. Every world's reports (attempts and
//! rejections included) and state, frame after frame, equal its own single
//! adaptive GPU run — bit for bit in f64 and, on the batch's origin, in
//! f32 on lavapipe (common::exact). A world rejected at every subdivision
//! fails the step, named as its own run names it, every world put back.

use crate::common;

use common::exact::{bits, f64_identical};
use common::gpu::adapter_or_skip;
use common::guarded::material_block;
use hyperpbd::batch::{Batch, BatchError, GpuBatch};
use hyperpbd::gpu::{GpuBackend, XpbdOptions};
use hyperpbd::{Backend, ConstraintKind, Guards, Plan, Precision, Scene, State, StepReport};

/// The drop at `speed` under the orientation guard (and a speed limit
/// `max_speed` when given), adaptive up to 2^`k` times the substeps.
fn world(speed: f64, max_speed: Option<f64>, k: u32) -> Scene {
    let guards = Guards {
        orientation: true,
        max_speed,
        ..Guards::default()
    };
    material_block(2, speed, ConstraintKind::NeoHookean, Some(guards), Some(k))
}

/// Four worlds: accepted at once, retried (4 times), accepted at once
/// after a retried world, retried (3 times).
fn worlds() -> Vec<Scene> {
    vec![
        world(1.0, Some(100.0), 6),
        world(40.0, Some(100.0), 6),
        world(2.0, Some(100.0), 6),
        world(20.0, Some(100.0), 6),
    ]
}

/// The substeps of every attempt of `report`.
fn substeps(report: &StepReport) -> Vec<u32> {
    report.attempts.iter().map(|a| a.substeps).collect()
}

/// Every world of `scenes` batched in `precision` against its own single
/// adaptive run on the batch's origin, `frames` frames: reports equal,
/// states bit for bit where the adapter claims it; the batch step's host
/// waits 1 + the most any world retried alone waits alone (the retried
/// worlds run in lockstep; they are the rejected ones, every world of a
/// failed step with `contact`); worlds 1 and 3 retried, 0 and 2 never.
fn worlds_are_their_own_adaptive_runs(
    test: &str,
    (scenes, contact): (&[Scene], bool),
    precision: Precision,
    frames: usize,
) {
    let Some((adapter, summary)) = adapter_or_skip(test, precision) else {
        return;
    };
    let batch = Batch::new(scenes).expect("one topology");
    let mut gpu = GpuBatch::on_adapter(&adapter, &batch, precision).expect("a guarded batch");
    let mut singles: Vec<GpuBackend> = scenes
        .iter()
        .map(|s| {
            let plan = Plan::compile(s).expect("plan");
            let origin = gpu.origin().clone();
            GpuBackend::with_options(
                &adapter,
                plan,
                &State::from_scene(s),
                precision,
                XpbdOptions::origin(origin),
            )
            .expect("single")
        })
        .collect();
    let exact = f64_identical(&summary);
    let mut retried = vec![0; scenes.len()];
    for frame in 0..frames {
        let reports = gpu.step().expect("batch step");
        let states = gpu.read_states().expect("states");
        let (mut most_retried, mut most, mut failed) = (0, 0, false);
        for (k, single) in singles.iter_mut().enumerate() {
            let alone = single.step().expect("single step");
            if alone.retries() > 0 {
                (most_retried, failed) = (most_retried.max(alone.host_waits), true);
            }
            most = most.max(alone.host_waits);
            let name = format!("{test} {precision}: world {k} frame {frame}");
            println!("{name}: attempts {:?}", substeps(&reports[k]));
            assert_eq!(reports[k], alone, "{name}: the reports");
            retried[k] += alone.retries();
            if exact {
                let own = single.read_state().expect("state");
                assert_eq!(bits(&states[k]), bits(&own), "{name}: the state");
            }
        }
        // The batch's wait, then the retried worlds in lockstep: as many
        // waits as the retried world that waits most alone.
        let expected = 1 + if contact && failed {
            most
        } else {
            most_retried
        };
        let got = reports[0].host_waits;
        println!("{test} {precision}: frame {frame} host waits {got} (expected {expected})");
        assert_eq!(
            got, expected,
            "{test} {precision} frame {frame}: host waits"
        );
    }
    assert!(retried[1] > 0 && retried[3] > 0, "{retried:?}");
    assert_eq!((retried[0], retried[2]), (0, 0), "{retried:?}");
}

#[test]
fn guarded_worlds_are_their_own_adaptive_runs_in_f64() {
    let test = "batch_guards f64";
    worlds_are_their_own_adaptive_runs(test, (&worlds(), false), Precision::F64, 3);
}

#[test]
fn guarded_worlds_are_their_own_adaptive_runs_in_f32() {
    let test = "batch_guards f32";
    worlds_are_their_own_adaptive_runs(test, (&worlds(), false), Precision::F32, 2);
}

#[test]
fn guarded_worlds_with_particle_contact_are_their_own_adaptive_runs() {
    // Two substeps, nodes of radius 0.06 m (neighbours 0.1 m apart touch):
    // a rejection at substep 0 in one world stops every world's later
    // contact calls (contact.wgsl's `failed_before`), so every world of
    // a failed step is retried alone.
    let scenes: Vec<Scene> = worlds()
        .into_iter()
        .map(|mut s| {
            s.substeps = 2;
            s.collisions = Some(hyperpbd::Collisions {
                friction: 0.0,
                margin: 0.0,
            });
            for p in &mut s.particles {
                p.radius = 0.06;
            }
            s
        })
        .collect();
    let test = "batch_guards contact";
    worlds_are_their_own_adaptive_runs(test, (&scenes, true), Precision::F64, 2);
}

#[test]
fn a_world_rejected_at_every_subdivision_fails_the_batch_put_back() {
    let test = "batch_guards rejected at every subdivision";
    let Some((adapter, _)) = adapter_or_skip(test, Precision::F64) else {
        return;
    };
    // World 1 moves at 2 m/s under a limit of its own of 1 m/s (world 0's
    // is 100 m/s), world 3 inverts: no subdivision helps either.
    let scenes = vec![
        world(1.0, Some(100.0), 1),
        world(2.0, Some(1.0), 1),
        world(2.0, Some(100.0), 1),
        world(40.0, Some(100.0), 1),
    ];
    let batch = Batch::new(&scenes).expect("one topology");
    let mut gpu = GpuBatch::on_adapter(&adapter, &batch, Precision::F64).expect("batch");
    let before = gpu.read_states().expect("states");
    let e = gpu.step().expect_err("worlds 1 and 3 are rejected twice");
    let BatchError::Backend { world, source } = &e else {
        panic!("not a world's error: {e}");
    };
    assert_eq!(*world, 1, "{e}");
    let plan = Plan::compile(&scenes[1]).expect("plan");
    let mut alone = GpuBackend::with_adapter(
        &adapter,
        plan,
        &State::from_scene(&scenes[1]),
        Precision::F64,
    )
    .expect("single");
    let expected = alone.step().expect_err("rejected alone").to_string();
    assert_eq!(source.to_string(), expected);
    println!("{test}: {expected}");
    assert!(expected.contains("speed"), "{expected}");
    let after = gpu.read_states().expect("states");
    for (k, (a, b)) in before.iter().zip(&after).enumerate() {
        assert_eq!(bits(a), bits(b), "world {k} not put back");
    }
}
