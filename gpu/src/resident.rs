//! The state a GPU backend keeps on the device — x, v, their copies at the
//! start of a step, the forces — and everything the `Backend` trait does
//! with it: read, write, set forces, save and roll back. Both GPU backends
//! hold one, so a state crosses the host boundary the same way on each.
//!
//! ```text
//! write        x − o (f64, exact) packed in the layout (records: inverse
//!              mass in the last lane) → x;  v → v
//! read         copy x, v → staging; map; unpack; x + o (f64)
//! save         x → saved_x, v → saved_v          (in the step's own encoder)
//! rollback     saved_x → x, saved_v → v; submit   (byte for byte)
//! prefetch     the next step also copies x, v → staging[k] in its own
//!              submission and maps it; read_state then takes it without
//!              another submit or wait. Two staging buffers (k alternates),
//!              so a snapshot left unread never blocks the next one.
//! ```

use std::sync::mpsc;

use hyperpbd_core::{BackendError, GpuError, Plan, State, check_forces, check_state};

use crate::context::GpuContext;
use crate::layout::VectorLayout;
use crate::params::{push_reals, read_reals, real_size};
use crate::{Precision, SceneOrigin};

/// A snapshot copy submitted with a step, its mapping under way.
struct Snapshot {
    slot: usize,
    mapped: mpsc::Receiver<Result<(), wgpu::BufferAsyncError>>,
}

/// How host vectors become device bytes and back.
pub(crate) struct Packing {
    layout: VectorLayout,
    dim: usize,
    precision: Precision,
    origin: SceneOrigin,
    /// Last lane of position records (the inverse masses).
    inverse_mass: Vec<f64>,
}

impl Packing {
    /// World positions as the device stores them.
    pub fn positions(&self, positions: &[f64]) -> Vec<u8> {
        self.positions_from(0, positions)
    }

    /// World positions of the particles from `first` on (a batch's world)
    /// as the device stores them.
    pub fn positions_from(&self, first: usize, positions: &[f64]) -> Vec<u8> {
        let local = self.origin.to_local(positions);
        let count = positions.len() / self.dim.max(1);
        let lane =
            (self.layout == VectorLayout::Record).then(|| &self.inverse_mass[first..first + count]);
        self.bytes_of(&self.layout.pack(self.dim, &local, lane))
    }

    /// Bytes of one particle's vector.
    pub(crate) fn particle_bytes(&self) -> u64 {
        (self.layout.reals_per_particle(self.dim) * real_size(self.precision)) as u64
    }

    /// Velocities or forces as the device stores them.
    pub fn vectors(&self, values: &[f64]) -> Vec<u8> {
        self.bytes_of(&self.layout.pack(self.dim, values, None))
    }

    fn bytes_of(&self, reals: &[f64]) -> Vec<u8> {
        let mut out = Vec::with_capacity(reals.len() * real_size(self.precision));
        push_reals(&mut out, reals, self.precision);
        out
    }

    /// Device bytes of a vector buffer back to flat f64 coordinates (device
    /// coordinates: positions stay relative to the origin).
    pub fn unpack(&self, bytes: &[u8]) -> Vec<f64> {
        self.layout
            .unpack(self.dim, &read_reals(bytes, self.precision))
    }
}

/// x, v, their saved copies and the forces of one backend.
pub(crate) struct ResidentState {
    pub x: wgpu::Buffer,
    pub v: wgpu::Buffer,
    pub saved_x: wgpu::Buffer,
    pub saved_v: wgpu::Buffer,
    pub force: wgpu::Buffer,
    staging: [wgpu::Buffer; 2],
    /// Staging buffer the next copy goes to.
    next: usize,
    /// A step should copy the state out (set by `prefetch`).
    wanted: bool,
    /// The snapshot of the current state, when one was taken.
    snapshot: Option<Snapshot>,
    /// The layout of x, v and force.
    pub packing: Packing,
    /// Bytes of each of x and v.
    bytes: u64,
    /// Further state a step carries over (XPBD with the primal residual:
    /// the multipliers and the element displacements), each with its
    /// saved copy: saved with x and v, put back with them, cleared by a
    /// written state ([`ResidentState::carry`]).
    carried: Vec<(wgpu::Buffer, wgpu::Buffer)>,
}

impl ResidentState {
    /// Uploads `state` and `force` in `layout` (position records carry
    /// `inverse_mass` in their last lane), positions relative to `origin`.
    pub fn new(
        ctx: &GpuContext,
        layout: VectorLayout,
        precision: Precision,
        origin: SceneOrigin,
        state: &State,
        inverse_mass: &[f64],
        force: &[f64],
    ) -> Result<Self, GpuError> {
        let dim = state.dim;
        let bytes =
            (inverse_mass.len() * layout.reals_per_particle(dim) * real_size(precision)) as u64;
        let packing = Packing {
            layout,
            dim,
            precision,
            origin,
            inverse_mass: inverse_mass.to_vec(),
        };
        let x = packing.positions(&state.positions);
        let v = packing.vectors(&state.velocities);
        Ok(ResidentState {
            x: ctx.storage("x", &x)?,
            v: ctx.storage("v", &v)?,
            saved_x: ctx.storage("saved_x", &x)?,
            saved_v: ctx.storage("saved_v", &v)?,
            force: ctx.storage("force", &packing.vectors(force))?,
            staging: [
                ctx.staging("state staging 0", 2 * bytes)?,
                ctx.staging("state staging 1", 2 * bytes)?,
            ],
            next: 0,
            wanted: false,
            snapshot: None,
            packing,
            bytes,
            carried: Vec::new(),
        })
    }

