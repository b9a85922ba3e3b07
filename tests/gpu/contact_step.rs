//! The contact step on the device (gpu/src/contact: hashed-grid
//! broadphase, per-particle sorted lists, gather-Jacobi iteration, report)
//! against the CPU golden path, held to exact equality:
//!
//! ```text
//! f64 states        to_bits of every position and velocity, every frame
//! f64 reports       to_bits of every residual (the collisions' deepest overlap
//!                   included), active contacts, kernel calls
//! schedules         the fused schedule (default for contact plans) and the exact one
//! regrowth          a scene whose lists outgrow the initial slots: the step
//!                   grows them, reruns from its start, and still matches
//! failures          a non-finite contact distance: the CPU's error, state kept
//! run_kernel        Predict, Broadphase, Collide, Velocity one at a time
//! f32               bit-identical between runs (integer atomics only order
//!                   bucket slots; lists are sorted); on lavapipe also
//!                   bit-identical to the f32 reference (states, reports),
//!                   the regrowth step included
//! loop budget       llvmpipe ends a shader's loops after 65 535 iterations:
//!                   a cut is a typed error, never a short list
//! ```
//! Every bound is 0 (bit-identical) except the loop-budget case, which
//! asserts the exact error on llvmpipe and exact pairs elsewhere.

use crate::common;

use common::bound::print_bound;

use common::exact::{assert_f32_reference_step, f32_identical};
use common::gpu::adapter_or_skip;
use hyperpbd::{
    Backend, BackendError, Collisions, CpuBackend, F32Reference, Kernel, Particle, Plan, Scene,
    SceneBuilder, StageName, State, StepError, StepReport,
};
use hyperpbd_core::broadphase::Aabbs;
use hyperpbd_gpu::{GpuBackend, GpuSweep, Precision, StepMode};

fn bits(values: &[f64]) -> Vec<u64> {
    values.iter().map(|v| v.to_bits()).collect()
}

/// 12 × 8 balls 0.1 apart in 2D with a 0.5 box margin: every box meets
/// ~80 others, more than the 32 list slots a contact stage starts with.
fn dense_cluster() -> Scene {
    cluster(0.5, 0.3)
}

/// 12 × 8 balls 0.1 apart in 2D over a floor, with box margin `margin`
/// (0.5: every box meets ~80 others; 0.01: a handful) and ball–ball
/// friction `mu`.
pub(crate) fn cluster(margin: f64, mu: f64) -> Scene {
    let mut b = SceneBuilder::new(2)
        .dt(1.0 / 60.0)
        .substeps(2)
        .iterations(2)
        .gravity_along(1, 9.81);
    for k in 0..96 {
        let (i, j) = ((k % 12) as f64, (k / 12) as f64);
        b.particle(Particle::new(vec![0.1 * i, 0.06 + 0.1 * j], 0.01).with_radius(0.05));
    }
    b.hyperplane(vec![0.0, 1.0], 0.0, 0.4);
    b.scene_mut().collisions = Some(Collisions {
        friction: mu,
        margin,
    });
    b.build().expect("valid scene")
}

fn scenes() -> Vec<(&'static str, Scene, usize)> {
    vec![
        ("sandpile2d", hyperpbd::scenes::sandpile2d(), 6),
        ("ballpit4d", hyperpbd::scenes::ballpit4d(), 6),
        ("column3d 6x10x6", hyperpbd::scenes::column3d(6, 10), 6),
        ("pit3d 8x6x8", hyperpbd::scenes::pit3d(8, 6), 6),
        ("dense cluster 2d", dense_cluster(), 4),
    ]
}

fn assert_reports_equal(name: &str, cpu: &StepReport, gpu: &StepReport) {
    assert_eq!(cpu.kernel_calls, gpu.kernel_calls, "{name}: kernel calls");
    assert_eq!(
        cpu.active_contacts, gpu.active_contacts,
        "{name}: active contacts"
    );
    assert_eq!(
        cpu.residuals.len(),
        gpu.residuals.len(),
        "{name}: residuals"
    );
    for (c, g) in cpu.residuals.iter().zip(&gpu.residuals) {
        assert_eq!(c.label, g.label, "{name}: residual labels");
        assert_eq!(
            c.max_violation.to_bits(),
            g.max_violation.to_bits(),
            "{name}: residual {} {} vs {}",
            c.label,
            c.max_violation,
            g.max_violation
        );
    }
}

