//! The GPU backend inside the caller's wgpu application (issue 14 item 3):
//! built on the caller's device and queue, its positions exported into a
//! buffer of the caller's by one dispatch recorded into the caller's
//! encoder — checked against `read_state` (the host's world coordinates).
//!
//! ```text
//! first three axes   out[3i + c] = f32(x_i[c] + o_c), 0 past N
//!   f64 device       the sum in f64 then one rounding: equal to f32 of the
//!                    host's world coordinate, bit for bit
//!   f32 device       x + o summed in f32 (o f32-representable): within one
//!                    f32 rounding of the host's value, u (|x + o| + |o|)·2
//! projection P       out = f32(P·o + Σ_a P[c][a] x[a]); vs P·x_world in
//!                    f64: (N + 2) roundings of Σ|P||x| in the device
//!                    precision + one f32 rounding
//! ```

use crate::common;

use common::gpu::adapter_or_skip;
use hyperpbd::gpu::{
    EXPORT_BYTES_PER_PARTICLE, GpuBackend, GpuBarrierBackend, PositionExport, request_device,
};
use hyperpbd::{Backend, BackendError, Particle, Plan, Precision, Scene, State};

/// A few free particles in R^dim, 100 m from the origin (so the f32 scene
/// origin is not zero), falling under gravity.
fn particles(dim: usize) -> Scene {
    let mut scene = Scene::new(dim, 1.0 / 60.0, 2, 1);
    let mut g = vec![0.0; dim];
    g[dim.min(2) - 1] = -9.81;
    scene.gravity = Some(g);
    for i in 0..7 {
        let position: Vec<f64> = (0..dim)
            .map(|a| 100.0 + 0.37 * i as f64 - 0.21 * a as f64)
            .collect();
        let velocity: Vec<f64> = (0..dim).map(|a| 0.5 * a as f64 - 0.1 * i as f64).collect();
        scene
            .particles
            .push(Particle::new(position, 1.0).with_velocity(velocity));
    }
    scene.validate().expect("valid particles");
    scene
}

