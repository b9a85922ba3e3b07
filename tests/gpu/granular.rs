//! Whole steps with particle–particle contact, CPU golden path vs the GPU
//! backend (broadphase per substep on the GPU sweep, the contact iteration
//! on the GPU kernels, everything else the plain step's kernels).
//!
//! f64: the pair lists are equal (same boxes, exact sweep), every kernel is
//! bit-identical to the CPU (tests/gpu/collide.rs, tests/gpu/kernels/),
//! so whole steps must be bit-identical: bound 0.
//!
//! f32: granular flows are chaotic (a grain's path branches at every
//! contact), so trajectories are compared only over one frame, against the
//! contact kernel's per-iteration bound ε·X·(8N + 40) summed over all
//! iterations and substeps of the frame (the other kernels' roundings are
//! of the same order and fewer); longer horizons are judged on the same
//! invariants as the CPU: overlap ≤ 0.15 r, energy never above its start.

use crate::common;

use common::bound::print_bound;
use common::exact::{assert_f32_reference_step, f32_identical};
use common::gpu::adapter_or_skip;
use hyperpbd::{Backend, CpuBackend, F32Reference, Plan, Scene, State};
use hyperpbd_gpu::{GpuBackend, Precision};

fn scenes() -> Vec<(&'static str, Scene, usize)> {
    vec![
        ("sandpile2d", hyperpbd::scenes::sandpile2d(), 8),
        ("ballpit4d", hyperpbd::scenes::ballpit4d(), 8),
        ("column3d 6x10x6", hyperpbd::scenes::column3d(6, 10), 8),
    ]
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn gpu_f64_contact_steps_are_bit_identical_to_the_cpu() {
    let Some((adapter, _)) = adapter_or_skip("gpu_granular_f64", Precision::F64) else {
        return;
    };
    for (name, scene, frames) in scenes() {
        let plan = Plan::compile(&scene).expect("valid");
        let state = State::from_scene(&scene);
        let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
        let mut gpu =
            GpuBackend::with_adapter(&adapter, plan, &state, Precision::F64).expect("gpu");
        let (mut worst_x, mut worst_v) = (0.0f64, 0.0f64);
        for frame in 0..frames {
            let rc = cpu.step().expect("cpu step");
            let rg = gpu.step().expect("gpu step");
            let (sc, sg) = (
                cpu.read_state().expect("read"),
                gpu.read_state().expect("read"),
            );
            worst_x = worst_x.max(max_diff(&sc.positions, &sg.positions));
            worst_v = worst_v.max(max_diff(&sc.velocities, &sg.velocities));
            assert_eq!(
                rc.kernel_calls, rg.kernel_calls,
                "{name} frame {frame}: kernel calls"
            );
            assert_eq!(
                rc.active_contacts, rg.active_contacts,
                "{name} frame {frame}: active contacts"
            );
        }
        print_bound(
            format_args!("whole step f64 {name} ({frames} frames) position / velocity"),
            format_args!("{worst_x:e} / {worst_v:e}"),
            "0 / 0",
            "same pairs, bit-identical kernels",
        );
        assert_eq!(worst_x, 0.0, "{name}: positions differ");
        assert_eq!(worst_v, 0.0, "{name}: velocities differ");
    }
}

#[test]
fn gpu_f32_contact_steps_stay_within_bounds() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_granular_f32", Precision::F32) else {
        return;
    };
    for (name, scene, frames) in scenes() {
        let plan = Plan::compile(&scene).expect("valid");
        let mut state = State::from_scene(&scene);
        for v in state
            .positions
            .iter_mut()
            .chain(state.velocities.iter_mut())
        {
            *v = f64::from(*v as f32);
        }
        let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
        let mut gpu =
            GpuBackend::with_adapter(&adapter, plan.clone(), &state, Precision::F32).expect("gpu");
        let mut reference = f32_identical(&summary).then(|| {
            F32Reference::new(plan.clone(), &state, gpu.origin().as_slice())
                .expect("the f32 reference runs particle contact")
        });
        cpu.step().expect("cpu step");
        let rg = gpu.step().expect("gpu step");
        let (sc, sg) = (
            cpu.read_state().expect("read"),
            gpu.read_state().expect("read"),
        );
        if let Some(r) = reference.as_mut() {
            assert_f32_reference_step(name, 1, r, &rg, &sg);
        }
        let err = max_diff(&sc.positions, &sg.positions);
        let scale = state.positions.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        let n = plan.dim as f64;
        let bound = f64::from(f32::EPSILON)
            * scale
            * (8.0 * n + 40.0)
            * f64::from(plan.iterations)
            * f64::from(plan.substeps);
        print_bound(
            format_args!("whole step f32 {name} (1 frame) position"),
            format_args!("{err:e}"),
            format_args!("{bound:e}"),
            "ε·X·(8N+40)·iterations·substeps",
        );
        assert!(err <= bound, "{name}: {err:e} > {bound:e}");
        // Longer horizon: invariants only.
        let radius: Vec<f64> = scene.particles.iter().map(|p| p.radius).collect();
        let r_min = radius.iter().fold(f64::INFINITY, |m, &r| m.min(r));
        let energy = |s: &State| {
            let g = scene.gravity.clone().unwrap_or_default();
            scene
                .particles
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    let m = p.mass.unwrap_or(0.0);
                    let v2: f64 = s.velocity(i).iter().map(|v| v * v).sum();
                    let gx: f64 = s.position(i).iter().zip(&g).map(|(x, g)| x * g).sum();
                    0.5 * m * v2 - m * gx
                })
                .sum::<f64>()
        };
        let e0 = energy(&state);
        let mut worst: f64 = 0.0;
        for frame in 2..=frames as u64 * 4 {
            let rg = gpu.step().expect("gpu step");
            let s = gpu.read_state().expect("read");
            if let Some(r) = reference.as_mut() {
                assert_f32_reference_step(name, frame, r, &rg, &s);
            }
            // Energy rounding allowance: f32 positions of ~1 m and masses
            // summing to M give |ΔE| ~ ε·M·g·X per particle sum; 1e-4 J.
            assert!(
                energy(&s) <= e0 + 1e-4,
                "{name}: energy rose by {:e}",
                energy(&s) - e0
            );
            let boxes =
                hyperpbd_core::broadphase::Aabbs::particles(plan.dim, &s.positions, &radius, 0.0);
            for [i, j] in hyperpbd_core::broadphase::sweep_pairs(&boxes, 0) {
                let (i, j) = (i as usize, j as usize);
                let d = s
                    .position(i)
                    .iter()
                    .zip(s.position(j))
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum::<f64>()
                    .sqrt();
                worst = worst.max((radius[i] + radius[j] - d) / r_min);
            }
        }
        print_bound(
            format_args!("gpu f32 {name} ({} frames) deepest overlap / r", frames * 4),
            format_args!("{worst:.4}"),
            "0.15",
            "invariant",
        );
        assert!(worst <= 0.15, "{name}: overlap {worst}");
        if reference.is_some() {
            print_bound(
                format_args!("gpu f32 {name} ({} frames) vs f32 reference", frames * 4),
                "0 (bit-identical: states, residuals, active contacts)",
                "0",
                "llvmpipe: exact",
            );
        }
    }
}
