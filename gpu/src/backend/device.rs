//! The XPBD GPU backend inside the caller's wgpu application: built on the
//! caller's device and queue, its resident positions exposed, and copied
//! into the caller's vertex buffer by one dispatch recorded into the
//! caller's encoder (`crate::export`).

use hyperpbd_core::{BackendError, Plan, State};

use super::GpuBackend;
use crate::Precision;
use crate::context::DeviceSource;
use crate::export::{ExportParts, PositionExport};

impl GpuBackend {
    /// Loads `plan` with `state` on the caller's `device` and `queue`
    /// (created on `adapter` with the features `precision` needs:
    /// [`crate::required_features`]), so the simulation lives in the
    /// caller's application: [`PositionExport::encode_positions`] then fills a
    /// vertex buffer of the caller's without a host round trip. The
    /// caller's error handler and device-lost callback stay in place.
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
        Self::load(source, plan, state, precision, None, None)
    }
}

impl PositionExport for GpuBackend {
    fn export_parts(&self) -> ExportParts<'_> {
        ExportParts::new(
            &self.ctx,
            &self.state,
            &self.exporter,
            self.plan.particle_count(),
        )
    }
}