    /// Makes `buffer` part of the state a step carries over, with `saved`
    /// (its size) as its copy for the rollback.
    pub fn carry(&mut self, buffer: wgpu::Buffer, saved: wgpu::Buffer) {
        self.carried.push((buffer, saved));
    }

    /// The scene origin device positions are relative to.
    pub fn origin(&self) -> &SceneOrigin {
        &self.packing.origin
    }

    /// Where `count` particles' positions sit in `x`.
    pub fn position_layout(&self, count: usize) -> PositionLayout {
        let p = &self.packing;
        PositionLayout {
            dim: p.dim,
            count,
            stride: p.layout.reals_per_particle(p.dim),
            precision: p.precision,
            origin: p.origin.as_slice().to_vec(),
        }
    }

    /// Records the copies x → saved_x, v → saved_v.
    pub fn save(&self, encoder: &mut wgpu::CommandEncoder) {
        if self.bytes > 0 {
            encoder.copy_buffer_to_buffer(&self.x, 0, &self.saved_x, 0, self.bytes);
            encoder.copy_buffer_to_buffer(&self.v, 0, &self.saved_v, 0, self.bytes);
        }
        for (buffer, saved) in &self.carried {
            encoder.copy_buffer_to_buffer(buffer, 0, saved, 0, buffer.size());
        }
    }

    /// Records the copy of `count` particles' x and v (their start-of-step
    /// copies when `saved`; the forces too when `forces`) of `from` from
    /// particle `a` on into `to` from particle `b` on, byte for byte (the
    /// same layout and precision: a batch's world and a backend of its
    /// own plan, gpu/src/batch/retry.rs).
    pub fn record_copy(
        encoder: &mut wgpu::CommandEncoder,
        (from, a, saved): (&ResidentState, usize, bool),
        (to, b): (&ResidentState, usize),
        (count, forces): (usize, bool),
    ) {
        let size = from.packing.particle_bytes();
        let (at, into, bytes) = (a as u64 * size, b as u64 * size, count as u64 * size);
        if bytes == 0 {
            return;
        }
        let (x, v) = match saved {
            true => (&from.saved_x, &from.saved_v),
            false => (&from.x, &from.v),
        };
        let mut pairs = vec![(x, &to.x), (v, &to.v)];
        if forces {
            pairs.push((&from.force, &to.force));
        }
        for (source, target) in pairs {
            encoder.copy_buffer_to_buffer(source, at, target, into, bytes);
        }
    }

    /// Restores x and v from their saved copies, byte for byte.
    pub fn rollback(&mut self, ctx: &GpuContext) -> Result<(), GpuError> {
        self.forget_snapshot();
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        if self.bytes > 0 {
            encoder.copy_buffer_to_buffer(&self.saved_x, 0, &self.x, 0, self.bytes);
            encoder.copy_buffer_to_buffer(&self.saved_v, 0, &self.v, 0, self.bytes);
        }
        for (buffer, saved) in &self.carried {
            encoder.copy_buffer_to_buffer(saved, 0, buffer, 0, buffer.size());
        }
        ctx.submit_and_wait(encoder)
    }

    /// Replaces x and v with `state`, checked against `plan` first (a bad
    /// state is a typed error and changes nothing): `Backend::write_state`
    /// of both GPU backends.
    pub fn write(
        &mut self,
        ctx: &GpuContext,
        plan: &Plan,
        state: &State,
    ) -> Result<(), BackendError> {
        self.write_from(ctx, plan, 0, state)
    }

    /// [`ResidentState::write`] of the particles from `first` on (a
    /// batch's world: `plan` is that world's).
    pub fn write_from(
        &mut self,
        ctx: &GpuContext,
        plan: &Plan,
        first: usize,
        state: &State,
    ) -> Result<(), BackendError> {
        check_state(plan, state)?;
        self.forget_snapshot();
        if self.bytes > 0 {
            let at = first as u64 * self.packing.particle_bytes();
            let x = self.packing.positions_from(first, &state.positions);
            ctx.queue.write_buffer(&self.x, at, &x);
            ctx.queue
                .write_buffer(&self.v, at, &self.packing.vectors(&state.velocities));
        }
        // A written state starts the carried forces over (as the CPU's
        // CarriedForces::clear): zeros.
        for (buffer, _) in &self.carried {
            ctx.queue
                .write_buffer(buffer, 0, &vec![0u8; buffer.size() as usize]);
        }
        Ok(())
    }

