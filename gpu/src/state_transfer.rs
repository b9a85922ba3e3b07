//! Moving the state (x, v) between the host and a backend's resident
//! buffers, through the scene origin.
//!
//! ```text
//! read   copy x, v → staging (x first, then v); map; x_world = x + o (f64)
//! write  x − o (f64, exact) and v → the precision's bytes → x, v
//! ```
//! Both GPU backends keep x and v as `particles × dim` reals and share this
//! code, so a state crosses the boundary the same way on each.

use hyperpbd_core::{GpuError, State};

use crate::params::{push_reals, read_reals};
use crate::{Precision, SceneOrigin};

/// The resident x and v of a backend and the staging buffer they are read
/// back through (at least twice `bytes`).
pub(crate) struct ResidentState<'a> {
    pub x: &'a wgpu::Buffer,
    pub v: &'a wgpu::Buffer,
    pub staging: &'a wgpu::Buffer,
    /// Bytes of each of x and v.
    pub bytes: u64,
    pub precision: Precision,
    pub origin: &'a SceneOrigin,
}

impl ResidentState<'_> {
    /// Copies x and v out; `submit` submits the copies, waits and checks
    /// the device (each backend's own rule).
    pub(crate) fn read(
        &self,
        device: &wgpu::Device,
        dim: usize,
        submit: impl FnOnce(wgpu::CommandEncoder) -> Result<(), GpuError>,
    ) -> Result<State, GpuError> {
        let bytes = self.bytes;
        if bytes > 0 {
            let mut encoder = device.create_command_encoder(&Default::default());
            encoder.copy_buffer_to_buffer(self.x, 0, self.staging, 0, bytes);
            encoder.copy_buffer_to_buffer(self.v, 0, self.staging, bytes, bytes);
            submit(encoder)?;
        }
        let data = crate::readback::read_mapped(device, self.staging, 2 * bytes)?;
        let (xs, vs) = data.split_at(bytes as usize);
        let mut positions = read_reals(xs, self.precision);
        self.origin.to_world(&mut positions);
        Ok(State {
            dim,
            positions,
            velocities: read_reals(vs, self.precision),
        })
    }

    /// Replaces x and v with `state` (already checked against the plan).
    pub(crate) fn write(&self, queue: &wgpu::Queue, state: &State) {
        let mut x = Vec::new();
        push_reals(
            &mut x,
            &self.origin.to_local(&state.positions),
            self.precision,
        );
        let mut v = Vec::new();
        push_reals(&mut v, &state.velocities, self.precision);
        if !x.is_empty() {
            queue.write_buffer(self.x, 0, &x);
            queue.write_buffer(self.v, 0, &v);
        }
    }
}
