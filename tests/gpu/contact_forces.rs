//! Contact forces on the GPU (gpu/src/backend/forces.rs: the golden path's
//! recorder replayed over the device's states, copied out around the
//! kernels it measures):
//!
//! ```text
//! gpu-f64 on lavapipe   every frame's forces the golden path's bit for bit (and
//!                       the states too: asking runs the exact schedule), for
//!                       every contact the recorder measures — plane contact with
//!                       static and dynamic friction, particle contact, the
//!                       primal residual, moving planes (a belt, the drum), a
//!                       static and a moving triangulated floor with friction,
//!                       and a step the adaptive guard retried
//! gpu-f32               the closed forms at rest: m g on the floor under a box,
//!                       the stack's floor, to a derived f32 bound; asking (the
//!                       exact schedule) leaves the state the fused one's, bit for bit
//! barrier backend       a particle at rest reports m g, to the minimiser's stop
//!                       (both precisions)
//! coupled backend       refused with a typed reason, nothing changed
//! ```

use crate::common;

use common::exact::{bits as state_bits, f64_identical};
use common::force_scenes::{assert_close, bits, incline, on_floor, square_box, stack, support};
use common::gpu::adapter_or_skip;
use common::implicit_scenes::{particle, settings};
use common::meshes::moving_floor;
use common::motion_scenes::{belt, resting};
use hyperpbd::{
    Backend, BackendError, ContactForces, CpuBackend, GpuError, Plan, Scene, Solver, State,
    XpbdSettings,
};
use hyperpbd_gpu::{GpuBackend, GpuBarrierBackend, GpuCoupledBackend, Precision};

/// A ball sliding over a triangulated floor (3D, μ 0.5), the floor moving
/// by `motion`, and a second ball resting on it.
fn on_a_mesh(motion: Vec<hyperpbd::motion::Motion>) -> Scene {
    let mut s = on_floor(3, 10, 2, 0.0);
    s.obstacles = vec![moving_floor(3, (0.0, 0.6, 4), 0.5, motion)];
    let mut sliding = particle(vec![0.03, 0.1, -0.11], Some(1.0), 0.1);
    sliding.velocity = Some(vec![1.0, 0.0, 0.4]);
    s.particles = vec![sliding, particle(vec![-0.2, 0.1, 0.17], Some(2.0), 0.1)];
    s
}

/// The scenes whose forces gpu-f64 reports bit for bit, with frames.
fn cases() -> Vec<(&'static str, Scene, u64)> {
    let mut primal = incline(on_floor(2, 10, 2, 0.0), 0.3, 0.8).0;
    primal.solver = Solver::Xpbd(XpbdSettings {
        primal_residual: true,
    });
    let drum = hyperpbd::scenes::by_name("drum3d").expect("built-in");
    vec![
        ("stack with friction 2D", stack(on_floor(2, 10, 4, 0.3)), 40),
        (
            "incline 2D",
            incline(on_floor(2, 10, 2, 0.0), 0.3, 0.8).0,
            40,
        ),
        ("incline, primal residual 2D", primal, 40),
        ("belt 3D", resting(3, 0.5, belt(2.0, 3), 20), 20),
        ("mesh floor 3D", on_a_mesh(Vec::new()), 30),
        ("moving mesh floor 3D", on_a_mesh(belt(0.7, 3)), 30),
        ("drum3d", drum, 6),
    ]
}

/// `scene` on `backend` with forces asked.
fn asking<B: Backend>(mut backend: B) -> B {
    backend
        .request_contact_forces(true)
        .expect("the backend reports forces");
    backend
}

fn forces_of(name: &str, frame: u64, report: hyperpbd::StepReport) -> ContactForces {
    report
        .contact_forces
        .unwrap_or_else(|| panic!("{name} frame {frame}: asked, not reported"))
}

#[test]
fn gpu_f64_reports_the_golden_paths_forces_bit_for_bit() {
    let test = "gpu_f64_reports_the_golden_paths_forces_bit_for_bit";
    let Some((adapter, summary)) = adapter_or_skip(test, Precision::F64) else {
        return;
    };
    if !f64_identical(&summary) {
        println!(
            "{}: not llvmpipe, the bit-identity rule is lavapipe's; the closed forms hold f32 and f64 elsewhere",
            summary.name
        );
        return;
    }
    for (name, scene, frames) in cases() {
        let plan = Plan::compile(&scene).expect("valid scene");
        let state = State::from_scene(&scene);
        let mut golden = asking(CpuBackend::with_threads(plan.clone(), &state, 1).expect("cpu"));
        let gpu = GpuBackend::with_adapter(&adapter, plan, &state, Precision::F64).expect("gpu");
        let mut gpu = asking(gpu);
        let (mut touching, mut bytes) = (0usize, 0u64);
        for frame in 1..=frames {
            let want = forces_of(name, frame, golden.step().expect("cpu step"));
            let got = forces_of(name, frame, gpu.step().expect("gpu step"));
            assert_eq!(
                bits(&got),
                bits(&want),
                "{name} frame {frame}: gpu-f64 forces {got:?} vs golden {want:?}"
            );
            let power = |f: &ContactForces| {
                f.obstacle_power
                    .iter()
                    .map(|p| p.to_bits())
                    .collect::<Vec<_>>()
            };
            assert_eq!(power(&got), power(&want), "{name} frame {frame}: power");
            touching += got.particles.iter().filter(|&&c| c != 0.0).count();
            bytes = gpu.contact_force_tape_bytes().expect("asked");
        }
        let (g, c) = (
            gpu.read_state().expect("gpu"),
            golden.read_state().expect("cpu"),
        );
        assert_eq!(
            state_bits(&g),
            state_bits(&c),
            "{name}: asking changed the state"
        );
        assert!(touching > 0, "{name}: no contact force in {frames} frames");
        println!(
            "{name}: {frames} frames bit for bit, {touching} nonzero particle force components, tape {bytes} B per step"
        );
    }
}

