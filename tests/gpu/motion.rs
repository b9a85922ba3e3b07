//! Prescribed motion on the GPU: gpu-f64 is the golden path and gpu-f32
//! the f32 reference, bit for bit on lavapipe (llvmpipe), every step of
//! every case in common/motion_scenes.rs — moving planes (translating,
//! turning, tilting in R^4, keyframed) and animated pins — states and
//! step reports. Other adapters are held to the golden path by a stated
//! bound instead.

use crate::common;

use common::bound::check_bound;
use common::exact::{assert_f32_reference_step, bits, f64_identical};
use common::gpu::adapter_or_skip;
use common::motion_scenes::cases;
use hyperpbd::batch::{Batch, GpuBatch};
use hyperpbd::{Backend, CpuBackend, F32Reference, Kernel, Plan, State};
use hyperpbd_gpu::{GpuBackend, Precision};

const STEPS: u64 = 40;

#[test]
fn gpu_f64_is_the_golden_path_with_motion() {
    let Some((adapter, summary)) =
        adapter_or_skip("gpu_f64_is_the_golden_path_with_motion", Precision::F64)
    else {
        return;
    };
    for (name, scene) in cases() {
        let plan = Plan::compile(&scene).expect("plan");
        let state = State::from_scene(&scene);
        let mut golden = CpuBackend::with_threads(plan.clone(), &state, 1).expect("cpu");
        let mut gpu =
            GpuBackend::with_adapter(&adapter, plan, &state, Precision::F64).expect("gpu");
        let mut worst: f64 = 0.0;
        for step in 1..=STEPS {
            let expected = golden.step().expect("cpu step");
            let got = gpu.step().expect("gpu step");
            let (a, b) = (golden.read_state().unwrap(), gpu.read_state().unwrap());
            if f64_identical(&summary) {
                assert!(
                    bits(&a) == bits(&b),
                    "{name}: step {step}: gpu-f64 ≠ golden"
                );
                let bits_of = |r: &hyperpbd::StepReport| -> Vec<u64> {
                    r.residuals
                        .iter()
                        .map(|f| f.max_violation.to_bits())
                        .collect()
                };
                assert_eq!(
                    bits_of(&expected),
                    bits_of(&got),
                    "{name}: step {step}: residuals"
                );
                assert_eq!(
                    expected.active_contacts, got.active_contacts,
                    "{name}: {step}"
                );
            }
            worst = worst.max(hyperpbd_verify::compare::max_abs_diff(
                &a.positions,
                &b.positions,
            ));
        }
        // Other adapters may contract a·b + c: a few ulps per operation on
        // O(1) coordinates, over STEPS × 20 substeps × ~10 operations.
        check_bound(
            &format!("{name}: gpu-f64 vs golden, max |dx| over {STEPS} steps"),
            worst,
            1e-9,
            "0 on llvmpipe (asserted bit for bit above); elsewhere a few ulps per \
             contracted a·b + c on O(1) coordinates, ~10 operations × 20 substeps × 40 steps",
        );
    }
}

#[test]
fn gpu_f32_is_the_f32_reference_with_motion() {
    let Some((adapter, summary)) =
        adapter_or_skip("gpu_f32_is_the_f32_reference_with_motion", Precision::F32)
    else {
        return;
    };
    if !f64_identical(&summary) {
        println!(
            "gpu_f32_is_the_f32_reference_with_motion: {} is not llvmpipe; the bit-identity rule is lavapipe's",
            summary.name
        );
        return;
    }
    for (name, scene) in cases() {
        let plan = Plan::compile(&scene).expect("plan");
        let state = State::from_scene(&scene);
        let mut gpu =
            GpuBackend::with_adapter(&adapter, plan.clone(), &state, Precision::F32).expect("gpu");
        let origin = gpu.origin().as_slice().to_vec();
        println!("{name}: f32 scene origin {origin:?}");
        let mut reference = F32Reference::new(plan, &state, &origin).expect("reference");
        for step in 1..=STEPS {
            let report = gpu.step().expect("gpu step");
            let got = gpu.read_state().unwrap();
            assert_f32_reference_step(name, step, &mut reference, &report, &got);
        }
    }
}

#[test]
fn kernels_alone_and_batches_refuse_motion_by_name() {
    let Some((adapter, _)) = adapter_or_skip(
        "kernels_alone_and_batches_refuse_motion_by_name",
        Precision::F32,
    ) else {
        return;
    };
    let (_, scene) = cases().remove(0);
    let plan = Plan::compile(&scene).expect("plan");
    let state = State::from_scene(&scene);
    let mut gpu = GpuBackend::with_adapter(&adapter, plan, &state, Precision::F32).expect("gpu");
    let refused = gpu.run_kernel(Kernel::Predict).expect_err("refused");
    assert!(
        refused.to_string().contains("prescribed motion"),
        "{refused}"
    );
    let batch = Batch::new(&[scene.clone(), scene]).expect("one topology");
    let refused = GpuBatch::on_adapter(&adapter, &batch, Precision::F32)
        .err()
        .expect("a batch refuses motion");
    assert!(
        refused.to_string().contains("prescribed \"motion\""),
        "{refused}"
    );
}