#[test]
fn f64_contact_steps_equal_the_cpu_bit_for_bit_in_both_schedules() {
    let Some((adapter, _)) = adapter_or_skip("gpu_contact_step_f64", Precision::F64) else {
        return;
    };
    let mut frames_compared = 0;
    for (name, scene, frames) in scenes() {
        let plan = Plan::compile(&scene).expect("valid");
        let state = State::from_scene(&scene);
        for mode in [StepMode::Fused, StepMode::Exact] {
            let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
            let mut gpu =
                common::gpu::in_mode(&adapter, (&plan, &state), Precision::F64, mode).expect("gpu");
            for frame in 0..frames {
                let label = format!("{name} ({}) frame {frame}", mode.as_str());
                let rc = cpu.step().expect("cpu step");
                let rg = gpu.step().expect("gpu step");
                assert_reports_equal(&label, &rc, &rg);
                let (sc, sg) = (cpu.read_state().unwrap(), gpu.read_state().unwrap());
                assert!(
                    bits(&sc.positions) == bits(&sg.positions),
                    "{label}: positions differ"
                );
                assert!(
                    bits(&sc.velocities) == bits(&sg.velocities),
                    "{label}: velocities differ"
                );
                frames_compared += 1;
            }
        }
    }
    print_bound(
        "gpu f64 contact step == cpu (5 scenes, fused and exact)",
        format_args!("{frames_compared} frames, 0 differing bits"),
        0,
        "same pairs, same list order, same operations",
    );
}

#[test]
fn lists_that_outgrow_their_slots_are_grown_and_the_step_rerun() {
    for precision in [Precision::F32, Precision::F64] {
        let Some((adapter, summary)) = adapter_or_skip("gpu_contact_regrowth", precision) else {
            return;
        };
        let scene = dense_cluster();
        let plan = Plan::compile(&scene).expect("valid");
        let mut state = State::from_scene(&scene);
        if precision == Precision::F32 {
            // Both backends start from the same (f32-representable) state.
            for v in state
                .positions
                .iter_mut()
                .chain(state.velocities.iter_mut())
            {
                *v = f64::from(*v as f32);
            }
        }
        let mut gpu =
            GpuBackend::with_adapter(&adapter, plan.clone(), &state, precision).expect("gpu");
        assert_eq!(gpu.contact_list_slots(), Some(32));
        let mut reference = (precision == Precision::F32 && f32_identical(&summary)).then(|| {
            F32Reference::new(plan.clone(), &state, gpu.origin().as_slice()).expect("reference")
        });
        let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
        let rc = cpu.step().expect("cpu step");
        let rg = gpu.step().expect("gpu step after regrowth");
        if let Some(r) = reference.as_mut() {
            // The balls start exactly touching: f32 rounding decides which
            // pairs are active, and the reference decides it the same way.
            let sg = gpu.read_state().unwrap();
            assert_f32_reference_step("dense cluster after regrowth", 1, r, &rg, &sg);
            print_bound(
                "gpu f32 list regrowth inside a step (dense cluster 2d, 1 frame) vs f32 reference",
                "0 differing bits (state, residuals, active contacts)",
                0,
                "llvmpipe: exact",
            );
        }
        let slots = gpu.contact_list_slots().unwrap_or(0);
        let c = cpu.contacts();
        let longest = (0..96)
            .map(|k| (c.offsets[k + 1] - c.offsets[k]) as usize)
            .max()
            .unwrap_or(0);
        assert!(longest > 32, "the scene must outgrow the initial slots");
        assert!(slots >= longest, "{precision}: slots {slots} < {longest}");
        let (sc, sg) = (cpu.read_state().unwrap(), gpu.read_state().unwrap());
        if precision == Precision::F64 {
            assert_reports_equal("dense cluster after regrowth", &rc, &rg);
            assert!(bits(&sc.positions) == bits(&sg.positions));
            assert!(bits(&sc.velocities) == bits(&sg.velocities));
            print_bound(
                "gpu f64 list regrowth inside a step (dense cluster 2d, 1 frame)",
                format_args!("longest list {longest}, slots 32 → {slots}, 0 differing bits"),
                0,
                "rerun from the saved state",
            );
        } else {
            // The rounding bound of tests/gpu/granular.rs: the contact
            // kernel's per-iteration bound summed over the frame. (Active
            // counts are not compared: the balls start exactly touching, so
            // f32 rounding decides which pairs are active.)
            let err = sc
                .positions
                .iter()
                .zip(&sg.positions)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            let scale = state.positions.iter().fold(1.0f64, |m, v| m.max(v.abs()));
            let bound = f64::from(f32::EPSILON)
                * scale
                * (8.0 * plan.dim as f64 + 40.0)
                * f64::from(plan.iterations)
                * f64::from(plan.substeps);
            print_bound(
                "gpu f32 list regrowth inside a step (dense cluster 2d, 1 frame) position",
                format_args!("{err:e}"),
                format_args!("{bound:e}"),
                format_args!(
                    "ε·X·(8N+40)·iterations·substeps; longest list {longest}, slots 32 → {slots}"
                ),
            );
            assert!(err <= bound, "f32 regrowth: {err:e} > {bound:e}");
        }
    }
}

