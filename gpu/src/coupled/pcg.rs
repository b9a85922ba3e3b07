//! PCG for the Newton direction on the device: the vectors and the scalar
//! recurrence both (core's `pcg_on`, decision for decision; the scalars in
//! `cp_cg_alpha` / `cp_cg_beta` of shaders/coupled_solve.wgsl), so that a
//! direction costs a few reads instead of two per CG iteration.
//!
//! ```text
//! submission 1  state cleared; cp_material_frames (H_F⁺ at x_k; a refused
//!               frame ends the solve here: Direction::FrameRefused); cp_slots
//!               (+ cp_material_slots, as after every cp_slots below) +
//!               cp_particle_curvature (the diagonal, P⁻¹),
//!               cp_cg_residual (start: d = 0, r = −g, z = p = P⁻¹ r), r·r, r·z
//!               one read: the start's decisions on the host (core's pcg_start)
//! chunks        CgState written (ρ, tolerance, budget, where p·q, r·r and r·z land)
//!               [cp_cg_turn (not before the first), cp_slots + cp_particle_curvature
//!                (q = H p), p·q, cp_cg_alpha, cp_cg_residual (advance), r·r, r·z,
//!                cp_cg_beta] × k, then the status words and CgState in one read
//!               k: the previous direction's iteration count (at least 2), doubled
//!               each chunk, never past the budget; once the state says stopped,
//!               every pass of the chunk's rest does nothing
//! report        CgState → PcgReport (status, iterations, ‖b‖, the last ‖r‖)
//! ```
//! Each pass is recorded on its own, as the host-driven loop did, so every
//! value is computed by the same kernel from the same inputs: in f64 on
//! lavapipe the directions and reports are the CPU's bit for bit
//! (tests/gpu/coupled/).

use hyperpbd_core::GpuError;
use hyperpbd_core::implicit::{PcgReport, PcgSettings, PcgStatus, pcg_start};

use super::cg_state::CgState;
use super::device::{Device, Reduction};
use super::entries::Entry;
use super::entries::status::NON_FINITE_ELEMENT;
use super::material::refuse_cut_loops_of;
use crate::Precision;
use crate::barrier::{NONE, STATUS_WORDS, status_words};
use crate::context::GpuContext;
use crate::resident_backend::Resident;

/// Where CgState starts in the probe (after the status words, 8-aligned).
const STATE_AT: u64 = (4 * STATUS_WORDS as u64).next_multiple_of(8);
/// The first chunk's length before any direction was solved.
const FIRST_CHUNK: u32 = 8;

/// The read-back buffer of the chunks, and the next first chunk's length.
pub(super) struct PcgProbe {
    buffer: wgpu::Buffer,
    chunk: u32,
}

impl PcgProbe {
    pub fn new(ctx: &GpuContext, precision: Precision) -> Result<Self, GpuError> {
        Ok(PcgProbe {
            buffer: ctx.staging("cg probe", STATE_AT + CgState::len(precision))?,
            chunk: FIRST_CHUNK,
        })
    }
}

/// The tree offset a reduction's result lands at.
fn landed(result: Result<usize, f64>) -> Result<u32, GpuError> {
    result.map(|at| at as u32).map_err(|_| GpuError::Other {
        message: "PCG's dot product over no terms (no particle)".into(),
    })
}

/// PCG's start as read back: r·r and r·z (core's `pcg_start` inputs) and
/// the status words of its submission.
pub(super) struct PcgStart {
    pub values: [f64; 2],
    pub status: [u32; STATUS_WORDS],
}

/// How the Newton direction's solve ended.
pub(super) enum Direction {
    /// PCG ran (its report).
    Solved(PcgReport),
    /// Material element e's frame Hessian at x_k was refused by its law or
    /// not finite: no direction (cpu `curvatures` refuses the step).
    FrameRefused(usize),
}

/// PCG's passes on the device (module docs).
impl PcgProbe {
    /// Clears CgState and sets the start's params (diagonal, mode 0):
    /// before the submission that records PCG's start.
    pub(super) fn prepare_start(device: &mut Device, on: &Resident) {
        let cleared = CgState::default().bytes(on.precision);
        on.ctx.queue.write_buffer(&device.cg, 0, &cleared);
        device.params.diagonal = 1;
        device.params.mode = 0;
    }

    /// Records PCG's start into `pass` (submission 1 of the module docs);
    /// its reductions r·r and r·z.
    pub(super) fn record_start(
        device: &Device,
        pass: &mut wgpu::ComputePass<'_>,
        (n, e, m): (usize, usize, usize),
    ) -> [Result<usize, f64>; 2] {
        for (entry, items) in [
            (Entry::MaterialFrames, m),
            (Entry::Slots, e),
            (Entry::MaterialSlots, m),
            (Entry::ParticleCurvature, n),
            (Entry::CgResidual, n),
        ] {
            device.dispatch(pass, entry, items);
        }
        [
            device.reduce_in(pass, Reduction::SumA),
            device.reduce_in(pass, Reduction::SumB),
        ]
    }

