//! The incremental-potential paths in a GPU batch (issue 35 item 4): W
//! worlds, each its own backend (the coupled step for the implicit chain,
//! the barrier step for the 4D drop onto a mesh), stepped in lockstep on
//! one device (gpu/src/batch/lockstep.rs). Every world's reports (but the
//! host waits: the batch step's) and state, frame after frame, equal its
//! own single GPU run — bit for bit where the adapter claims it, in f64 and
//! f32 (each world keeps its own origin); the batch step waits on the host
//! max_k n_k times where the W single runs wait n_k each; a world whose
//! step fails fails the batch step, named with its own run's error, every
//! world put back.

use std::path::Path;

use crate::common;

use common::exact::{bits, f32_identical, f64_identical};
use common::gpu::adapter_or_skip;
use hyperpbd::batch::{Batch, BatchError, GpuBatch};
use hyperpbd::{Backend, Plan, Precision, Scene, State};

fn scene(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(format!("{name}.json"));
    Scene::from_json_file(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The implicit chain (coupled step) at three gravities and two
/// compliances: the worlds need different numbers of Newton iterations.
fn chains() -> Vec<Scene> {
    [(-9.81, 1e-6), (-2.0, 1e-6), (-25.0, 1e-4)]
        .into_iter()
        .map(|(g, compliance)| {
            let mut s = scene("chain2d_implicit");
            s.gravity.as_mut().expect("gravity")[1] = g;
            s.constraints[0].compliance = compliance;
            s
        })
        .collect()
}

/// The 4D drop onto a mesh (barrier step) at three gravities.
fn drops() -> Vec<Scene> {
    [-9.81, -1.0, -30.0]
        .into_iter()
        .map(|g| {
            let mut s = scene("barrier4d");
            s.gravity.as_mut().expect("gravity")[3] = g;
            s
        })
        .collect()
}

/// `scenes` batched in `precision` against their own single GPU runs,
/// `frames` frames (see the module docs); returns the batch's host waits
/// and the singles' over all frames.
fn worlds_are_their_own_runs(
    test: &str,
    scenes: &[Scene],
    precision: Precision,
    frames: usize,
) -> Option<(u64, u64)> {
    let (adapter, summary) = adapter_or_skip(test, precision)?;
    let batch = Batch::new(scenes).expect("one topology");
    let mut gpu = GpuBatch::on_adapter(&adapter, &batch, precision).expect("an implicit batch");
    assert_eq!(gpu.dispatches_per_step(), None);
    let mut singles: Vec<Box<dyn Backend>> = scenes
        .iter()
        .map(|s| {
            let plan = Plan::compile(s).expect("plan");
            hyperpbd::load_on_adapter(&adapter, plan, &State::from_scene(s), precision)
                .expect("single")
        })
        .collect();
    let exact = match precision {
        Precision::F64 => f64_identical(&summary),
        Precision::F32 => f32_identical(&summary),
    };
    let (mut batch_waits, mut single_waits) = (0, 0);
    let mut iterations = vec![0; scenes.len()];
    for frame in 0..frames {
        let reports = gpu.step().expect("batch step");
        let states = gpu.read_states().expect("states");
        let mut most = 0;
        for (k, single) in singles.iter_mut().enumerate() {
            let mut alone = single.step().expect("single step");
            let name = format!("{test} {precision}: world {k} frame {frame}");
            most = most.max(alone.host_waits);
            single_waits += alone.host_waits;
            alone.host_waits = reports[k].host_waits;
            assert_eq!(reports[k], alone, "{name}: the reports");
            iterations[k] += alone.minimisation[0].iterations;
            if exact {
                let own = single.read_state().expect("state");
                assert_eq!(bits(&states[k]), bits(&own), "{name}: the state");
            }
        }
        let got = reports[0].host_waits;
        println!("{test} {precision}: frame {frame} host waits {got} (singles: most {most})");
        for (k, r) in reports.iter().enumerate() {
            let name = format!("{test} {precision} world {k} frame {frame}");
            assert_eq!(r.host_waits, most, "{name}: the batch step's host waits");
        }
        batch_waits += got;
    }
    // The worlds stop on their own criteria, after different iterations.
    println!("{test} {precision}: Newton iterations per world {iterations:?}");
    assert!(
        iterations.iter().any(|&i| i != iterations[0]),
        "{iterations:?}"
    );
    Some((batch_waits, single_waits))
}

#[test]
fn implicit_chains_are_their_own_coupled_runs_in_f64() {
    let test = "batch_implicit chains";
    if let Some((batch, singles)) = worlds_are_their_own_runs(test, &chains(), Precision::F64, 4) {
        println!("{test}: host waits {batch} batched, {singles} one world after another");
        assert!(batch < singles, "{batch} vs {singles}");
    }
}

#[test]
fn implicit_chains_are_their_own_coupled_runs_in_f32() {
    let test = "batch_implicit chains";
    worlds_are_their_own_runs(test, &chains(), Precision::F32, 3);
}

#[test]
fn drops_onto_a_mesh_are_their_own_barrier_runs() {
    let test = "batch_implicit drops";
    worlds_are_their_own_runs(test, &drops(), Precision::F64, 4);
}

#[test]
fn a_failing_world_fails_the_implicit_batch_put_back() {
    let test = "batch_implicit failing world";
    let Some((adapter, _)) = adapter_or_skip(test, Precision::F64) else {
        return;
    };
    let scenes = chains();
    let batch = Batch::new(&scenes).expect("one topology");
    let mut gpu = GpuBatch::on_adapter(&adapter, &batch, Precision::F64).expect("batch");
    gpu.step().expect("a first step");
    // World 1's middle bead below the floor: an infeasible start, refused
    // by its own step; worlds 0 and 2 step and are put back.
    let mut states = gpu.read_states().expect("states");
    states[1].positions[2 * 10 + 1] = -0.05;
    gpu.write_state(1, &states[1]).expect("write");
    let before = gpu.read_states().expect("states");
    let e = gpu.step().expect_err("world 1 starts inside the floor");
    let BatchError::Backend { world, source } = &e else {
        panic!("not a world's error: {e}");
    };
    assert_eq!(*world, 1, "{e}");
    let plan = Plan::compile(&scenes[1]).expect("plan");
    let mut alone =
        hyperpbd::load_on_adapter(&adapter, plan, &states[1], Precision::F64).expect("single");
    let expected = alone.step().expect_err("refused alone").to_string();
    println!("{test}: {expected}");
    assert_eq!(source.to_string(), expected);
    let after = gpu.read_states().expect("states");
    for (k, (a, b)) in before.iter().zip(&after).enumerate() {
        assert_eq!(bits(a), bits(b), "world {k} not put back");
    }
    // The batch goes on once the world is out of the floor.
    states[1].positions[2 * 10 + 1] = 1.4;
    gpu.write_state(1, &states[1]).expect("write");
    gpu.step().expect("a step after the failure");
}
