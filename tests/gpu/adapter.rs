//! Adapter discovery and a smoke compute dispatch.
//!
//! Every test that needs a device goes through `common::gpu::adapter_or_skip`:
//! without an adapter they print `SKIPPED: no adapter`, record the skip
//! (counted by `scripts/test.sh`) and pass, unless `HYPERPBD_REQUIRE_GPU=1`.

use crate::common;

use common::gpu::adapter_or_skip;
use hyperpbd_gpu::{Precision, list_adapters, request_adapter, request_device};
use wgpu::util::DeviceExt;

/// Workgroup size of the smoke kernels; the element counts below are chosen
/// not to divide it.
const WORKGROUP: u32 = 64;

/// Element counts for the smoke kernels: one element, less than one
/// workgroup, and more than two workgroups, none a multiple of 64.
const SIZES: [usize; 3] = [1, 37, 129];

#[test]
fn list_adapters_does_not_panic_and_names_every_adapter() {
    let adapters = list_adapters();
    eprintln!("{} adapter(s):", adapters.len());
    for a in &adapters {
        eprintln!("  {a}");
    }
    for a in &adapters {
        assert!(!a.name.is_empty(), "adapter with an empty name: {a:?}");
        assert!(!a.backend.is_empty(), "adapter with no backend: {a:?}");
    }
}

/// Run `wgsl` (entry point `main`, workgroup size [`WORKGROUP`], one
/// read-write storage array at group 0 binding 0) over `input`, `count`
/// elements, one invocation per element, and read the array back.
fn run_in_place(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    wgsl: &str,
    input: &[u8],
    count: usize,
) -> Vec<u8> {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("smoke"),
        source: wgpu::ShaderSource::Wgsl(wgsl.into()),
    });
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("smoke"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only: false },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }],
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("smoke"),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("smoke"),
        layout: Some(&pipeline_layout),
        module: &module,
        entry_point: Some("main"),
        compilation_options: wgpu::PipelineCompilationOptions::default(),
        cache: None,
    });
    let data = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("smoke data"),
        contents: input,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
    });
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("smoke readback"),
        size: input.len() as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("smoke"),
        layout: &layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: data.as_entire_binding(),
        }],
    });
    let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
        label: Some("smoke"),
    });
    {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("smoke"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &bind_group, &[]);
        let groups = u32::try_from(count.div_ceil(WORKGROUP as usize)).expect("small count");
        pass.dispatch_workgroups(groups, 1, 1);
    }
    encoder.copy_buffer_to_buffer(&data, 0, &readback, 0, input.len() as u64);
    // A validation error anywhere above reaches wgpu's default uncaptured-error
    // handler, which panics: the test fails with wgpu's message.
    let submission = queue.submit([encoder.finish()]);

    let (tx, rx) = std::sync::mpsc::channel();
    readback.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::Wait {
            submission_index: Some(submission),
            timeout: Some(std::time::Duration::from_secs(60)),
        })
        .expect("poll");
    rx.recv()
        .expect("map_async callback ran during poll")
        .expect("map_async succeeded");
    let view = readback.get_mapped_range(..).expect("mapped range");
    let out = view.to_vec();
    drop(view);
    readback.unmap();
    out
}

const DOUBLE_U32: &str = r#"
@group(0) @binding(0) var<storage, read_write> data: array<u32>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i < arrayLength(&data) {
        data[i] = data[i] * 2u;
    }
}
"#;

#[test]
fn f32_device_runs_a_compute_kernel() {
    let Some((adapter, summary)) =
        adapter_or_skip("f32_device_runs_a_compute_kernel", Precision::F32)
    else {
        return;
    };
    let (device, queue) = request_device(&adapter, Precision::F32)
        .unwrap_or_else(|e| panic!("f32 device on {summary}: {e}"));
    for n in SIZES {
        let input: Vec<u32> = (0..n as u32).map(|i| 3 * i + 1).collect();
        let bytes: Vec<u8> = input.iter().flat_map(|v| v.to_le_bytes()).collect();
        let out = run_in_place(&device, &queue, DOUBLE_U32, &bytes, n);
        let out: Vec<u32> = out
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let expected: Vec<u32> = input.iter().map(|v| 2 * v).collect();
        assert_eq!(out, expected, "doubling {n} u32 on {summary}");
        eprintln!("doubled {n} u32 on {}: ok", summary.name);
    }
}

const AFFINE_F64: &str = r#"
@group(0) @binding(0) var<storage, read_write> data: array<f64>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if i < arrayLength(&data) {
        data[i] = fma(data[i], 2.0lf, 0.5lf);
    }
}
"#;

/// lavapipe (Vulkan on llvmpipe) offers `SHADER_F64`; CI relies on it for
/// the f64 differential tests, so on lavapipe its absence is a failure, not
/// a skip.
#[test]
fn lavapipe_offers_f64() {
    let lavapipe: Vec<_> = list_adapters()
        .into_iter()
        .filter(|a| a.name.contains("llvmpipe") && a.backend == "vulkan")
        .collect();
    for a in &lavapipe {
        assert!(a.shader_f64, "lavapipe without SHADER_F64: {a}");
    }
    let Some((_, summary)) = adapter_or_skip("lavapipe_offers_f64", Precision::F32) else {
        return;
    };
    if !(summary.name.contains("llvmpipe") && summary.backend == "vulkan") {
        eprintln!(
            "lavapipe_offers_f64: chosen adapter is {} (not lavapipe); {} lavapipe adapter(s) listed",
            summary.name,
            lavapipe.len()
        );
        return;
    }
    assert!(
        summary.shader_f64,
        "lavapipe chosen but no SHADER_F64: {summary}"
    );
    let (adapter, summary) =
        request_adapter(Precision::F64).unwrap_or_else(|e| panic!("f64 adapter on lavapipe: {e}"));
    let (device, queue) = request_device(&adapter, Precision::F64)
        .unwrap_or_else(|e| panic!("f64 device on {summary}: {e}"));
    assert!(device.features().contains(wgpu::Features::SHADER_F64));
    for n in SIZES {
        // Values whose f64 image 2x + 0.5 is exact but not representable in f32.
        let input: Vec<f64> = (0..n).map(|i| 1.0 + i as f64 * 2f64.powi(-40)).collect();
        let bytes: Vec<u8> = input.iter().flat_map(|v| v.to_le_bytes()).collect();
        let out = run_in_place(&device, &queue, AFFINE_F64, &bytes, n);
        let out: Vec<f64> = out
            .chunks_exact(8)
            .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
            .collect();
        let expected: Vec<f64> = input.iter().map(|v| 2.0 * v + 0.5).collect();
        assert_eq!(out, expected, "2x + 0.5 over {n} f64 on {summary}");
        eprintln!("f64 2x+0.5 over {n} on {}: ok (bit-exact)", summary.name);
    }
}

/// Whatever the machine, `request_adapter(F64)` answers with an adapter that
/// has `SHADER_F64` or with a typed error, never a panic.
#[test]
fn f64_request_is_typed() {
    match request_adapter(Precision::F64) {
        Ok((_, summary)) => assert!(summary.shader_f64, "{summary}"),
        Err(e) => eprintln!("no f64 adapter: {e}"),
    }
}
