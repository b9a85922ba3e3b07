//! Batches of worlds on the CPU: world k of a batch stepped in lockstep is
//! bit for bit world k stepped alone; worlds that do not share the
//! topology, or are invalid, are refused naming the world and the field; a
//! failing world puts every world back.

use hyperpbd::batch::{Batch, BatchError, CpuBatch};
use hyperpbd::sweep::Sweep;
use hyperpbd::{Backend, Obstacle, Scene};

const CHAIN: &str = include_str!("../../scenes/chain2d.json");

/// 15 worlds of chain2d: 3 sideways gravities × 5 plane offsets (the
/// highest plane cuts through the hanging chain).
fn worlds() -> Vec<Scene> {
    let axes = ["gravity[0]=-3:3:3", "obstacles[0].offset=0:1.5:5"]
        .iter()
        .map(|a| a.parse().expect("axis"))
        .collect();
    let sweep = Sweep::new(CHAIN, axes).expect("sweep");
    (0..sweep.world_count())
        .map(|w| sweep.scene(w).expect("world"))
        .collect()
}

fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn every_world_of_a_batch_is_its_own_run() {
    let scenes = worlds();
    let batch = Batch::new(&scenes).expect("one topology");
    for threads in [1, 2, 5] {
        let mut batched = CpuBatch::new(&batch, threads).expect("batch");
        for _ in 0..90 {
            let reports = batched.step().expect("step");
            assert_eq!(reports.len(), scenes.len());
        }
        let mut finals = Vec::new();
        for (k, scene) in scenes.iter().enumerate() {
            let mut alone = hyperpbd::cpu_backend(scene).expect("alone");
            for _ in 0..90 {
                alone.step().expect("step");
            }
            let (a, b) = (
                alone.read_state().expect("state"),
                batched.world(k).read_state().expect("state"),
            );
            assert_eq!(
                bits(&a.positions),
                bits(&b.positions),
                "world {k}, {threads} threads"
            );
            assert_eq!(
                bits(&a.velocities),
                bits(&b.velocities),
                "world {k}, {threads} threads"
            );
            finals.push(b.positions);
        }
        // The parameters reach the physics: the plane's offset and the
        // sideways gravity both change where the chain ends up.
        assert_ne!(finals[0], finals[4]);
        assert_ne!(finals[0], finals[10]);
    }
}

#[test]
fn worlds_of_another_topology_are_refused_by_world_and_field() {
    let mut scenes = worlds();
    scenes[3].particles[5].mass = Some(0.2);
    let e = Batch::new(&scenes).expect_err("mass differs").to_string();
    assert!(
        e.starts_with("worlds[3].particles[5].mass: differs from worlds[0]"),
        "{e}"
    );

    let mut scenes = worlds();
    scenes[2].constraints[0].elements.swap(0, 1);
    let e = Batch::new(&scenes)
        .expect_err("elements differ")
        .to_string();
    assert!(e.starts_with("worlds[2].constraints[0]: differs"), "{e}");

    let mut scenes = worlds();
    scenes[4].dt = 0.01;
    let e = Batch::new(&scenes).expect_err("dt differs").to_string();
    assert!(e.starts_with("worlds[4].dt: differs"), "{e}");

    // Effects switched off by a parameter (no damping here) are fine: each
    // world runs its own plan.
    let mut scenes = worlds();
    scenes[4].damping = None;
    assert!(Batch::new(&scenes).is_ok());

    let mut scenes = worlds();
    if let Obstacle::Hyperplane { friction, .. } = &mut scenes[3].obstacles[0] {
        *friction = -1.0;
    }
    let e = Batch::new(&scenes).expect_err("bad friction").to_string();
    assert!(e.starts_with("worlds[3].obstacles[0].friction"), "{e}");

    assert!(matches!(Batch::new(&[]), Err(BatchError::Empty)));
}

#[test]
fn a_failing_world_puts_every_world_back() {
    let mut scenes = worlds();
    // World 7 gets a force that overflows the velocity in one step.
    let n = scenes[7].particles.len();
    scenes[7].particles[n / 2].force = Some(vec![f64::MAX, 0.0]);
    let batch = Batch::new(&scenes).expect("forces are per world");
    let mut batched = CpuBatch::new(&batch, 2).expect("batch");
    let before: Vec<_> = (0..scenes.len())
        .map(|k| batched.world(k).read_state().expect("state"))
        .collect();
    let e = batched.step().expect_err("world 7 overflows");
    assert!(matches!(e, BatchError::Backend { world: 7, .. }), "{e}");
    for (k, state) in before.iter().enumerate() {
        let now = batched.world(k).read_state().expect("state");
        assert_eq!(bits(&now.positions), bits(&state.positions), "world {k}");
        assert_eq!(bits(&now.velocities), bits(&state.velocities), "world {k}");
    }
}

#[test]
fn revert_step_undoes_only_a_successful_last_step() {
    let scene = Scene::from_json_str(CHAIN).expect("chain");
    let mut b = hyperpbd::cpu_backend(&scene).expect("backend");
    assert!(b.revert_step().is_err(), "nothing to revert before a step");
    b.step().expect("step");
    let after_one = b.read_state().expect("state");
    b.step().expect("step");
    b.revert_step().expect("revert the second step");
    let now = b.read_state().expect("state");
    assert_eq!(bits(&now.positions), bits(&after_one.positions));
    assert_eq!(bits(&now.velocities), bits(&after_one.velocities));
    assert!(b.revert_step().is_err(), "one step back only");
    b.step().expect("step");
    b.write_state(&after_one).expect("write");
    assert!(b.revert_step().is_err(), "a written state is not undone");
}