#[test]
fn a_retried_step_reports_the_forces_of_its_accepted_attempt_on_the_gpu() {
    let test = "a_retried_step_reports_the_forces_of_its_accepted_attempt_on_the_gpu";
    let Some((adapter, summary)) = adapter_or_skip(test, Precision::F64) else {
        return;
    };
    if !f64_identical(&summary) {
        return;
    }
    let guards = common::guarded::orientation();
    let retried = common::guarded::dropped_block(2, 40.0, Some(guards), Some(4));
    let plan = Plan::compile(&retried).expect("valid");
    let state = State::from_scene(&retried);
    let mut golden = asking(CpuBackend::with_threads(plan.clone(), &state, 1).expect("cpu"));
    let want = golden.step().expect("cpu");
    let want_forces = forces_of("retried", 1, want.clone());
    // Asked before the retries build the subdivided steps, and after
    // (the same step again from the same state).
    let load = || GpuBackend::with_adapter(&adapter, plan.clone(), &state, Precision::F64);
    let mut late = load().expect("gpu");
    assert!(late.step().expect("unasked").contact_forces.is_none());
    late.write_state(&state).expect("back to the start");
    for (when, mut gpu) in [
        ("before", asking(load().expect("gpu"))),
        ("after", asking(late)),
    ] {
        let got = gpu.step().expect("gpu");
        assert!(got.retries() > 0, "{when}: {got:?}");
        assert_eq!(got.attempts, want.attempts, "{when}");
        let got = forces_of("retried", 1, got);
        assert!(got.obstacle(0)[1] > 0.0, "the block lands: {got:?}");
        assert_eq!(bits(&got), bits(&want_forces), "asked {when} the retries");
    }
}

/// The forces of the last of `frames` steps of `scene` on the GPU.
fn last_forces(
    adapter: &wgpu::Adapter,
    scene: &Scene,
    precision: Precision,
    frames: u64,
) -> ContactForces {
    let plan = Plan::compile(scene).expect("valid");
    let gpu = GpuBackend::with_adapter(adapter, plan, &State::from_scene(scene), precision);
    let mut gpu = asking(gpu.expect("gpu"));
    let mut last = None;
    for frame in 1..=frames {
        last = Some(forces_of("closed form", frame, gpu.step().expect("step")));
    }
    last.expect("frames > 0")
}

/// The f32 bound of a resting force (relative): each substep's multiplier
/// resolves the gravity sag g h² of a contact measured from f32 positions,
/// each coordinate rounded to half an ulp (≤ ε32 |x| / 2), so C = n·x − rest
/// carries at most ε32 X of error (X: the largest coordinate), ε32 X / (g h²)
/// of the sag; a frame's force is the mean of its substeps'. (The origin
/// of these scenes is 0: every box centre coordinate is under 4 q.)
fn f32_resting_bound(scene: &Scene) -> f64 {
    let h = scene.dt / f64::from(scene.substeps);
    let x = (scene.particles.iter())
        .flat_map(|p| p.position.iter().map(|c| c.abs()))
        .fold(0.0, f64::max);
    f64::from(f32::EPSILON) * x / (common::motion_scenes::G * h * h)
}

#[test]
fn resting_forces_meet_their_closed_forms_on_the_gpu() {
    let test = "resting_forces_meet_their_closed_forms_on_the_gpu";
    for precision in [Precision::F32, Precision::F64] {
        let Some((adapter, _)) = adapter_or_skip(test, precision) else {
            return;
        };
        let cases = [
            ("box: m g", square_box(on_floor(2, 10, 4, 0.0)), 2.0, 240),
            (
                "stack: the floor carries both",
                stack(on_floor(2, 10, 4, 0.0)),
                3.0,
                300,
            ),
        ];
        for (what, scene, mass, frames) in cases {
            // f64: the golden path's own 1e-9 (tests/cpu/contact_forces.rs).
            let bound = match precision {
                Precision::F32 => f32_resting_bound(&scene),
                Precision::F64 => 1e-9,
            };
            let forces = last_forces(&adapter, &scene, precision, frames);
            let what = format!("gpu-{precision} {what}");
            assert_close(&what, forces.obstacle(0), &support(2, mass), bound);
        }
    }
}