/// Two balls 1e200 apart with radius 1e200: their boxes overlap and
/// |d|² overflows, so the contact distance is not finite.
fn overflowing_pair() -> Scene {
    huge_pair(1e200)
}

/// Two balls of radius 1e200 at distance `gap`: at 1e200 their boxes
/// overlap and |d|² overflows (a non-finite contact), at 3e200 they do not.
pub(crate) fn huge_pair(gap: f64) -> Scene {
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(2)
        .iterations(1);
    b.particle(Particle::new(vec![0.0, 0.0, 0.0], 1.0).with_radius(1e200));
    b.particle(Particle::new(vec![gap, 0.0, 0.0], 1.0).with_radius(1e200));
    b.scene_mut().collisions = Some(Collisions {
        friction: 0.0,
        margin: 0.0,
    });
    b.build().expect("valid scene")
}

#[test]
fn a_non_finite_contact_is_named_like_the_cpu_and_rolled_back() {
    let Some((adapter, _)) = adapter_or_skip("gpu_contact_non_finite", Precision::F64) else {
        return;
    };
    let scene = overflowing_pair();
    let plan = Plan::compile(&scene).expect("valid");
    let state = State::from_scene(&scene);
    let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
    let cpu_error = cpu.step().expect_err("the CPU refuses the step");
    assert!(matches!(
        cpu_error,
        BackendError::Step(StepError::NonFiniteParticle {
            stage: StageName::Project,
            substep: 0,
            particle: 0,
        })
    ));
    for mode in [StepMode::Fused, StepMode::Exact] {
        let mut gpu =
            common::gpu::in_mode(&adapter, (&plan, &state), Precision::F64, mode).expect("gpu");
        let gpu_error = gpu.step().expect_err("the GPU refuses the step");
        assert_eq!(
            gpu_error.to_string(),
            cpu_error.to_string(),
            "{}: the error names what the CPU names",
            mode.as_str()
        );
        let after = gpu.read_state().unwrap();
        assert!(bits(&after.positions) == bits(&state.positions));
        assert!(bits(&after.velocities) == bits(&state.velocities));
    }
}

/// The kernels a contact substep runs, as the kernel-alone tests call them.
const CONTACT_KERNELS: [Kernel; 5] = [
    Kernel::Predict,
    Kernel::Broadphase,
    Kernel::Collide,
    Kernel::Collide,
    Kernel::Velocity,
];

/// A 4 × 5 column of balls after 12 CPU steps (settling, in contact): its
/// CPU backend, plan and state.
fn settled_column() -> (CpuBackend, Plan, State) {
    let scene = hyperpbd::scenes::column3d(4, 5);
    let plan = Plan::compile(&scene).expect("valid");
    let mut cpu = CpuBackend::new(plan.clone(), &State::from_scene(&scene)).expect("cpu");
    for _ in 0..12 {
        cpu.step().expect("cpu step");
    }
    let state = cpu.read_state().unwrap();
    (cpu, plan, state)
}
#[test]
fn contact_kernels_run_alone_like_the_cpu() {
    let Some((adapter, _)) = adapter_or_skip("gpu_contact_run_kernel", Precision::F64) else {
        return;
    };
    let (mut cpu, plan, state) = settled_column();
    let mut gpu = GpuBackend::with_adapter(&adapter, plan, &state, Precision::F64).expect("gpu");
    for kernel in CONTACT_KERNELS {
        cpu.run_kernel(kernel).expect("cpu kernel");
        gpu.run_kernel(kernel).expect("gpu kernel");
        let (sc, sg) = (cpu.read_state().unwrap(), gpu.read_state().unwrap());
        assert!(
            bits(&sc.positions) == bits(&sg.positions),
            "{kernel:?}: positions differ"
        );
        assert!(
            bits(&sc.velocities) == bits(&sg.velocities),
            "{kernel:?}: velocities differ"
        );
    }
    assert!(cpu.contacts().active_count() > 0, "the case has contacts");
}

