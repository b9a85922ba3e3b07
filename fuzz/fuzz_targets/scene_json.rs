//! Arbitrary bytes through the JSON scene loader.
//!
//! ```text
//! bytes ─UTF-8?─▶ Scene::parse_json ─▶ validate ─▶ Plan::compile ─▶ 1 CPU step
//! ```
//! Every stage must answer with a value or a typed error, never a panic,
//! an abort or a hang. A scene that validates must also compile (nothing
//! downstream re-checks validation). Small valid scenes run one step of the
//! CPU golden path; a step may fail (`StepError`), but then the state must
//! be byte-identical to the state before it.

#![no_main]

use hyperpbd_core::{Backend, Plan, Scene, State};
use hyperpbd_cpu::CpuBackend;
use libfuzzer_sys::fuzz_target;

/// Largest scene (particles × dim, plus substeps × the work of one
/// substep: constraint indices and contact pairs per iteration, Newton
/// passes over particles × obstacles) that is stepped; bigger ones are only
/// validated and compiled, so one input never takes seconds.
const STEP_BUDGET: u64 = 20_000;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let scene = match Scene::parse_json(text) {
        Ok(scene) => scene,
        Err(e) => {
            assert!(!e.to_string().is_empty(), "empty parse error");
            return;
        }
    };
    if let Err(e) = scene.validate() {
        assert!(!e.to_string().is_empty(), "empty validation error");
        return;
    }
    // Scenes that validate compile: a validated scene is never refused
    // later.
    let plan = match Plan::compile(&scene) {
        Ok(plan) => plan,
        Err(e) => panic!("validated scene refused by Plan::compile: {e}"),
    };
    let elements: u64 = plan
        .families
        .iter()
        .map(|f| (f.len() * f.arity) as u64)
        .sum();
    let particles = plan.particle_count() as u64;
    // Per substep: the constraint projections; with particle contact up to
    // n² candidate pairs per iteration; on the barrier path up to
    // max_iterations Newton passes over every particle and obstacle.
    let contacts = if plan.contacts.is_some() {
        particles.saturating_mul(particles)
    } else {
        0
    };
    let barrier = plan.incremental_potential().map_or(0, |ip| {
        u64::from(ip.max_iterations)
            .saturating_mul(particles)
            .saturating_mul((ip.obstacles.len() as u64).max(1))
    });
    let per_substep = u64::from(plan.iterations)
        .saturating_mul(elements.max(1).saturating_add(contacts))
        .saturating_add(barrier);
    let work = (particles * plan.dim as u64)
        .saturating_add(u64::from(plan.substeps).saturating_mul(per_substep));
    if work > STEP_BUDGET || plan.dim > 16 {
        return;
    }
    let initial = State::from_scene(&scene);
    let mut cpu = match CpuBackend::new(plan, &initial) {
        Ok(cpu) => cpu,
        Err(e) => panic!("a compiled plan must load with its own initial state: {e}"),
    };
    let before = cpu.read_state().expect("CPU read_state cannot fail");
    if cpu.step().is_err() {
        let after = cpu.read_state().expect("CPU read_state cannot fail");
        assert_eq!(
            before.hash(),
            after.hash(),
            "a failed step must leave the state byte-identical"
        );
    }
});
