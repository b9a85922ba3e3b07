//! `hyperpbd plan`'s dispatch count is the backend's.
//!
//! ```text
//! gpu::dispatches_per_step(plan, software) == GpuBackend::dispatches_per_step()
//! on the adapter, for a plan with particle contact (its broadphase and
//! contact dispatches included) and one without
//! ```

use crate::common;

use common::gpu::adapter_or_skip;
use hyperpbd::gpu::{GpuBackend, Precision};
use hyperpbd::{Plan, State, scenes};

#[test]
fn plan_dispatch_count_includes_the_contact_stage() {
    let Some((adapter, summary)) = adapter_or_skip("plan_dispatch_count", Precision::F32) else {
        return;
    };
    let software = summary.device_type == "Cpu";
    for (name, scene, with_contact) in [
        ("pit3d(3, 2)", scenes::pit3d(3, 2), true),
        ("cloth(8)", scenes::cloth(8), false),
    ] {
        let plan = Plan::compile(&scene).expect("scene compiles");
        let (mode, counted, exact) =
            hyperpbd::gpu::dispatches_per_step(&plan, software).expect("an XPBD plan");
        let contacts = plan.contacts.is_some();
        assert_eq!(contacts, with_contact, "{name}: particle contact");
        let gpu =
            GpuBackend::with_adapter(&adapter, plan, &State::from_scene(&scene), Precision::F32)
                .expect("backend");
        println!(
            "{name}: {} schedule, {counted} dispatches per step counted, {} recorded, \
             exact {exact}, particle contact {contacts}",
            mode.as_str(),
            gpu.dispatches_per_step()
        );
        assert_eq!(gpu.step_mode(), mode, "{name}");
        assert_eq!(counted, gpu.dispatches_per_step(), "{name}");
        assert!(exact >= counted, "{name}");
    }
}
