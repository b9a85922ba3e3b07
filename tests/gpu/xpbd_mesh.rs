//! The GPU backends refuse a simplex-mesh contact on the XPBD path by
//! name (the golden path and the f32 reference run it:
//! tests/cpu/xpbd_mesh.rs); the kernels are not written yet.

use crate::common;

use common::gpu::adapter_or_skip;
use hyperpbd::{BackendError, GpuError, Obstacle, Particle, Plan, Scene, State};
use hyperpbd_gpu::{GpuBackend, Precision};

#[test]
fn gpu_refuses_a_mesh_contact_by_name() {
    let Some((adapter, _)) = adapter_or_skip("gpu_refuses_a_mesh_contact_by_name", Precision::F64)
    else {
        return;
    };
    let mut scene = Scene::new(2, 0.01, 2, 2);
    scene.gravity = Some(vec![0.0, -9.81]);
    scene.particles = vec![Particle::new(vec![0.0, 0.2], 1.0).with_radius(0.1)];
    scene.obstacles = vec![Obstacle::SimplexMesh {
        vertices: vec![vec![-1.0, 0.0], vec![1.0, 0.0]],
        simplices: vec![vec![0, 1]],
        friction: 0.0,
    }];
    let plan = Plan::compile(&scene).expect("valid");
    for precision in [Precision::F32, Precision::F64] {
        let state = State::from_scene(&scene);
        match GpuBackend::with_adapter(&adapter, plan.clone(), &state, precision) {
            Err(BackendError::Gpu(GpuError::Unsupported { what })) => {
                println!("{precision}: {what}");
                assert!(
                    what.contains("obstacles[0]") && what.contains("simplex_mesh"),
                    "{what}"
                );
            }
            Err(other) => panic!("{precision}: expected Unsupported, got {other}"),
            Ok(_) => panic!("{precision}: a mesh contact was accepted"),
        }
    }
}
