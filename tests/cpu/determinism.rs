//! Determinism goldens for the CPU path.
//!
//! The f64 CPU backend is the golden path: sequential, no threads, fixed
//! Gauss–Seidel order from the plan's coloring, transcendentals through
//! `libm`. Its state after a fixed number of steps of a built-in scene is
//! therefore a constant, pinned here as `State::hash()` (FNV-1a over the
//! exact bit patterns of every position and velocity).
//!
//! A mismatch means the CPU arithmetic changed. That is allowed only on
//! purpose (a deliberate change of the golden algorithm, explained in the
//! commit); an accidental change — a reordered sum, a fused multiply-add, a
//! parallel reduction, a platform `exp` — is exactly what these tests exist
//! to catch.

use crate::support;

use hyperpbd::{Backend, CpuBackend, Plan, Scene, State};
use support::{backend, state, step};

/// `scenes::cloth(16)` after 60 steps (1 s): 256 particles, distance
/// family with 8 colors, ground contact with static and dynamic friction,
/// damping.
const CLOTH16_60_FRAMES: u64 = 0x166b_9c6b_e98b_8363;

/// `scenes::tesseract()` after 30 steps (0.5 s): 81 particles, 384 oriented
/// 4-simplices (generic measure path with the adjugate), contact with
/// friction, damping.
const TESSERACT_30_FRAMES: u64 = 0x0a6f_6981_90f9_ab01;

/// `scenes::jelly4d()` after 30 steps (0.5 s): 81 particles with lumped
/// masses, 384 Neo-Hookean 4-simplices (the XPBD energy constraint), floor
/// contact with friction, damping.
const JELLY4D_30_FRAMES: u64 = 0xa98f_1ac7_70ac_eca9;

/// `scenes::sandpile2d()` after 60 steps (1 s): balls poured onto a floor,
/// broadphase every substep, averaged gather-Jacobi contact with friction.
const SANDPILE2D_60_FRAMES: u64 = 0x6a17_493f_e109_e18a;

/// Runs `frames` steps of `scene` on a fresh CPU backend.
fn run(scene: &Scene, frames: usize) -> State {
    let mut sim = backend(scene);
    for _ in 0..frames {
        step(&mut sim);
    }
    state(&mut sim)
}

/// The failure message of a pinned-hash mismatch: what changed and what to
/// do about it.
fn golden_message(what: &str, constant: &str, got: u64, pinned: u64) -> String {
    format!(
        "{what}: State::hash() = {got:#018x}, pinned {constant} = {pinned:#018x}.\n\
         If you changed the golden algorithm on purpose (the CPU path's arithmetic or its order), \
         explain why in the commit and update the constant to:\n    \
         const {constant}: u64 = {got:#018x};\n\
         otherwise the CPU path lost determinism (or its arithmetic changed by accident: \
         a reordered sum, an FMA, a parallel reduction, a non-libm transcendental) — \
         find the cause before touching the constant."
    )
}

#[test]
fn cloth16_state_hash_is_pinned() {
    let got = run(&hyperpbd::scenes::cloth(16), 60).hash();
    eprintln!("cloth(16), 60 frames: hash {got:#018x} / pinned {CLOTH16_60_FRAMES:#018x}");
    assert_eq!(
        got,
        CLOTH16_60_FRAMES,
        "{}",
        golden_message(
            "cloth(16) after 60 frames",
            "CLOTH16_60_FRAMES",
            got,
            CLOTH16_60_FRAMES
        )
    );
}

#[test]
fn jelly4d_state_hash_is_pinned() {
    let got = run(&hyperpbd::scenes::jelly4d(), 30).hash();
    eprintln!("jelly4d(), 30 frames: hash {got:#018x} / pinned {JELLY4D_30_FRAMES:#018x}");
    assert_eq!(
        got,
        JELLY4D_30_FRAMES,
        "{}",
        golden_message(
            "jelly4d() after 30 frames",
            "JELLY4D_30_FRAMES",
            got,
            JELLY4D_30_FRAMES
        )
    );
}

#[test]
fn tesseract_state_hash_is_pinned() {
    let got = run(&hyperpbd::scenes::tesseract(), 30).hash();
    eprintln!("tesseract(), 30 frames: hash {got:#018x} / pinned {TESSERACT_30_FRAMES:#018x}");
    assert_eq!(
        got,
        TESSERACT_30_FRAMES,
        "{}",
        golden_message(
            "tesseract() after 30 frames",
            "TESSERACT_30_FRAMES",
            got,
            TESSERACT_30_FRAMES
        )
    );
}

