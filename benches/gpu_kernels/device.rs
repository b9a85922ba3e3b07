//! The device side: buffers, pipelines, dispatch and verification.

use super::*;
/// One candidate on the device: pipeline, buffers, bind group.
pub(crate) struct Case {
    pub(crate) pipeline: wgpu::ComputePipeline,
    pub(crate) group: wgpu::BindGroup,
    pub(crate) buffers: Vec<wgpu::Buffer>,
    pub(crate) groups: u32,
}

pub(crate) struct Gpu {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    pub(crate) layout: wgpu::BindGroupLayout,
    pub(crate) pipeline_layout: wgpu::PipelineLayout,
}

impl Gpu {
    pub(crate) fn buffer(&self, bytes: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
        let buffer = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: (bytes.len() as u64).max(16).next_multiple_of(16),
            usage: usage | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        self.queue.write_buffer(&buffer, 0, bytes);
        buffer
    }

    pub(crate) fn read(&self, buffer: &wgpu::Buffer) -> Vec<u8> {
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: None,
            size: buffer.size(),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(buffer, 0, &staging, 0, buffer.size());
        self.queue.submit(Some(encoder.finish()));
        staging.slice(..).map_async(wgpu::MapMode::Read, |r| {
            r.expect("map");
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("poll");
        let bytes = staging
            .slice(..)
            .get_mapped_range()
            .expect("mapped")
            .to_vec();
        staging.unmap();
        bytes
    }

    pub(crate) fn build(
        &self,
        precision: Precision,
        kernel: Kernel,
        candidate: Candidate,
        d: &Data,
    ) -> Case {
        let (layout, wg) = (candidate.layout, candidate.wg);
        let source = candidate.source(precision, kernel);
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: None,
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        let pipeline = self
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: None,
                layout: Some(&self.pipeline_layout),
                module: &module,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            });
        let x0 = round(&d.x, precision);
        let (x_in, p_in) = match kernel {
            Kernel::Velocity => {
                let mut x = x0.clone();
                for (k, c) in x.iter_mut().enumerate() {
                    *c = round(
                        &[*c + round(&[1e-3 * jitter(k + 5)], precision)[0]],
                        precision,
                    )[0];
                }
                (x, x0.clone())
            }
            _ => (x0.clone(), vec![0.0; 3 * N]),
        };
        let storage = wgpu::BufferUsages::STORAGE;
        let mut params = reals(&[G[0], G[1], G[2], 0.0, H, 1e-7 / (H * H)], precision);
        params.extend_from_slice(&(EDGES as u32).to_le_bytes());
        params.resize(params.len().next_multiple_of(32).max(64), 0);
        let buffers = vec![
            self.buffer(&params, wgpu::BufferUsages::UNIFORM),
            self.buffer(&reals(&layout.pack(&x_in, &d.w), precision), storage),
            self.buffer(&reals(&layout.pack(&d.v, &d.w), precision), storage),
            self.buffer(&reals(&layout.pack(&p_in, &d.w), precision), storage),
            self.buffer(&reals(&d.w, precision), storage),
            self.buffer(&reals(&d.s, precision), storage),
            self.buffer(&u32_bytes(&d.edges), storage),
            self.buffer(&reals(&d.rest, precision), storage),
            self.buffer(&reals(&vec![0.0; EDGES], precision), storage),
            self.buffer(&u32_bytes(&[u32::MAX; 4]), storage),
            self.buffer(&params, storage),
        ];
        let entries: Vec<_> = buffers
            .iter()
            .enumerate()
            .map(|(b, buffer)| wgpu::BindGroupEntry {
                binding: b as u32,
                resource: buffer.as_entire_binding(),
            })
            .collect();
        let group = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &self.layout,
            entries: &entries,
        });
        let invocations = kernel.elements()
            / if kernel == Kernel::Project {
                1
            } else {
                layout.per_invocation()
            };
        Case {
            pipeline,
            group,
            buffers,
            groups: (invocations as u32).div_ceil(wg),
        }
    }

    pub(crate) fn dispatch(&self, case: &Case, repeats: u32) {
        let mut encoder = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(&case.pipeline);
            pass.set_bind_group(0, &case.group, &[]);
            for _ in 0..repeats {
                pass.dispatch_workgroups(case.groups, 1, 1);
            }
        }
        let index = self.queue.submit(Some(encoder.finish()));
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(index),
                timeout: None,
            })
            .expect("poll");
    }
}

pub(crate) fn u32_bytes(words: &[u32]) -> Vec<u8> {
    words.iter().flat_map(|w| w.to_le_bytes()).collect()
}

/// Checks one call of `case` against the host reference.
pub(crate) fn verify(
    gpu: &Gpu,
    case: &Case,
    kernel: Kernel,
    layout: Layout,
    precision: Precision,
    d: &Data,
) {
    gpu.dispatch(case, 1);
    let (x, v, p) = reference(kernel, precision, d);
    let got = |b: usize| layout.unpack(&from_reals(&gpu.read(&case.buffers[b]), precision));
    let label = format!("{precision} {} {}", kernel.name(), layout.name());
    let same = |name: &str, a: &[f64], b: &[f64]| {
        let bad = a
            .iter()
            .zip(b)
            .position(|(x, y)| x.to_bits() != y.to_bits());
        assert!(
            bad.is_none(),
            "{label}: {name}[{}] = {} on the device, {} on the host",
            bad.unwrap_or(0),
            a[bad.unwrap_or(0)],
            b[bad.unwrap_or(0)]
        );
    };
    match kernel {
        Kernel::Copy => same("p", &got(3)[..3 * N], &x),
        Kernel::Predict => {
            same("x", &got(1)[..3 * N], &x);
            same("v", &got(2)[..3 * N], &v);
            same("p", &got(3)[..3 * N], &p);
        }
        Kernel::Velocity => same("v", &got(2)[..3 * N], &v),
        Kernel::Project => same("x", &got(1)[..3 * N], &x),
    }
}

/// The device, its shared layouts, and the test data of one precision.
pub(crate) fn setup(precision: Precision) -> Option<Gpu> {
    let (adapter, summary) = match request_adapter(precision) {
        Ok(found) => found,
        Err(e) => {
            eprintln!("SKIPPED {precision}: {e}");
            return None;
        }
    };
    eprintln!("gpu_kernels {precision} on {summary}");
    let (device, queue) = request_device(&adapter, precision).expect("device");
    let entry = |binding: u32, ty: wgpu::BufferBindingType| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let mut entries = vec![entry(0, wgpu::BufferBindingType::Uniform)];
    for (b, read_only) in [
        (1, false),
        (2, false),
        (3, false),
        (4, true),
        (5, true),
        (6, true),
        (7, true),
        (8, false),
        (9, false),
        (10, true),
    ] {
        entries.push(entry(b, wgpu::BufferBindingType::Storage { read_only }));
    }
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &entries,
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: None,
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    Some(Gpu {
        device,
        queue,
        layout,
        pipeline_layout,
    })
}
