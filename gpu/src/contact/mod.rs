//! The contact kernel set: broadphase on a hashed grid, per-particle
//! contact lists and the gather-Jacobi contact iteration, all on the
//! device (`shaders/{contact,scan,grid,collide}.wgsl`).
//!
//! ```text
//! broadphase   boxes_and_bounds → grid_frame → bin_count → scan (3) → bin_fill
//!              → neighbours                                     (8 dispatches)
//! collide      contact_snapshot → collide                       (2 dispatches)
//! report       contact_report → contact_report_final            (2 dispatches)
//! outcome      counters[0..4] + deepest overlap → 32-byte staging, read once
//! ```
//! Every dispatch size is the particle count, the bucket count or a
//! constant — known when the plan is loaded — so nothing waits for a count
//! from the device inside a step: the lists have a fixed number of slots
//! per particle, the longest list found is reported in the outcome, and a
//! list that did not fit (outcome: "need N slots") makes the caller grow
//! the lists and rerun from the saved state ([`ContactBuffers::grow`]).
//! Nothing is dropped silently.
//!
//! Three users share it: [`crate::GpuBackend`] (the step, bound to its
//! resident x, p and status word), [`crate::GpuSweep`] (boxes given, lists
//! read back as canonical pairs) and [`crate::GpuCollide`] (one iteration
//! on given lists).

mod buffers;

pub(crate) use buffers::{Block, Bound, ContactBuffers, Outcome, Particles};

use hyperpbd_core::GpuError;

use crate::Precision;
use crate::shader::{ShaderFile, compose};

/// Particles per workgroup of the per-particle kernels.
const WORKGROUP: u32 = 64;
const MAX_GROUPS_X: u32 = 65_535;
/// Invocations of `boxes_and_bounds` (`BOUND_THREADS` in contact.wgsl).
const BOUND_THREADS: u32 = 1024;
/// Hash-bucket counters per scan block (`SCAN_BLOCK` in scan.wgsl).
const SCAN_BLOCK: usize = 2048;
/// Flags of a parameter block (`ContactParams.flags`).
pub(crate) const SKIP_FIXED_PAIRS: u32 = 1;
pub(crate) const BOXES_FROM_STATE: u32 = 2;

/// Every entry point of the set, in dispatch order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ContactEntry {
    BoxesAndBounds,
    GridFrame,
    BinCount,
    ScanReduce,
    ScanTop,
    ScanApply,
    BinFill,
    Neighbours,
    Snapshot,
    Collide,
    Report,
    ReportFinal,
}

impl ContactEntry {
    const ALL: [ContactEntry; 12] = [
        ContactEntry::BoxesAndBounds,
        ContactEntry::GridFrame,
        ContactEntry::BinCount,
        ContactEntry::ScanReduce,
        ContactEntry::ScanTop,
        ContactEntry::ScanApply,
        ContactEntry::BinFill,
        ContactEntry::Neighbours,
        ContactEntry::Snapshot,
        ContactEntry::Collide,
        ContactEntry::Report,
        ContactEntry::ReportFinal,
    ];

    fn source(self) -> (ShaderFile, &'static str) {
        match self {
            ContactEntry::BoxesAndBounds => (ShaderFile::Grid, "boxes_and_bounds"),
            ContactEntry::GridFrame => (ShaderFile::Grid, "grid_frame"),
            ContactEntry::BinCount => (ShaderFile::Grid, "bin_count"),
            ContactEntry::ScanReduce => (ShaderFile::Scan, "scan_reduce"),
            ContactEntry::ScanTop => (ShaderFile::Scan, "scan_top"),
            ContactEntry::ScanApply => (ShaderFile::Scan, "scan_apply"),
            ContactEntry::BinFill => (ShaderFile::Grid, "bin_fill"),
            ContactEntry::Neighbours => (ShaderFile::Grid, "neighbours"),
            ContactEntry::Snapshot => (ShaderFile::Collide, "contact_snapshot"),
            ContactEntry::Collide => (ShaderFile::Collide, "collide"),
            ContactEntry::Report => (ShaderFile::Collide, "contact_report"),
            ContactEntry::ReportFinal => (ShaderFile::Collide, "contact_report_final"),
        }
    }
}

/// Layouts and pipelines of the set, for one dimension and precision.
pub(crate) struct ContactKernels {
    dim: usize,
    precision: Precision,
    layout: wgpu::BindGroupLayout,
    params_layout: wgpu::BindGroupLayout,
    pipelines: Vec<wgpu::ComputePipeline>,
}

/// Read-only flags of the group-0 bindings (contact.wgsl), in order:
/// x p status props boxes cands snapshot scratch counters ranges words lists.
const READ_ONLY: [bool; 12] = [
    false, true, false, true, false, false, false, false, false, false, false, false,
];

