//! The shape of llvmpipe's loop budget, measured (the finding that
//! gpu/src/barrier.rs and the kernels' `check_loops` probes rely on). A
//! tiny kernel runs data-dependent loops with trip counts read from a
//! buffer and reports how many bodies ran, then a two-trip probe:
//!
//! ```text
//! one loop of 70 000 trips            65 535 bodies, probe 1   (cut, silently)
//! two loops of 40 000 trips each      40 000 + 25 534 bodies   (one budget for
//!                                     both: a loop of n trips costs n + 1)
//! 65 000 trips around a constant      not cut                  (constant trip
//! 4-trip f64 loop                                              counts unroll: free)
//! invocation 0: 70 000 trips,         invocations 0..8 cut,    (one budget per
//! the others 1 000                    8.. not                  SIMD group: 8 lanes
//!                                                              at "256 bits")
//! ```
//! On llvmpipe these are asserted; elsewhere only printed.

use crate::common;

use common::gpu::adapter_or_skip;
use hyperpbd::gpu::{Precision, request_device};
use wgpu::util::DeviceExt;

const KERNEL: &str = r#"
@group(0) @binding(0) var<storage, read> trips: array<vec4<u32>>;
@group(0) @binding(1) var<storage, read_write> counted: array<vec4<u32>>;

@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    let t = trips[i];
    var first = 0u;
    for (var k = 0u; k < t.x; k++) { first++; }
    var second = 0u;
    for (var k = 0u; k < t.y; k++) { second++; }
    var nested = 0u;
    var acc: f64 = 0.0lf;
    for (var k = 0u; k < t.z; k++) {
        for (var q = 0u; q < 4u; q++) { acc += f64(q) * 0.5lf; nested++; }
    }
    if (acc < 0.0lf) { nested = 0u; }
    var probe = 0u;
    for (var k = 0u; k < 2u + (t.w >> 31u); k++) { probe++; }
    counted[i] = vec4<u32>(first, second, nested, probe);
}
"#;

/// Runs the kernel over one invocation per entry of `trips`: (bodies of
/// the first, second and nested loops, probe count) per invocation.
fn run(device: &wgpu::Device, queue: &wgpu::Queue, trips: &[[u32; 4]]) -> Vec<[u32; 4]> {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: None,
        source: wgpu::ShaderSource::Wgsl(KERNEL.into()),
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: None,
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let words: Vec<u8> = trips
        .iter()
        .flatten()
        .flat_map(|w| w.to_le_bytes())
        .collect();
    let input = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: &words,
        usage: wgpu::BufferUsages::STORAGE,
    });
    let size = words.len() as u64;
    let output = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let staging = device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: input.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: output.as_entire_binding(),
            },
        ],
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups((trips.len() as u32).div_ceil(64), 1, 1);
    }
    encoder.copy_buffer_to_buffer(&output, 0, &staging, 0, size);
    queue.submit([encoder.finish()]);
    let slice = staging.slice(..);
    slice.map_async(wgpu::MapMode::Read, |_| {});
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .expect("poll");
    let bytes = slice.get_mapped_range().expect("mapped").to_vec();
    let words: Vec<u32> = bytes
        .chunks_exact(4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    words
        .chunks_exact(4)
        .map(|w| [w[0], w[1], w[2], w[3]])
        .collect()
}

#[test]
fn llvmpipe_budget_is_65535_loop_iterations_per_simd_group() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_llvmpipe_loop_budget", Precision::F64)
    else {
        return;
    };
    let (device, queue) = request_device(&adapter, Precision::F64).expect("device");
    let one = |t: [u32; 4]| run(&device, &queue, &[t])[0];
    let single = one([70_000, 0, 0, 0]);
    let two = one([40_000, 40_000, 0, 0]);
    let unrolled = one([0, 0, 65_000, 0]);
    let mut trips = vec![[0, 1000, 0, 0]; 256];
    trips[0][0] = 70_000;
    let cut: Vec<usize> = run(&device, &queue, &trips)
        .iter()
        .enumerate()
        .filter(|(_, c)| c[1] != 1000 || c[3] != 2)
        .map(|(i, _)| i)
        .collect();
    println!(
        "{}: 70 000 trips {single:?}; 40 000 + 40 000 {two:?}; 65 000 × const 4 {unrolled:?}; \
         cut with invocation 0 at 70 000: {cut:?}",
        summary.name
    );
    if !summary.name.contains("llvmpipe") {
        return;
    }
    assert_eq!(
        single,
        [65_535, 0, 0, 1],
        "one loop: the budget, then the probe sees it"
    );
    assert_eq!(
        two,
        [40_000, 25_534, 0, 1],
        "two loops share one budget (n + 1 each)"
    );
    assert_eq!(
        unrolled,
        [0, 0, 260_000, 2],
        "constant inner loops cost nothing"
    );
    // "llvmpipe (LLVM 15.0.6, 256 bits)": lanes of 32 bits per SIMD group.
    let bits: usize = summary
        .name
        .split([',', '('])
        .find_map(|part| part.trim().strip_suffix(" bits)")?.parse().ok())
        .expect("llvmpipe names its vector width");
    assert_eq!(
        cut,
        (0..bits / 32).collect::<Vec<_>>(),
        "one budget per SIMD group"
    );
}