    /// The Newton direction into R_DIRECTION by PCG on the device (module
    /// docs), for `settings`; the material elements' H_F⁺ at x_k (step 6)
    /// are recorded ahead of PCG's start, in the same read. `started`: the
    /// start already read back (recorded with the gradient pass, newton.rs).
    pub(super) fn solve(
        &mut self,
        (device, on): (&mut Device, &Resident),
        (n, e, m): (usize, usize, usize),
        settings: PcgSettings,
        started: Option<PcgStart>,
    ) -> Result<Direction, GpuError> {
        let precision = on.precision;
        let PcgStart {
            values: start,
            status,
        } = match started {
            Some(start) => start,
            None => {
                Self::prepare_start(device, on);
                device.write_params(&on.ctx);
                device.reset_status(&on.ctx);
                let mut encoder = on.encoder();
                let results = {
                    let mut pass = device.begin(&mut encoder);
                    Self::record_start(device, &mut pass, (n, e, m))
                };
                let (values, status) = device.read(&on.ctx, encoder, &results)?;
                PcgStart {
                    values: [values[0], values[1]],
                    status,
                }
            }
        };
        // Only cp_material_frames writes this word in that submission.
        if status[NON_FINITE_ELEMENT] != NONE {
            return Ok(Direction::FrameRefused(status[NON_FINITE_ELEMENT] as usize));
        }
        let (mut report, tolerance) = pcg_start(start[0], start[1], settings);
        let Some(tolerance) = tolerance else {
            return Ok(Direction::Solved(report));
        };
        if settings.max_iterations == 0 {
            report.status = PcgStatus::BudgetExhausted;
            return Ok(Direction::Solved(report));
        }
        device.params.diagonal = 0;
        device.params.mode = 1;
        device.write_params(&on.ctx);
        let mut recorded = 0;
        let mut chunk = self.chunk.max(2);
        loop {
            let k = chunk.min(settings.max_iterations - recorded);
            let mut encoder = on.encoder();
            let mut at = [0; 3];
            {
                let device = &*device;
                let mut pass = device.begin(&mut encoder);
                for j in 0..k {
                    if recorded + j > 0 {
                        device.dispatch(&mut pass, Entry::CgTurn, n);
                    }
                    device.dispatch(&mut pass, Entry::Slots, e);
                    device.dispatch(&mut pass, Entry::MaterialSlots, m);
                    device.dispatch(&mut pass, Entry::ParticleCurvature, n);
                    at[0] = landed(device.reduce_in(&mut pass, Reduction::SumA))?;
                    device.dispatch(&mut pass, Entry::CgAlpha, 1);
                    device.dispatch(&mut pass, Entry::CgResidual, n);
                    at[1] = landed(device.reduce_in(&mut pass, Reduction::SumA))?;
                    at[2] = landed(device.reduce_in(&mut pass, Reduction::SumB))?;
                    device.dispatch(&mut pass, Entry::CgBeta, 1);
                }
            }
            if recorded == 0 {
                // Lands before the submission below (queue writes precede it).
                let state = CgState {
                    at,
                    max_iterations: settings.max_iterations,
                    rho: start[1],
                    tolerance,
                    residual: report.initial_residual,
                    ..CgState::default()
                };
                on.ctx
                    .queue
                    .write_buffer(&device.cg, 0, &state.bytes(precision));
            }
            device.reset_status(&on.ctx);
            recorded += k;
            let state = self.read_cg((device, on), encoder)?;
            if state.stopped != 0 {
                self.chunk = state.iterations;
                return state.report(report.initial_residual).map(Direction::Solved);
            }
            if recorded >= settings.max_iterations {
                return Err(GpuError::Other {
                    message: format!(
                        "the device's PCG ran its budget of {recorded} iterations without stopping"
                    ),
                });
            }
            chunk = chunk.saturating_mul(2);
        }
    }

    /// Submits `encoder` after recording the copies of the status words and
    /// CgState into the probe; waits, refuses cut loops, returns the state.
    fn read_cg(
        &self,
        (device, on): (&Device, &Resident),
        mut encoder: wgpu::CommandEncoder,
    ) -> Result<CgState, GpuError> {
        let len = CgState::len(on.precision);
        let probe = &self.buffer;
        encoder.copy_buffer_to_buffer(&device.status, 0, probe, 0, 4 * STATUS_WORDS as u64);
        encoder.copy_buffer_to_buffer(&device.cg, 0, probe, STATE_AT, len);
        let bytes = on.ctx.submit_and_read(encoder, probe, STATE_AT + len)?;
        refuse_cut_loops_of(&status_words(&bytes))?;
        Ok(CgState::parse(&bytes[STATE_AT as usize..], on.precision))
    }
}