#[test]
fn sandpile2d_state_hash_is_pinned() {
    let got = run(&hyperpbd::scenes::sandpile2d(), 60).hash();
    eprintln!("sandpile2d(), 60 frames: hash {got:#018x} / pinned {SANDPILE2D_60_FRAMES:#018x}");
    assert_eq!(
        got,
        SANDPILE2D_60_FRAMES,
        "{}",
        golden_message(
            "sandpile2d() after 60 frames",
            "SANDPILE2D_60_FRAMES",
            got,
            SANDPILE2D_60_FRAMES
        )
    );
}

/// Bit-for-bit comparison with the first differing value named.
fn assert_bit_identical(what: &str, a: &State, b: &State) {
    assert_eq!(a.dim, b.dim, "{what}: dimension differs");
    for (name, xs, ys) in [
        ("positions", &a.positions, &b.positions),
        ("velocities", &a.velocities, &b.velocities),
    ] {
        assert_eq!(xs.len(), ys.len(), "{what}: {name} length differs");
        if let Some(k) = xs
            .iter()
            .zip(ys.iter())
            .position(|(x, y)| x.to_bits() != y.to_bits())
        {
            panic!(
                "{what}: {name}[{k}] (particle {}, axis {}) differs: {:e} vs {:e} — \
                 the CPU path lost determinism",
                k / a.dim,
                k % a.dim,
                xs[k],
                ys[k]
            );
        }
    }
    assert_eq!(
        a.hash(),
        b.hash(),
        "{what}: equal bits but different hashes"
    );
}

/// Two runs in one process, and a run on another thread at the same time,
/// give bit-identical states (no dependence on allocation, thread or any
/// global state).
#[test]
fn repeated_runs_are_bit_identical() {
    for (name, scene, frames) in [
        ("cloth(16)", hyperpbd::scenes::cloth(16), 60),
        ("tesseract()", hyperpbd::scenes::tesseract(), 30),
    ] {
        let other = {
            let scene = scene.clone();
            std::thread::spawn(move || run(&scene, frames))
        };
        let first = run(&scene, frames);
        let second = run(&scene, frames);
        assert_bit_identical(&format!("{name}: run 1 vs run 2"), &first, &second);
        let threaded = other
            .join()
            .unwrap_or_else(|_| panic!("{name}: the threaded run panicked"));
        assert_bit_identical(&format!("{name}: run 1 vs other thread"), &first, &threaded);
        eprintln!(
            "{name}, {frames} frames: hash {:#018x} in all three runs",
            first.hash()
        );
    }
}

/// The state (positions, velocities) is all a step depends on: stopping
/// half way, reading the state out and loading it into a fresh backend
/// continues bit-identically (multipliers are reset every substep, so no
/// hidden solver state may carry over).
#[test]
fn resuming_from_read_state_is_bit_identical() {
    for (name, scene, frames) in [
        ("cloth(16)", hyperpbd::scenes::cloth(16), 60),
        ("tesseract()", hyperpbd::scenes::tesseract(), 30),
    ] {
        let straight = run(&scene, frames);
        let half = run(&scene, frames / 2);
        let plan = Plan::compile(&scene).unwrap_or_else(|e| panic!("{name}: {e}"));
        let mut resumed = CpuBackend::new(plan, &half).unwrap_or_else(|e| panic!("{name}: {e}"));
        for _ in frames / 2..frames {
            step(&mut resumed);
        }
        let resumed = state(&mut resumed);
        assert_bit_identical(&format!("{name}: straight vs resumed"), &straight, &resumed);

        // write_state on a running backend is the same as a fresh one.
        let mut sim = backend(&scene);
        step(&mut sim);
        sim.write_state(&half)
            .unwrap_or_else(|e| panic!("{name}: write_state failed: {e}"));
        for _ in frames / 2..frames {
            step(&mut sim);
        }
        let rewritten = state(&mut sim);
        assert_bit_identical(
            &format!("{name}: straight vs write_state"),
            &straight,
            &rewritten,
        );
        eprintln!("{name}: resumed at frame {} bit-identically", frames / 2);
    }
}