    /// Replaces the forces, checked against `plan` first:
    /// `Backend::set_forces` of both GPU backends.
    pub fn set_forces(
        &self,
        ctx: &GpuContext,
        plan: &Plan,
        forces: &[f64],
    ) -> Result<(), BackendError> {
        self.set_forces_from(ctx, plan, 0, forces)
    }

    /// [`ResidentState::set_forces`] of the particles from `first` on (a
    /// batch's world: `plan` is that world's).
    pub fn set_forces_from(
        &self,
        ctx: &GpuContext,
        plan: &Plan,
        first: usize,
        forces: &[f64],
    ) -> Result<(), BackendError> {
        check_forces(plan, forces)?;
        if self.bytes > 0 {
            let at = first as u64 * self.packing.particle_bytes();
            ctx.queue
                .write_buffer(&self.force, at, &self.packing.vectors(forces));
        }
        Ok(())
    }

    /// Asks the next step to copy the state out with its own submission.
    pub fn prefetch(&mut self) {
        self.wanted = true;
    }

    /// Records the snapshot copy into a step's encoder when one was asked
    /// for; returns the staging slot to map after the submit.
    pub fn record_snapshot(&mut self, encoder: &mut wgpu::CommandEncoder) -> Option<usize> {
        self.forget_snapshot();
        if !std::mem::take(&mut self.wanted) || self.bytes == 0 {
            return None;
        }
        let slot = self.next;
        self.next = 1 - slot;
        let staging = &self.staging[slot];
        encoder.copy_buffer_to_buffer(&self.x, 0, staging, 0, self.bytes);
        encoder.copy_buffer_to_buffer(&self.v, 0, staging, self.bytes, self.bytes);
        Some(slot)
    }

    /// Starts mapping the snapshot of `slot` (its copy just submitted); the
    /// step's own wait completes it.
    pub fn map_snapshot(&mut self, slot: usize) {
        let (tx, rx) = mpsc::channel();
        self.staging[slot]
            .slice(0..2 * self.bytes)
            .map_async(wgpu::MapMode::Read, move |r| {
                let _ = tx.send(r);
            });
        self.snapshot = Some(Snapshot { slot, mapped: rx });
    }

    /// Drops a snapshot that no longer describes the state (call after
    /// any work that changes x or v outside a step).
    pub fn forget_snapshot(&mut self) {
        if let Some(s) = self.snapshot.take() {
            self.staging[s.slot].unmap();
        }
    }

    /// The state: from the prefetched snapshot when there is one, else
    /// copied out now.
    pub fn read(&mut self, ctx: &GpuContext) -> Result<State, GpuError> {
        let data = match self.snapshot.take() {
            Some(s) => {
                let mapped = match s.mapped.try_recv() {
                    Ok(r) => r,
                    Err(_) => {
                        ctx.poll(None)?;
                        s.mapped.recv().map_err(|_| GpuError::DeviceLost {
                            message: "snapshot mapping was never answered".into(),
                        })?
                    }
                };
                let buffer = &self.staging[s.slot];
                let bytes = mapped
                    .map_err(|e| GpuError::Other {
                        message: format!("buffer mapping failed: {e}"),
                    })
                    .and_then(|()| {
                        buffer
                            .slice(0..2 * self.bytes)
                            .get_mapped_range()
                            .map(|view| view.to_vec())
                            .map_err(|e| GpuError::Other {
                                message: format!("mapped range: {e:?}"),
                            })
                    });
                buffer.unmap();
                ctx.check()?;
                bytes?
            }
            None => {
                let staging = &self.staging[self.next];
                if self.bytes == 0 {
                    Vec::new()
                } else {
                    let mut encoder = ctx.device.create_command_encoder(&Default::default());
                    encoder.copy_buffer_to_buffer(&self.x, 0, staging, 0, self.bytes);
                    encoder.copy_buffer_to_buffer(&self.v, 0, staging, self.bytes, self.bytes);
                    ctx.submit_and_read(encoder, staging, 2 * self.bytes)?
                }
            }
        };
        let (xs, vs) = data.split_at(self.bytes as usize);
        let mut positions = self.packing.unpack(xs);
        self.packing.origin.to_world(&mut positions);
        Ok(State {
            dim: self.packing.dim,
            positions,
            velocities: self.packing.unpack(vs),
        })
    }
}

/// How a backend's resident positions sit in its position buffer.
#[derive(Debug, Clone, PartialEq)]
pub struct PositionLayout {
    /// Spatial dimension N.
    pub dim: usize,
    /// Particles in the buffer.
    pub count: usize,
    /// Reals per particle (coordinate a of particle i is real
    /// `stride · i + a`; the other reals of a record are padding or the
    /// inverse mass).
    pub stride: usize,
    /// The reals' type: f32 or f64.
    pub precision: Precision,
    /// The scene origin o: world position = stored position + o.
    pub origin: Vec<f64>,
}