impl ContactKernels {
    /// Builds every pipeline of the set on `device`.
    pub(crate) fn new(
        device: &wgpu::Device,
        dim: usize,
        precision: Precision,
    ) -> Result<Self, GpuError> {
        if dim == 0 || dim > crate::shader::MAX_GPU_DIM {
            return Err(GpuError::Unsupported {
                what: format!(
                    "contact dimension {dim} (the GPU kernels support 1..={})",
                    crate::shader::MAX_GPU_DIM
                ),
            });
        }
        let needed = READ_ONLY.len() as u32 + 1;
        if device.limits().max_storage_buffers_per_shader_stage < needed {
            return Err(GpuError::Unsupported {
                what: format!("the contact kernels need {needed} storage buffers per shader stage"),
            });
        }
        let entries: Vec<_> = READ_ONLY
            .iter()
            .enumerate()
            .map(|(b, &ro)| crate::pipelines::storage(b as u32, ro, false))
            .collect();
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hyperpbd contact"),
            entries: &entries,
        });
        let params_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("hyperpbd contact params"),
            entries: &[crate::pipelines::storage(0, true, true)],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("hyperpbd contact"),
            bind_group_layouts: &[Some(&layout), Some(&params_layout)],
            immediate_size: 0,
        });
        let modules: Vec<(ShaderFile, wgpu::ShaderModule)> = ShaderFile::CONTACT
            .iter()
            .map(|&file| {
                let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(file.file_name()),
                    source: wgpu::ShaderSource::Wgsl(compose(file, dim, precision).into()),
                });
                (file, module)
            })
            .collect();
        let mut pipelines = Vec::new();
        for entry in ContactEntry::ALL {
            let (file, name) = entry.source();
            let Some((_, module)) = modules.iter().find(|(f, _)| *f == file) else {
                return Err(GpuError::Other {
                    message: format!("no module for {file:?}"),
                });
            };
            pipelines.push(
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(name),
                    layout: Some(&pipeline_layout),
                    module,
                    entry_point: Some(name),
                    compilation_options: Default::default(),
                    cache: None,
                }),
            );
        }
        Ok(ContactKernels {
            dim,
            precision,
            layout,
            params_layout,
            pipelines,
        })
    }

    fn pipeline(&self, entry: ContactEntry) -> &wgpu::ComputePipeline {
        let index = ContactEntry::ALL
            .iter()
            .position(|&e| e == entry)
            .unwrap_or(0);
        &self.pipelines[index]
    }
}

/// Workgroups (x, y) for one invocation per particle.
fn per_particle(n: usize) -> (u32, u32) {
    let groups = (n as u32).div_ceil(WORKGROUP).max(1);
    let x = groups.min(MAX_GROUPS_X);
    (x, groups.div_ceil(x))
}

impl ContactBuffers {
    fn dispatch(
        &self,
        kernels: &ContactKernels,
        pass: &mut wgpu::ComputePass<'_>,
        entry: ContactEntry,
        groups: (u32, u32),
    ) {
        pass.set_pipeline(kernels.pipeline(entry));
        pass.dispatch_workgroups(groups.0, groups.1, 1);
    }

    fn bind(&self, pass: &mut wgpu::ComputePass<'_>, block: usize) {
        pass.set_bind_group(0, &self.group, &[]);
        pass.set_bind_group(1, &self.params_group, &[self.block_offset(block)]);
    }

    /// Records the broadphase (parameter block `block`) into `pass`; the
    /// caller restores its own bind groups afterwards.
    pub(crate) fn encode_broadphase(
        &self,
        kernels: &ContactKernels,
        pass: &mut wgpu::ComputePass<'_>,
        block: usize,
    ) {
        if self.particles() == 0 {
            return;
        }
        self.bind(pass, block);
        let each = per_particle(self.particles());
        let scan = (self.scan_blocks() as u32, 1);
        use ContactEntry::*;
        self.dispatch(
            kernels,
            pass,
            BoxesAndBounds,
            (BOUND_THREADS / WORKGROUP, 1),
        );
        self.dispatch(kernels, pass, GridFrame, (1, 1));
        self.dispatch(kernels, pass, BinCount, each);
        self.dispatch(kernels, pass, ScanReduce, scan);
        self.dispatch(kernels, pass, ScanTop, (1, 1));
        self.dispatch(kernels, pass, ScanApply, scan);
        self.dispatch(kernels, pass, BinFill, each);
        self.dispatch(kernels, pass, Neighbours, each);
    }

    /// Records one contact iteration (parameter block `block`).
    pub(crate) fn encode_collide(
        &self,
        kernels: &ContactKernels,
        pass: &mut wgpu::ComputePass<'_>,
        block: usize,
    ) {
        if self.particles() == 0 {
            return;
        }
        self.bind(pass, block);
        let each = per_particle(self.particles());
        self.dispatch(kernels, pass, ContactEntry::Snapshot, each);
        self.dispatch(kernels, pass, ContactEntry::Collide, each);
    }

    /// Records the report of the last lists on the current positions:
    /// deepest overlap and active pairs (parameter block `block`).
    pub(crate) fn encode_report(
        &self,
        kernels: &ContactKernels,
        pass: &mut wgpu::ComputePass<'_>,
        block: usize,
    ) {
        if self.particles() == 0 {
            return;
        }
        self.bind(pass, block);
        let each = per_particle(self.particles());
        self.dispatch(kernels, pass, ContactEntry::Report, each);
        self.dispatch(kernels, pass, ContactEntry::ReportFinal, (1, 1));
    }
}

/// Hash buckets for `n` particles: a power of two ≥ 2n (at least 16).
fn buckets_for(n: usize) -> usize {
    (2 * n).next_power_of_two().max(16)
}

/// Scan blocks of `buckets` counters.
fn scan_blocks_for(buckets: usize) -> usize {
    buckets.div_ceil(SCAN_BLOCK)
}

/// The largest particle count the scan covers in three dispatches
/// (SCAN_BLOCK² buckets at two per particle).
pub(crate) const MAX_PARTICLES: usize = SCAN_BLOCK * SCAN_BLOCK / 2;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buckets_are_a_power_of_two_with_room() {
        assert_eq!(buckets_for(0), 16);
        assert_eq!(buckets_for(5), 16);
        assert_eq!(buckets_for(9), 32);
        assert_eq!(buckets_for(16_224), 32_768);
        assert_eq!(scan_blocks_for(32_768), 16);
        assert_eq!(scan_blocks_for(buckets_for(MAX_PARTICLES)), SCAN_BLOCK);
    }
}
