//! The built-in scenes of moving walls and hands on the GPU — `drum3d`,
//! `drum4d` (a ring of hyperplanes rotating together, granular balls with
//! friction) and `twirl` (a cloth held by two spinning corners): on
//! lavapipe gpu-f64 is the golden path and gpu-f32 the f32 reference, bit
//! for bit, every frame of a short run (states and step reports).

use crate::common;

use common::exact::{assert_f32_reference_step, bits, f64_identical};
use common::gpu::adapter_or_skip;
use hyperpbd::{Backend, CpuBackend, F32Reference, Plan, Scene, State};
use hyperpbd_gpu::{GpuBackend, Precision};

/// Frames per scene: long enough for the walls to carry the pile and for
/// ball contacts, wall friction and the hands' motion to act every substep.
const FRAMES: u64 = 12;

fn scenes() -> Vec<(&'static str, Scene)> {
    ["drum3d", "drum4d", "twirl"]
        .into_iter()
        .map(|name| (name, hyperpbd::scenes::by_name(name).expect("built-in")))
        .collect()
}

/// The largest distance a fixed particle is from where it was authored.
fn hands_moved(scene: &Scene, state: &State) -> f64 {
    let mut worst: f64 = 0.0;
    for (i, p) in scene.particles.iter().enumerate().filter(|(_, p)| p.fixed) {
        let d: f64 = (state.position(i).iter())
            .zip(&p.position)
            .map(|(a, b)| (a - b) * (a - b))
            .sum();
        worst = worst.max(d.sqrt());
    }
    worst
}

#[test]
fn gpu_f64_is_the_golden_path_on_the_moving_scenes() {
    let Some((adapter, summary)) = adapter_or_skip(
        "gpu_f64_is_the_golden_path_on_the_moving_scenes",
        Precision::F64,
    ) else {
        return;
    };
    if !f64_identical(&summary) {
        println!(
            "{} is not llvmpipe: the bit-identity rule is lavapipe's (tests/gpu_motion.rs holds other adapters to a bound)",
            summary.name
        );
        return;
    }
    for (name, scene) in scenes() {
        let plan = Plan::compile(&scene).expect("plan");
        let state = State::from_scene(&scene);
        let mut golden = CpuBackend::with_threads(plan.clone(), &state, 1).expect("cpu");
        let mut gpu =
            GpuBackend::with_adapter(&adapter, plan, &state, Precision::F64).expect("gpu");
        let mut contacts = 0;
        for frame in 1..=FRAMES {
            let expected = golden.step().expect("cpu step");
            let got = gpu.step().expect("gpu step");
            let (a, b) = (golden.read_state().unwrap(), gpu.read_state().unwrap());
            assert!(
                bits(&a) == bits(&b),
                "{name}: frame {frame}: gpu-f64 ≠ golden"
            );
            let residual_bits = |r: &hyperpbd::StepReport| -> Vec<u64> {
                r.residuals
                    .iter()
                    .map(|f| f.max_violation.to_bits())
                    .collect()
            };
            assert_eq!(
                residual_bits(&expected),
                residual_bits(&got),
                "{name}: frame {frame}: residuals"
            );
            assert_eq!(expected.active_contacts, got.active_contacts, "{name}");
            contacts = got.active_contacts;
        }
        // The comparison means something only if what moves acts: the
        // drums' balls touch the walls, the cloth's hands have moved.
        let hands = hands_moved(&scene, &gpu.read_state().unwrap());
        if name == "twirl" {
            assert!(hands > 0.01, "{name}: the hands moved {hands} m");
        } else {
            assert!(contacts > 0, "{name}: no active contact by frame {FRAMES}");
        }
        println!(
            "{name}: {FRAMES} frames bit for bit, {contacts} active contacts at the end, hands moved {hands:.4} m"
        );
    }
}

#[test]
fn gpu_f32_is_the_f32_reference_on_the_moving_scenes() {
    let Some((adapter, summary)) = adapter_or_skip(
        "gpu_f32_is_the_f32_reference_on_the_moving_scenes",
        Precision::F32,
    ) else {
        return;
    };
    if !f64_identical(&summary) {
        println!(
            "{} is not llvmpipe; the bit-identity rule is lavapipe's",
            summary.name
        );
        return;
    }
    for (name, scene) in scenes() {
        let plan = Plan::compile(&scene).expect("plan");
        let state = State::from_scene(&scene);
        let mut gpu =
            GpuBackend::with_adapter(&adapter, plan.clone(), &state, Precision::F32).expect("gpu");
        let origin = gpu.origin().as_slice().to_vec();
        let mut reference = F32Reference::new(plan, &state, &origin).expect("reference");
        for frame in 1..=FRAMES {
            let report = gpu.step().expect("gpu step");
            let got = gpu.read_state().unwrap();
            assert_f32_reference_step(name, frame, &mut reference, &report, &got);
        }
        println!("{name}: {FRAMES} frames of gpu-f32 bit for bit the f32 reference");
    }
}
