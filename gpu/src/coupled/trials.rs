//! Armijo's trials in batches: several trial points of one line search
//! evaluated in one submission and read back together, while the host's
//! search (core's `armijo`) decides exactly as before on their values.
//!
//! ```text
//! batch     t_c, t_c/2, …: the search's own halvings of the first trial it
//!           has no value for, k of them (1, 2, 4, … per search, never past
//!           MAX_HALVINGS + 1 in all: fewer than twice the trials the search
//!           needs, ⌈log₂(trials + 1)⌉ reads; a first batch sized by the last
//!           search would waste up to 60 trials after a failed search)
//! per trial t_j copied into the params' step (a buffer copy in the encoder,
//!           so every kernel sees exactly the t the host would write);
//!           cp_trial, x_k + t_j Δ → point; changes; ΣA, ΣE copied out;
//!           the moved flag (status[0]) copied out and cleared
//! read      one: every trial's (ΣA, ΣE, moved) and the status words
//! accepted  R_TRIAL must be the accepted trial's for cp_set_x: when a later
//!           trial of the batch ran, cp_trial runs again at the accepted t
//!           (no read); the trials write nothing else that a later pass reads
//!           before rewriting it (the tree and the point buffer are rewritten
//!           by the next gradient; the records and terms are not touched)
//! ```
//! Each trial's values come from the same kernels on the same inputs as a
//! trial of its own, so the search, the iterate and the report are the
//! host-driven loop's, bit for bit.

use hyperpbd_core::GpuError;
use hyperpbd_core::implicit::line_search::MAX_HALVINGS;

use super::device::{Device, Params, Reduction};
use super::entries::{Entry, region};
use crate::Precision;
use crate::barrier::{STATUS_WORDS, status_words};
use crate::params::{push_reals, read_reals, real_size};
use crate::resident_backend::Resident;

/// Trials a batch can hold: every trial of one search.
const MOST: usize = MAX_HALVINGS as usize + 1;

/// Where the params block holds `step` (the first byte where two blocks
/// that differ only in it differ, rounded down to its real).
pub(super) fn step_offset(precision: Precision) -> u64 {
    let zero = Params::default().bytes(precision);
    let one = Params {
        step: -1.0,
        ..Params::default()
    }
    .bytes(precision);
    let first = zero.iter().zip(&one).position(|(a, b)| a != b).unwrap_or(0);
    let r = real_size(precision);
    (first / r * r) as u64
}

/// The batch read-back (2 reals per trial, 8 bytes each, MOST moved
/// words, then the status words) and the batch's steps.
pub(super) struct TrialProbe {
    staging: wgpu::Buffer,
    steps: wgpu::Buffer,
}

const MOVED_AT: u64 = (2 * MOST * 8) as u64;
const STATUS_AT: u64 = MOVED_AT + (4 * MOST as u64).next_multiple_of(8);

impl TrialProbe {
    pub fn new(ctx: &crate::context::GpuContext) -> Result<Self, GpuError> {
        Ok(TrialProbe {
            staging: ctx.staging("trial probe", STATUS_AT + 4 * STATUS_WORDS as u64)?,
            steps: ctx.storage("trial steps", &vec![0u8; MOST * 8])?,
        })
    }

    /// (F's change, moved) of each trial step in `steps` (≤ MOST) from
    /// R_X along R_DIRECTION, as newton.rs's `trial` gives them one at a
    /// time; R_TRIAL is left at the last one.
    pub(super) fn trials(
        &self,
        (device, on): (&Device, &Resident),
        (n, e, m): (usize, usize, usize),
        steps: &[f64],
    ) -> Result<Vec<(f64, bool)>, GpuError> {
        let precision = on.precision;
        let r = real_size(precision) as u64;
        let mut bytes = Vec::new();
        push_reals(&mut bytes, steps, precision);
        on.ctx.queue.write_buffer(&self.steps, 0, &bytes);
        device.write_params(&on.ctx);
        device.reset_status(&on.ctx);
        let at = step_offset(precision);
        let mut encoder = on.encoder();
        let probe = &self.staging;
        let mut results = Vec::with_capacity(steps.len());
        for j in 0..steps.len() {
            let steps = &self.steps;
            encoder.copy_buffer_to_buffer(steps, j as u64 * r, &device.params_buffer, at, r);
            device.pass(&mut encoder, Entry::Trial, n);
            device.load_point(&mut encoder, &on.state, region::TRIAL);
            let (own, coupled) = {
                let mut pass = device.begin(&mut encoder);
                device.dispatch(&mut pass, Entry::ParticleChanges, n);
                device.dispatch(&mut pass, Entry::ElementChanges, e);
                device.dispatch(&mut pass, Entry::MaterialChanges, m);
                (
                    device.reduce_in(&mut pass, Reduction::SumA),
                    device.reduce_in(&mut pass, Reduction::SumE),
                )
            };
            for (k, result) in [own, coupled].into_iter().enumerate() {
                if let Ok(from) = result {
                    let to = (2 * j + k) as u64 * 8;
                    encoder.copy_buffer_to_buffer(&device.tree, from as u64 * r, probe, to, r);
                }
            }
            let moved = MOVED_AT + 4 * j as u64;
            encoder.copy_buffer_to_buffer(&device.status, 0, probe, moved, 4);
            encoder.clear_buffer(&device.status, 0, Some(4));
            results.push([own, coupled]);
        }
        let words = 4 * STATUS_WORDS as u64;
        encoder.copy_buffer_to_buffer(&device.status, 0, probe, STATUS_AT, words);
        let read = on.ctx.submit_and_read(encoder, probe, STATUS_AT + words)?;
        super::material::refuse_cut_loops_of(&status_words(&read[STATUS_AT as usize..]))?;
        let h2 = on.plan.h * on.plan.h;
        Ok((0..steps.len())
            .map(|j| {
                // A reduction over no terms is its pad (Device::read).
                let real = |k: usize| {
                    let at = (2 * j + k) * 8;
                    match results[j][k] {
                        Err(pad) => pad,
                        Ok(_) => match read_reals(&read[at..at + r as usize], precision)[0] {
                            value if value >= f64::MAX => f64::INFINITY,
                            value => value,
                        },
                    }
                };
                let total = real(0) + h2 * real(1);
                let change = if total.is_finite() {
                    total
                } else {
                    f64::INFINITY
                };
                let word = MOVED_AT as usize + 4 * j;
                (change, read[word..word + 4] != [0, 0, 0, 0])
            })
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The offset found is where the block holds `step`, in both
    /// precisions.
    #[test]
    fn the_step_offset_holds_the_step() {
        for precision in [Precision::F32, Precision::F64] {
            let params = Params {
                step: 0.375,
                ..Params::default()
            };
            let bytes = params.bytes(precision);
            let at = step_offset(precision) as usize;
            let r = real_size(precision);
            assert_eq!(read_reals(&bytes[at..at + r], precision), vec![0.375]);
        }
    }
}
