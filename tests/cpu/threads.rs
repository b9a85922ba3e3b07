//! The CPU golden path on several threads: the same bytes for any thread
//! count.
//!
//! Every shipped scene (`scenes/*.json`) runs for enough frames to reach
//! its contacts on 1 thread with the kernels' own chunks (the reference),
//! and on 1, 2 and 8 threads with every chunk capped at 4 items, so that
//! even these small scenes split every kernel — a colour's projections,
//! the per-particle stages, the contact pairs and gathers, the barrier
//! path's Newton sweeps and its fixed-tree residual — over many chunks on
//! several threads. States must be bit-identical (`State::hash` and every
//! value), and so must the step reports (residual maxima, contact counts,
//! minimisation reports) apart from the thread count they carry. Larger
//! built-in scenes check the kernels' own grains on 2 threads.

use hyperpbd::{Backend, CpuBackend, Plan, Scene, State, StepReport};
use std::path::Path;

/// Chunk cap of the finely split runs.
const FINE_CHUNK: usize = 4;

/// Frames per shipped scene: the cloth needs ~20 frames to reach the
/// ground, the tesseract and the jelly ~15; the granular scenes touch from the start.
fn frames(name: &str) -> usize {
    match name {
        "cloth" | "chain2d" => 40,
        "tesseract" | "jelly4d" => 30,
        "column3d" => 8,
        "ballpit4d" | "sandpile2d" => 30,
        _ => 20,
    }
}

/// `frames` steps on `threads` threads (`max_chunk`: the chunk cap, or
/// `None` for the kernels' own); the final state and every report.
fn run(
    scene: &Scene,
    frames: usize,
    threads: usize,
    max_chunk: Option<usize>,
) -> (State, Vec<StepReport>) {
    let plan = Plan::compile(scene).unwrap_or_else(|e| panic!("scene does not compile: {e}"));
    let mut backend = CpuBackend::with_threads(plan, &State::from_scene(scene), threads)
        .unwrap_or_else(|e| panic!("backend does not load: {e}"));
    if let Some(max_chunk) = max_chunk {
        backend = backend.with_max_chunk(max_chunk);
    }
    assert_eq!(backend.threads(), threads);
    let reports = (0..frames)
        .map(|frame| {
            let report = backend
                .step()
                .unwrap_or_else(|e| panic!("frame {frame}: step failed: {e}"));
            assert_eq!(report.threads, threads, "the report names the thread count");
            report
        })
        .collect();
    let state = backend
        .read_state()
        .unwrap_or_else(|e| panic!("read_state failed: {e}"));
    (state, reports)
}

/// Panics naming the first value that differs.
fn assert_same(what: &str, reference: &(State, Vec<StepReport>), other: &(State, Vec<StepReport>)) {
    let (a, b) = (&reference.0, &other.0);
    let bits = |s: &State| -> Vec<u64> {
        s.positions
            .iter()
            .chain(&s.velocities)
            .map(|v| v.to_bits())
            .collect()
    };
    let (ours, theirs) = (bits(a), bits(b));
    if let Some(k) = (0..ours.len().max(theirs.len())).find(|&k| ours.get(k) != theirs.get(k)) {
        let (half, dim) = (a.positions.len(), a.dim.max(1));
        let (name, index) = if k < half {
            ("positions", k)
        } else {
            ("velocities", k - half)
        };
        panic!(
            "{what}: {name}[{index}] (particle {}, axis {}) is {:?}, the 1-thread reference {:?}: \
             the result depends on the thread count",
            index / dim,
            index % dim,
            theirs.get(k).map(|&v| f64::from_bits(v)),
            ours.get(k).map(|&v| f64::from_bits(v)),
        );
    }
    assert_eq!(a.hash(), b.hash(), "{what}: hash");
    for (frame, (r, o)) in reference.1.iter().zip(&other.1).enumerate() {
        let same_report = StepReport {
            threads: r.threads,
            ..o.clone()
        };
        assert!(
            bitwise_equal(r, &same_report),
            "{what}: the report of frame {frame} differs:\n{r:?}\nvs\n{o:?}"
        );
    }
}

/// Reports equal with every real compared by its bits.
fn bitwise_equal(a: &StepReport, b: &StepReport) -> bool {
    let bits = |r: &StepReport| {
        r.residuals
            .iter()
            .map(|f| (f.label.clone(), f.max_violation.to_bits()))
            .collect::<Vec<_>>()
    };
    let minimisation = |r: &StepReport| format!("{:?}", r.minimisation);
    a.kernel_calls == b.kernel_calls
        && a.active_contacts == b.active_contacts
        && bits(a) == bits(b)
        && minimisation(a) == minimisation(b)
}