/// f32 on lavapipe: each contact kernel alone is the f32 reference's
/// kernel bit for bit (lists and the report as well, checked by a step
/// after them).
#[test]
fn f32_contact_kernels_run_alone_like_the_f32_reference() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_contact_run_kernel_f32", Precision::F32)
    else {
        return;
    };
    if !f32_identical(&summary) {
        return;
    }
    let (_, plan, state) = settled_column();
    let mut gpu =
        GpuBackend::with_adapter(&adapter, plan.clone(), &state, Precision::F32).expect("gpu");
    let mut reference =
        F32Reference::new(plan, &state, gpu.origin().as_slice()).expect("reference");
    for kernel in CONTACT_KERNELS {
        reference.run_kernel(kernel).expect("reference kernel");
        gpu.run_kernel(kernel).expect("gpu kernel");
        let (sr, sg) = (reference.read_state(), gpu.read_state().unwrap());
        assert!(
            bits(&sr.positions) == bits(&sg.positions),
            "f32 {kernel:?}: positions differ from the f32 reference"
        );
        assert!(
            bits(&sr.velocities) == bits(&sg.velocities),
            "f32 {kernel:?}: velocities differ from the f32 reference"
        );
    }
    for frame in 1..=3 {
        let report = gpu.step().expect("gpu step");
        let s = gpu.read_state().unwrap();
        assert_f32_reference_step(
            "column3d 4x5 after run_kernel",
            frame,
            &mut reference,
            &report,
            &s,
        );
    }
}

#[test]
fn f32_contact_steps_are_identical_between_runs() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_contact_f32_runs", Precision::F32) else {
        return;
    };
    let scene = hyperpbd::scenes::pit3d(8, 6);
    let plan = Plan::compile(&scene).expect("valid");
    let state = State::from_scene(&scene);
    // On lavapipe the first run is also the f32 reference's, every frame.
    let run = |check: bool| {
        let mut gpu =
            GpuBackend::with_adapter(&adapter, plan.clone(), &state, Precision::F32).expect("gpu");
        let mut reference = (check && f32_identical(&summary)).then(|| {
            F32Reference::new(plan.clone(), &state, gpu.origin().as_slice()).expect("reference")
        });
        for frame in 1..=12 {
            let report = gpu.step().expect("gpu step");
            if let Some(r) = reference.as_mut() {
                let s = gpu.read_state().unwrap();
                assert_f32_reference_step("pit3d 8x6", frame, r, &report, &s);
            }
        }
        let s = gpu.read_state().unwrap();
        (bits(&s.positions), bits(&s.velocities))
    };
    assert!(
        run(true) == run(false),
        "f32 contact steps differ between runs"
    );
}

#[test]
fn loops_the_adapter_cuts_short_are_an_error_never_a_short_list() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_contact_loop_budget", Precision::F32)
    else {
        return;
    };
    // 5000 boxes that all overlap: every list has 4999 entries, more loop
    // iterations than llvmpipe runs in one invocation.
    let n = 5000;
    let boxes = Aabbs::new(1, vec![0.0; n], vec![1.0; n]);
    let mut sweep = GpuSweep::with_adapter(&adapter, 1, Precision::F32, 8).expect("sweep");
    match sweep.sweep(&boxes, 0) {
        Ok(pairs) => {
            assert!(
                !summary.name.contains("llvmpipe"),
                "llvmpipe cannot run these loops to the end, yet pairs came back"
            );
            assert_eq!(pairs.len(), n * (n - 1) / 2);
        }
        Err(e) => {
            assert!(e.to_string().contains("65 535"), "unexpected error: {e}");
            print_bound(
                format_args!("loop budget of {}", summary.name),
                format_args!("typed error: {e}"),
                "—",
                "never a short list",
            );
        }
    }
}