/// Exports the backend's positions into a new STORAGE | VERTEX buffer of
/// the device and reads it back.
fn export(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    backend: &dyn PositionExport,
    count: usize,
    projection: Option<&[f64]>,
) -> Vec<f32> {
    let size = EXPORT_BYTES_PER_PARTICLE * count as u64;
    let target = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("vertices"),
        size,
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::VERTEX
            | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("staging"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    backend
        .encode_positions(&mut encoder, &target, projection)
        .expect("export");
    encoder.copy_buffer_to_buffer(&target, 0, &staging, 0, size);
    queue.submit(Some(encoder.finish()));
    let slice = staging.slice(..);
    slice.map_async(wgpu::MapMode::Read, |r| r.expect("map"));
    device
        .poll(wgpu::PollType::Wait {
            submission_index: None,
            timeout: None,
        })
        .expect("poll");
    let out: Vec<f32> = slice
        .get_mapped_range()
        .expect("mapped range")
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    staging.unmap();
    out
}

#[test]
fn exported_positions_are_the_world_positions_on_the_callers_device() {
    let test = "exported_positions_are_the_world_positions_on_the_callers_device";
    for precision in [Precision::F64, Precision::F32] {
        let Some((adapter, _)) = adapter_or_skip(test, precision) else {
            return;
        };
        for dim in [2, 3, 5] {
            let scene = particles(dim);
            let plan = Plan::compile(&scene).expect("plan");
            let count = plan.particle_count();
            let (device, queue) = request_device(&adapter, precision).expect("the caller's device");
            let mut backend = GpuBackend::with_device(
                &adapter,
                device.clone(),
                queue.clone(),
                plan,
                &State::from_scene(&scene),
                precision,
            )
            .expect("backend on the caller's device");
            for _ in 0..3 {
                backend.step().expect("step");
            }
            let layout = backend.position_layout();
            assert_eq!((layout.dim, layout.count), (dim, count));
            assert_eq!(
                layout.origin.iter().all(|&o| o == 0.0),
                precision == Precision::F64
            );
            let world = backend.read_state().expect("state").positions;
            let origin = layout.origin.clone();

            // The first three axes.
            let out = export(&device, &queue, &backend, count, None);
            let mut worst: f64 = 0.0;
            for i in 0..count {
                for c in 0..3 {
                    let got = out[3 * i + c];
                    if c >= dim {
                        assert_eq!(got, 0.0, "{precision} {dim}D particle {i} axis {c}");
                        continue;
                    }
                    let w = world[i * dim + c];
                    if precision == Precision::F64 {
                        assert_eq!(got, w as f32, "{precision} {dim}D particle {i} axis {c}");
                    } else {
                        let bound = 2.0 * f64::from(f32::EPSILON) * (w.abs() + origin[c].abs());
                        let measured = (f64::from(got) - w).abs();
                        assert!(
                            measured <= bound,
                            "{dim}D particle {i} axis {c}: {measured:e} > {bound:e}"
                        );
                        worst = worst.max(measured / bound);
                    }
                }
            }
            println!("{precision} {dim}D first axes: worst measured / bound {worst:.3}");

            // A projection R^dim → R^3.
            let p: Vec<f64> = (0..3 * dim)
                .map(|k| ((k * 7 + 3) % 11) as f64 / 5.0 - 1.0)
                .collect();
            let out = export(&device, &queue, &backend, count, Some(&p));
            let u = precision.epsilon() / 2.0;
            let mut worst: f64 = 0.0;
            for i in 0..count {
                for c in 0..3 {
                    let row = &p[c * dim..(c + 1) * dim];
                    let x = &world[i * dim..(i + 1) * dim];
                    let exact: f64 = row.iter().zip(x).map(|(p, x)| p * x).sum();
                    let magnitude: f64 = row
                        .iter()
                        .zip(x.iter().zip(&origin))
                        .map(|(p, (x, o))| p.abs() * (x.abs() + o.abs()))
                        .sum();
                    let bound = (dim as f64 + 2.0) * u * magnitude
                        + f64::from(f32::EPSILON) / 2.0 * exact.abs();
                    let measured = (f64::from(out[3 * i + c]) - exact).abs();
                    assert!(
                        measured <= bound,
                        "{precision} {dim}D projected particle {i} row {c}: {measured:e} > {bound:e}"
                    );
                    worst = worst.max(measured / bound);
                }
            }
            println!("{precision} {dim}D projection: worst measured / bound {worst:.3}");
        }
    }
}

#[test]
fn a_buffer_the_export_cannot_write_is_a_typed_error() {
    let test = "a_buffer_the_export_cannot_write_is_a_typed_error";
    let Some((adapter, _)) = adapter_or_skip(test, Precision::F32) else {
        return;
    };
    let scene = particles(3);
    let plan = Plan::compile(&scene).expect("plan");
    let count = plan.particle_count() as u64;
    let (device, queue) = request_device(&adapter, Precision::F32).expect("device");
    let backend = GpuBackend::with_device(
        &adapter,
        device.clone(),
        queue,
        plan,
        &State::from_scene(&scene),
        Precision::F32,
    )
    .expect("backend");
    let buffer = |size: u64, usage: wgpu::BufferUsages| {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size,
            usage,
            mapped_at_creation: false,
        })
    };
    let cases = [
        (
            buffer(12 * count, wgpu::BufferUsages::VERTEX),
            None,
            "STORAGE",
        ),
        (
            buffer(12 * count - 4, wgpu::BufferUsages::STORAGE),
            None,
            "12 per particle",
        ),
        (
            buffer(12 * count, wgpu::BufferUsages::STORAGE),
            Some(vec![1.0; 8]),
            "projection",
        ),
    ];
    for (target, projection, says) in cases {
        let mut encoder = device.create_command_encoder(&Default::default());
        match backend.encode_positions(&mut encoder, &target, projection.as_deref()) {
            Err(BackendError::Gpu(e)) => {
                let text = e.to_string();
                assert!(text.contains(says), "{text}");
            }
            other => panic!("expected a typed GPU error, got {other:?}"),
        }
    }
}

#[test]
fn the_barrier_backend_exports_its_dense_positions_too() {
    let test = "the_barrier_backend_exports_its_dense_positions_too";
    let Some((adapter, _)) = adapter_or_skip(test, Precision::F64) else {
        return;
    };
    let scene = hyperpbd::scenes::barrier4d();
    let plan = Plan::compile(&scene).expect("plan");
    let count = plan.particle_count();
    let (device, queue) = request_device(&adapter, Precision::F64).expect("device");
    let mut backend = GpuBarrierBackend::with_device(
        &adapter,
        device.clone(),
        queue.clone(),
        plan,
        &State::from_scene(&scene),
        Precision::F64,
    )
    .expect("barrier backend on the caller's device");
    for _ in 0..3 {
        backend.step().expect("step");
    }
    let layout = backend.position_layout();
    assert_eq!((layout.dim, layout.stride, layout.count), (4, 4, count));
    let world = backend.read_state().expect("state").positions;
    let out = export(&device, &queue, &backend, count, None);
    for i in 0..count {
        for c in 0..3 {
            assert_eq!(
                out[3 * i + c],
                world[4 * i + c] as f32,
                "particle {i} axis {c}"
            );
        }
    }
}
