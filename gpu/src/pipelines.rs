//! Compute pipelines: one per entry point, built once per (dimension,
//! precision) at backend creation, sharing one pipeline layout.
//!
//! ```text
//! group 0: x v p inv_mass gravity_scale force elements rest lambda status resid report
//! group 1: params (read-only storage, dynamic offset: one block per call)
//! ```

use crate::Precision;
use crate::shader::{ShaderFile, compose};
use hyperpbd_core::GpuError;

/// Every kernel entry point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Entry {
    Predict,
    Velocity,
    Damping,
    ProjectDistance,
    ProjectSimplexMeasure,
    ProjectOrientedMeasure,
    ProjectContact,
    Friction,
    Residual,
    Reduce,
}

impl Entry {
    const ALL: [Entry; 10] = [
        Entry::Predict,
        Entry::Velocity,
        Entry::Damping,
        Entry::ProjectDistance,
        Entry::ProjectSimplexMeasure,
        Entry::ProjectOrientedMeasure,
        Entry::ProjectContact,
        Entry::Friction,
        Entry::Residual,
        Entry::Reduce,
    ];

    fn source(self) -> (ShaderFile, &'static str) {
        match self {
            Entry::Predict => (ShaderFile::Integrate, "predict"),
            Entry::Velocity => (ShaderFile::Integrate, "velocity"),
            Entry::Damping => (ShaderFile::Integrate, "damping"),
            Entry::ProjectDistance => (ShaderFile::Project, "project_distance"),
            Entry::ProjectSimplexMeasure => (ShaderFile::Project, "project_simplex_measure"),
            Entry::ProjectOrientedMeasure => (ShaderFile::Project, "project_oriented_measure"),
            Entry::ProjectContact => (ShaderFile::Project, "project_contact"),
            Entry::Friction => (ShaderFile::Friction, "friction"),
            Entry::Residual => (ShaderFile::Residual, "residual"),
            Entry::Reduce => (ShaderFile::Residual, "reduce"),
        }
    }
}

/// Read-only flags of the group-0 bindings, in binding order.
const STATE_READ_ONLY: [bool; 12] = [
    false, false, false, true, true, true, true, true, false, false, false, false,
];

/// The layouts and every pipeline.
pub struct Pipelines {
    pub state_layout: wgpu::BindGroupLayout,
    pub params_layout: wgpu::BindGroupLayout,
    pipelines: Vec<wgpu::ComputePipeline>,
}

/// A storage-buffer binding visible to compute shaders (every kernel set
/// of this crate lays its bindings out with it).
pub(crate) fn storage(binding: u32, read_only: bool, dynamic: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: dynamic,
            min_binding_size: None,
        },
        count: None,
    }
}

impl Pipelines {
    /// Builds every pipeline for `dim` and `precision`.
    pub fn new(
        device: &wgpu::Device,
        dim: usize,
        precision: Precision,
        limits: &wgpu::Limits,
    ) -> Result<Self, GpuError> {
        let needed = STATE_READ_ONLY.len() as u32 + 1;
        if limits.max_storage_buffers_per_shader_stage < needed {
            return Err(GpuError::Unsupported {
                what: format!(
                    "the adapter allows {} storage buffers per shader stage; the kernels need {needed}",
                    limits.max_storage_buffers_per_shader_stage
                ),
            });
        }
        let entries: Vec<_> = STATE_READ_ONLY
            .iter()
            .enumerate()
            .map(|(i, &ro)| storage(i as u32, ro, false))
            .collect();
        let state_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hyperpbd state"),
            entries: &entries,
        });
        let params_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hyperpbd params"),
            entries: &[storage(0, true, true)],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hyperpbd"),
            bind_group_layouts: &[Some(&state_layout), Some(&params_layout)],
            immediate_size: 0,
        });
        let modules: Vec<(ShaderFile, wgpu::ShaderModule)> = ShaderFile::STEP
            .iter()
            .map(|&file| {
                let source = compose(file, dim, precision);
                let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(file.file_name()),
                    source: wgpu::ShaderSource::Wgsl(source.into()),
                });
                (file, module)
            })
            .collect();
        let pipelines = Entry::ALL
            .iter()
            .map(|entry| {
                let (file, name) = entry.source();
                let module = &modules
                    .iter()
                    .find(|(f, _)| *f == file)
                    .map(|(_, m)| m)
                    .ok_or_else(|| GpuError::Other {
                        message: format!("no module for {file:?}"),
                    })?;
                Ok(
                    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                        label: Some(name),
                        layout: Some(&layout),
                        module,
                        entry_point: Some(name),
                        compilation_options: Default::default(),
                        cache: None,
                    }),
                )
            })
            .collect::<Result<Vec<_>, GpuError>>()?;
        Ok(Pipelines {
            state_layout,
            params_layout,
            pipelines,
        })
    }

    /// The pipeline of `entry`.
    pub fn get(&self, entry: Entry) -> &wgpu::ComputePipeline {
        let index = Entry::ALL.iter().position(|&e| e == entry).unwrap_or(0);
        &self.pipelines[index]
    }
}