fn check(name: &str, scene: &Scene, frames: usize) {
    let reference = run(scene, frames, 1, None);
    for threads in [1, 2, 8] {
        let fine = run(scene, frames, threads, Some(FINE_CHUNK));
        assert_same(
            &format!("{name}, {frames} frames, {threads} threads, chunks of {FINE_CHUNK}"),
            &reference,
            &fine,
        );
    }
    eprintln!(
        "{name}: {frames} frames, hash {:#018x} on 1 thread and on 1, 2, 8 threads in chunks of {FINE_CHUNK}",
        reference.0.hash()
    );
}

#[test]
fn every_shipped_scene_gives_the_same_bytes_on_1_2_and_8_threads() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap_or_else(|e| panic!("{e}")).path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    paths.sort();
    let names: Vec<String> = paths
        .iter()
        .filter_map(|p| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
        .collect();
    for expected in [
        "cloth",
        "tesseract",
        "chain2d",
        "incline5d",
        "example",
        "column3d",
        "ballpit4d",
        "sandpile2d",
        "barrier4d",
        "jelly4d",
    ] {
        assert!(
            names.iter().any(|n| n == expected),
            "scenes/{expected}.json is missing"
        );
    }
    for (path, name) in paths.iter().zip(&names) {
        let scene = Scene::from_json_file(path).unwrap_or_else(|e| panic!("{e}"));
        check(name, &scene, frames(name));
    }
}

/// The kernels' own chunks (thousands of items) on 2 threads: scenes large
/// enough to split at the production grain.
#[test]
fn large_scenes_give_the_same_bytes_at_the_kernels_own_grain() {
    for (name, scene, frames) in [
        ("peer_cloth(128)", hyperpbd::scenes::peer_cloth(128), 10),
        ("cloth(96)", hyperpbd::scenes::cloth(96), 30),
        ("column3d(16, 24)", hyperpbd::scenes::column3d(16, 24), 4),
    ] {
        let reference = run(&scene, frames, 1, None);
        let parallel = run(&scene, frames, 2, None);
        assert_same(&format!("{name}, 2 threads"), &reference, &parallel);
        eprintln!(
            "{name}: {frames} frames, hash {:#018x} on 1 and 2 threads",
            reference.0.hash()
        );
    }
}

/// The end of one substep and the start of the next run as one pass over
/// the particles (velocity, then the next prediction). A failure there is
/// reported as the kernels one by one would report it: particles 17 and
/// 30 start at 1.7e308 m/s with a force of 5e306 N on 1 kg and h = 1 s, so
/// their velocity stays finite in substep 0 and overflows in the
/// prediction of substep 1 — stage `predict`, substep 1, the lower
/// particle — on any thread count, and the state rolls back.
#[test]
fn fused_substeps_fail_where_the_kernels_would() {
    use hyperpbd::{BackendError, Particle, SceneBuilder, StageName, StepError};
    let mut b = SceneBuilder::new(2).dt(10.0).substeps(10);
    for i in 0..40 {
        let mut particle = Particle::new(vec![i as f64, 0.0], 1.0);
        if i == 17 || i == 30 {
            particle = particle.with_velocity(vec![1.7e308, 0.0]);
            particle.force = Some(vec![5e306, 0.0]);
        }
        b.particle(particle);
    }
    let scene = b.build().unwrap_or_else(|e| panic!("{e}"));
    for (threads, max_chunk) in [(1, None), (2, Some(FINE_CHUNK)), (8, Some(FINE_CHUNK))] {
        let plan = Plan::compile(&scene).unwrap_or_else(|e| panic!("{e}"));
        let mut backend = CpuBackend::with_threads(plan, &State::from_scene(&scene), threads)
            .unwrap_or_else(|e| panic!("{e}"));
        if let Some(max_chunk) = max_chunk {
            backend = backend.with_max_chunk(max_chunk);
        }
        let before = backend.read_state().unwrap_or_else(|e| panic!("{e}"));
        match backend.step() {
            Err(BackendError::Step(StepError::NonFiniteParticle {
                stage,
                substep,
                particle,
            })) => {
                assert_eq!(
                    (stage, substep, particle),
                    (StageName::Predict, 1, 17),
                    "{threads} threads"
                );
            }
            other => panic!("{threads} threads: expected a failed prediction, got {other:?}"),
        }
        let after = backend.read_state().unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            after.hash(),
            before.hash(),
            "{threads} threads: rolled back"
        );
    }
}

/// The barrier path's packed-gradient criterion sums per-particle terms by
/// a fixed pairwise tree; split into blocks of 4 on several threads the
/// blocks are subtrees of the same tree, so the residuals (and with them
/// the Newton iterations and the state) are the same bits.
#[test]
fn the_packed_gradient_sum_keeps_its_tree_on_any_thread_count() {
    use hyperpbd::{Convergence, Solver};
    let mut scene = hyperpbd::scenes::barrier4d();
    let Solver::IncrementalPotential(settings) = &mut scene.solver else {
        panic!("barrier4d is a barrier scene");
    };
    settings.convergence = Convergence::PackedGradient { tolerance: 1e-9 };
    check("barrier4d (packed gradient)", &scene, 20);
}
