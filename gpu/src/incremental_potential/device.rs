//! The barrier backend inside the caller's wgpu application: built on the
//! caller's device and queue, its resident positions exported
//! (`crate::export`), as `crate::GpuBackend` does for the XPBD path.

use hyperpbd_core::{BackendError, Plan, State};

use super::GpuBarrierBackend;
use crate::Precision;
use crate::context::DeviceSource;
use crate::export::{ExportParts, PositionExport};

impl GpuBarrierBackend {
    /// Loads an incremental-potential `plan` with `state` on the caller's
    /// `device` and `queue` (created on `adapter`), as
    /// [`crate::GpuBackend::with_device`] does for the XPBD path.
    pub fn with_device(
        adapter: &wgpu::Adapter,
        device: wgpu::Device,
        queue: wgpu::Queue,
        plan: Plan,
        state: &State,
        precision: Precision,
    ) -> Result<Self, BackendError> {
        let source = DeviceSource::Given {
            adapter,
            device,
            queue,
        };
        Self::load(source, plan, state, precision)
    }
}

impl PositionExport for GpuBarrierBackend {
    fn export_parts(&self) -> ExportParts<'_> {
        ExportParts::new(
            &self.ctx,
            &self.state,
            &self.exporter,
            self.plan.particle_count(),
        )
    }
}