#[test]
fn a_particle_at_rest_on_a_gpu_barrier_reports_m_g() {
    // As on the CPU (tests/cpu/contact_forces.rs): the force is −∇B at the
    // accepted iterate, as exact as the minimiser's stop, |F − m g| ≤
    // m r_final, here with the GPU minimiser's own r_final; the host
    // evaluates b'(d) in f64 where the device formed d in its precision
    // (d = y − r, rounded to ε X, X = 0.1 m the largest coordinate), which
    // adds at most |b''(d)| ε X.
    let m = 2.0;
    let mut scene = on_floor(3, 1, 1, 0.0);
    scene.solver = Solver::IncrementalPotential(settings(1e8, 1e-4, 1e-10, 100));
    scene
        .particles
        .push(particle(vec![0.0, 0.10005, 0.0], Some(m), 0.1));
    let g = common::motion_scenes::G;
    for (precision, epsilon) in [
        (Precision::F64, f64::EPSILON),
        (Precision::F32, f64::from(f32::EPSILON)),
    ] {
        let test = "a_particle_at_rest_on_a_gpu_barrier_reports_m_g";
        let Some((adapter, _)) = adapter_or_skip(test, precision) else {
            return;
        };
        let plan = Plan::compile(&scene).expect("valid");
        let law = plan.incremental_potential().expect("barrier path").law;
        let state = State::from_scene(&scene);
        let b = GpuBarrierBackend::with_adapter(&adapter, plan, &state, precision);
        let mut b = asking(b.expect("barrier"));
        let mut last = None;
        for _ in 0..120 {
            last = Some(b.step().expect("step"));
        }
        let report = last.expect("steps");
        let stop = report.minimisation[0].final_residual.expect("a residual");
        let f = forces_of("barrier", 120, report);
        let d = b.read_state().expect("state").positions[1] - 0.1;
        let rounding = law.evaluate(d).2.abs() * epsilon * 0.1;
        let bound = m * stop * (1.0 + 1e-6) + rounding + 1e-13 * m * g;
        let error = (f.obstacle(0)[1] - m * g).abs();
        println!(
            "BOUND gpu-{precision} barrier at rest: |F − m g| {error:.3e} N / {bound:.3e} N \
             (m r_final {:.3e} + |b''| ε X {rounding:.3e})",
            m * stop
        );
        assert!(error <= bound, "gpu-{precision}: {f:?}");
    }
}

#[test]
fn the_coupled_backend_refuses_forces_with_a_typed_reason() {
    let mut scene = stack(on_floor(2, 4, 1, 0.0));
    scene.solver = Solver::IncrementalPotential(settings(1e4, 0.01, 1e-10, 100));
    scene.particles[0].position[1] += 0.005;
    scene.particles[1].position[1] += 0.015;
    for precision in [Precision::F32, Precision::F64] {
        let test = "the_coupled_backend_refuses_forces_with_a_typed_reason";
        let Some((adapter, _)) = adapter_or_skip(test, precision) else {
            return;
        };
        let plan = Plan::compile(&scene).expect("valid");
        let state = State::from_scene(&scene);
        let b = GpuCoupledBackend::with_adapter(&adapter, plan, &state, precision);
        let mut b = b.expect("coupled");
        match b.request_contact_forces(true) {
            Err(BackendError::Gpu(GpuError::Unsupported { what })) => {
                assert!(what.contains("coupled implicit step"), "{what}");
            }
            other => panic!("gpu-{precision} coupled: {other:?}"),
        }
        b.request_contact_forces(false).expect("nothing to stop");
        let report = b.step().expect("steps as before");
        assert!(report.contact_forces.is_none());
    }
}

#[test]
fn asking_changes_no_gpu_f32_state_and_can_be_withdrawn() {
    // The recorded step runs the exact schedule, the plain one the fused
    // schedule: the same bits (every mode gives the same results), here on
    // gpu-f32 with particle contact and plane friction.
    let test = "asking_changes_no_gpu_f32_state_and_can_be_withdrawn";
    let Some((adapter, _)) = adapter_or_skip(test, Precision::F32) else {
        return;
    };
    let scene = stack(on_floor(2, 10, 4, 0.3));
    let plan = Plan::compile(&scene).expect("valid");
    let state = State::from_scene(&scene);
    let load = || GpuBackend::with_adapter(&adapter, plan.clone(), &state, Precision::F32);
    let (mut asked, mut plain) = (asking(load().expect("gpu")), load().expect("gpu"));
    for frame in 1..=20 {
        assert!(
            asked.step().expect("step").contact_forces.is_some(),
            "frame {frame}"
        );
        assert!(
            plain.step().expect("step").contact_forces.is_none(),
            "frame {frame}"
        );
    }
    let (a, p) = (
        asked.read_state().expect("a"),
        plain.read_state().expect("p"),
    );
    assert_eq!(
        state_bits(&a),
        state_bits(&p),
        "asking changed the gpu-f32 state"
    );
    asked.request_contact_forces(false).expect("withdrawn");
    assert!(asked.contact_force_tape_bytes().is_none());
    assert!(asked.step().expect("step").contact_forces.is_none());
}
