//! The contact kernel set: broadphase on a hashed grid, per-particle
//! contact lists and the gather-Jacobi contact iteration, all on the
//! device (`shaders/{contact,scan,grid,collide}.wgsl` after the prelude),
//! built with the kernel-set builder.
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
//! from the device inside a step (no indirect dispatch is needed): the
//! lists have a fixed number of slots per particle, the longest list found
//! is reported in the outcome, and a list that did not fit (outcome: "need
//! N slots") makes the caller grow the lists and rerun from the saved
//! state ([`ContactBuffers::grow`]). Nothing is dropped silently.
//!
//! Three users share it: [`crate::GpuBackend`] (the step, bound to its
//! resident particle records and status word; in a batch of W worlds the
//! same dispatches over every world, each its own grid, lists and outcome:
//! [`ContactKernels::for_worlds`], contact.wgsl), [`crate::GpuSweep`] (boxes
//! given, lists read back as canonical pairs) and [`crate::GpuCollide`]
//! (iterations on given lists).

mod buffers;

pub(crate) use buffers::{Block, Bound, ContactBuffers, Outcome, Particles};

use hyperpbd_core::{GpuError, Kernel, Plan};

use crate::Precision;
use crate::context::GpuContext;
use crate::kernel_set::{EntryPoint, KernelSet, KernelSetSpec};
use crate::shader::ShaderFile;

/// Invocations of `boxes_and_bounds` (`BOUND_THREADS` in contact.wgsl).
const BOUND_THREADS: u32 = 1024;
/// Hash-bucket counters per scan block (`SCAN_BLOCK` in scan.wgsl).
const SCAN_BLOCK: usize = 2048;
/// Flags of a parameter block (`ContactParams.flags`).
pub(crate) const SKIP_FIXED_PAIRS: u32 = 1;
pub(crate) const BOXES_FROM_STATE: u32 = 2;

/// Every entry point of the set, in dispatch order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ContactEntry {
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

/// Compute dispatches of the contact stage in one step of `plan`: 8 per
/// broadphase and 2 per collide kernel of a substep, and 2 per step (0
/// without particle contact).
pub(crate) fn contact_dispatches_per_step(plan: &Plan) -> usize {
    if plan.contacts.is_none() {
        return 0;
    }
    let per_substep: usize = plan
        .substep_kernels
        .iter()
        .map(|k| match k {
            Kernel::Broadphase => 8,
            Kernel::Collide => 2,
            _ => 0,
        })
        .sum();
    per_substep * plan.substeps as usize + 2
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
}

impl EntryPoint for ContactEntry {
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

/// What one recording of the set does (the module doc's rows).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ContactPhase {
    /// Boxes, grid, bins, scan, lists (8 dispatches).
    Broadphase,
    /// One contact iteration: snapshot, collide (2 dispatches).
    Collide,
    /// The report of the last lists on the current positions: deepest
    /// overlap and active pairs (2 dispatches).
    Report,
}

/// The contact kernel set for one dimension and precision (and, in a
/// batch, its worlds).
pub(crate) struct ContactKernels {
    dim: usize,
    precision: Precision,
    /// Worlds every dispatch runs (1 but in a batch).
    worlds: usize,
    set: KernelSet<ContactEntry>,
}

impl ContactKernels {
    /// Every pipeline of the set on `ctx`'s device, for one world.
    pub(crate) fn new(
        ctx: &GpuContext,
        dim: usize,
        precision: Precision,
    ) -> Result<Self, GpuError> {
        Self::for_worlds(ctx, dim, precision, (1, 0))
    }

    /// Every pipeline of the set on `ctx`'s device for `worlds` =
    /// (W, particles per world): with W > 1 the batch's kernels
    /// (contact.wgsl's WORLDS, the prelude's WORLD_PARTICLES), else the
    /// single-world ones.
    pub(crate) fn for_worlds(
        ctx: &GpuContext,
        dim: usize,
        precision: Precision,
        worlds: (usize, usize),
    ) -> Result<Self, GpuError> {
        if dim == 0 || dim > crate::shader::MAX_GPU_DIM {
            return Err(GpuError::Unsupported {
                what: format!(
                    "contact dimension {dim} (the GPU kernels support 1..={})",
                    crate::shader::MAX_GPU_DIM
                ),
            });
        }
        let (count, particles) = (worlds.0.max(1), worlds.1);
        let constants = if count == 1 {
            Vec::new()
        } else {
            vec![
                ("WORLDS", count as f64),
                ("WORLD_PARTICLES", particles as f64),
            ]
        };
        let set = KernelSet::new(
            ctx,
            &KernelSetSpec {
                label: "hyperpbd contact",
                modules: &[ShaderFile::Scan, ShaderFile::Grid, ShaderFile::Collide],
                dim,
                precision,
                entries: &ContactEntry::ALL,
                constants: &constants,
                generated: None,
            },
        )?;
        Ok(ContactKernels {
            dim,
            precision,
            worlds: count,
            set,
        })
    }
}

impl ContactBuffers {
    /// Binds the groups with parameter block `block` and returns the
    /// particle count of every world, or `None` (nothing bound) when there
    /// are none.
    fn bind(&self, pass: &mut wgpu::ComputePass<'_>, block: usize) -> Option<u32> {
        let n = (self.particles() * self.worlds()) as u32;
        if n == 0 {
            return None;
        }
        pass.set_bind_group(0, &self.group, &[]);
        pass.set_bind_group(1, &self.params_group, &[self.block_offset(block)]);
        Some(n)
    }

    /// Records `phase` (parameter block `block`) into `pass`, nothing
    /// without particles; the caller restores its own bind groups
    /// afterwards.
    pub(crate) fn encode(
        &self,
        kernels: &ContactKernels,
        pass: &mut wgpu::ComputePass<'_>,
        phase: ContactPhase,
        block: usize,
    ) {
        let Some(n) = self.bind(pass, block) else {
            return;
        };
        let set = &kernels.set;
        let worlds = self.worlds() as u32;
        use ContactEntry::*;
        match phase {
            ContactPhase::Broadphase => {
                let scan = self.scan_blocks() as u32;
                set.dispatch(pass, BoxesAndBounds, BOUND_THREADS * worlds);
                set.dispatch_workgroups(pass, GridFrame, worlds);
                set.dispatch(pass, BinCount, n);
                set.dispatch_workgroups(pass, ScanReduce, scan);
                set.dispatch_workgroups(pass, ScanTop, 1);
                set.dispatch_workgroups(pass, ScanApply, scan);
                set.dispatch(pass, BinFill, n);
                set.dispatch(pass, Neighbours, n);
            }
            ContactPhase::Collide => {
                set.dispatch(pass, Snapshot, n);
                set.dispatch(pass, Collide, n);
            }
            ContactPhase::Report => {
                set.dispatch(pass, Report, n);
                set.dispatch_workgroups(pass, ReportFinal, worlds);
            }
        }
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
