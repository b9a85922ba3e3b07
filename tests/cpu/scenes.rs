//! The scenes shipped in `scenes/`: each built-in one matches its builder
//! (regenerate with `hyperpbd scene NAME --out scenes/NAME.json`), and every
//! file loads, compiles and runs on the golden path without a non-finite
//! value or a constraint blowing up.

use hyperpbd::{Backend, CpuBackend, Plan, Scene, State};
use std::path::Path;

fn scene_file(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name)
}

#[test]
fn shipped_builtin_scenes_match_their_builders() {
    for name in hyperpbd::scenes::NAMES {
        let path = scene_file(&format!("{name}.json"));
        let loaded =
            Scene::from_json_file(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let built = hyperpbd::scenes::by_name(name).expect("listed name");
        assert!(
            loaded == built,
            "{} differs from hyperpbd::scenes::{name}(); regenerate it with \
             `cargo run --release -- scene {name} --out scenes/{name}.json`",
            path.display()
        );
    }
}

#[test]
fn every_shipped_scene_runs() {
    let mut names: Vec<_> = std::fs::read_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes"))
        .expect("scenes/ exists")
        .map(|e| e.expect("readable entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "json"))
        .collect();
    names.sort();
    assert!(
        names.len() >= 5,
        "expected the shipped scenes, found {names:?}"
    );
    for path in names {
        let scene = Scene::from_json_file(&path).unwrap_or_else(|e| panic!("{e}"));
        let plan = Plan::compile(&scene).unwrap_or_else(|e| panic!("{e}"));
        let mut backend = CpuBackend::new(plan, &State::from_scene(&scene)).expect("loads");
        let mut worst: f64 = 0.0;
        for _ in 0..10 {
            let report = backend
                .step()
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            worst = worst.max(report.max_violation());
        }
        let state = backend.read_state().expect("cpu read");
        assert!(
            state
                .positions
                .iter()
                .chain(&state.velocities)
                .all(|x| x.is_finite()),
            "{}: non-finite state",
            path.display()
        );
        // Bound: every shipped scene is at most a few metres across with
        // constraints of order 1 (lengths, unit-cell measures); a violation
        // of 1e-2 after 10 frames would mean the solver is not converging.
        eprintln!("{}: max violation {worst:e} / bound 1e-2", path.display());
        assert!(worst < 1e-2, "{}: max violation {worst:e}", path.display());
    }
}