/// 5000 balls of radius 1 within 0.07 of each other in 2D: every box
/// overlaps every other, so every contact list holds 4999 entries.
fn heap_of_overlapping_balls(n: usize) -> Scene {
    let mut b = SceneBuilder::new(2)
        .dt(1.0 / 60.0)
        .substeps(1)
        .iterations(1);
    for k in 0..n {
        let (i, j) = ((k % 71) as f64, (k / 71) as f64);
        b.particle(Particle::new(vec![0.001 * i, 0.001 * j], 1.0).with_radius(1.0));
    }
    b.scene_mut().collisions = Some(Collisions {
        friction: 0.0,
        margin: 0.0,
    });
    b.build().expect("valid scene")
}

#[test]
fn a_step_whose_loops_the_adapter_cuts_short_is_refused_and_rolled_back() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_contact_step_loop_budget", Precision::F32)
    else {
        return;
    };
    // The first pass finds lists of 4999 entries (32 slots: grown to 5000);
    // the rerun sorts them in place, more loop iterations per invocation
    // than llvmpipe runs (4999 candidates + a heapsort of 4999 entries).
    let n = 5000;
    let scene = heap_of_overlapping_balls(n);
    let plan = Plan::compile(&scene).expect("valid");
    let mut state = State::from_scene(&scene);
    // f32-representable, so the read-back of an untouched state is exact.
    for v in state.positions.iter_mut() {
        *v = f64::from(*v as f32);
    }
    let mut gpu =
        GpuBackend::with_adapter(&adapter, plan.clone(), &state, Precision::F32).expect("gpu");
    let before = gpu.read_state().expect("read");
    assert!(bits(&before.positions) == bits(&state.positions));
    match gpu.step() {
        Ok(report) => {
            assert!(
                !summary.name.contains("llvmpipe"),
                "llvmpipe cannot run these loops to the end, yet the step succeeded"
            );
            let mut cpu = CpuBackend::new(plan, &state).expect("cpu");
            let rc = cpu.step().expect("cpu step");
            assert_eq!(rc.active_contacts, report.active_contacts);
        }
        Err(e) => {
            assert!(
                matches!(&e, BackendError::Gpu(hyperpbd::GpuError::Unsupported { what })
                    if what.contains("65 535")),
                "unexpected error: {e}"
            );
            let after = gpu.read_state().expect("read");
            assert!(
                bits(&after.positions) == bits(&state.positions),
                "positions changed by a refused step"
            );
            assert!(
                bits(&after.velocities) == bits(&state.velocities),
                "velocities changed by a refused step"
            );
            assert!(
                gpu.contact_list_slots() >= Some(n - 1),
                "the lists were grown before the cut was found"
            );
            print_bound(
                format_args!(
                    "step loop budget of {} ({n} mutually overlapping balls)",
                    summary.name
                ),
                format_args!("typed error, state unchanged: {e}"),
                "—",
                "never a silently short list",
            );
        }
    }
}

#[test]
fn a_contact_step_waits_for_the_device_the_same_times_whatever_its_substeps() {
    let Some((adapter, _)) = adapter_or_skip("gpu_contact_round_trips", Precision::F32) else {
        return;
    };
    let mut waits = Vec::new();
    for substeps in [1, 8] {
        let mut scene = hyperpbd::scenes::pit3d(8, 6);
        scene.substeps = substeps;
        let plan = Plan::compile(&scene).expect("valid");
        let state = State::from_scene(&scene);
        let mut gpu =
            GpuBackend::with_adapter(&adapter, plan, &state, Precision::F32).expect("gpu");
        gpu.step().expect("first step (lists may grow)");
        let before = gpu.host_waits();
        let steps = 3;
        for _ in 0..steps {
            gpu.step().expect("gpu step");
        }
        let per_step = (gpu.host_waits() - before) / steps;
        assert_eq!((gpu.host_waits() - before) % steps, 0, "uneven steps");
        waits.push(per_step);
        print_bound(
            format_args!("host waits per contact step (pit3d 8x6, {substeps} substeps)"),
            per_step,
            3,
            "one wait, the status/report read, the contact outcome read; none per substep",
        );
    }
    assert_eq!(waits[0], waits[1], "a substep added a round trip");
    assert!(waits[1] <= 3, "more than one submission's waits per step");
}
