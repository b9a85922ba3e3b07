//! [`Lockstep`]: worlds stepped on host threads of their own, on one
//! device, that share the host's waits for it.
//!
//! ```text
//! begin(W)   W worlds take part (each on a thread of its own)
//! wait       a world that needs the device's results (its work and its
//!            read-back copies submitted, its buffers' maps requested)
//!            arrives; the last of the worlds taking part to arrive waits
//!            for the device ONCE, for all of them (every submission), and
//!            releases them with that wait's result
//! leave      a world whose step ended (done, refused, failed or panicked)
//!            stops taking part; if every world still taking part has
//!            arrived, the one leaving waits for them
//! ```
//! A round ends when every world still taking part has arrived, so a step
//! in which world k waits n_k times costs max_k n_k waits, where W worlds
//! stepped one after another cost Σ_k n_k. Nothing here touches what a
//! world computes: its kernels, buffers and the order of its submissions
//! are its own run's, so its results are its own run's, bit for bit. Outside
//! a step (nobody taking part) a wait is the caller's own.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Condvar, Mutex, MutexGuard, PoisonError};

use hyperpbd_core::GpuError;

/// The rendezvous of the worlds of a lockstep batch (module docs).
#[derive(Debug, Default)]
pub(crate) struct Lockstep {
    round: Mutex<Round>,
    released: Condvar,
    waits: AtomicU64,
}

/// Who takes part and who has arrived in the current round.
#[derive(Debug, Default)]
struct Round {
    taking_part: usize,
    arrived: usize,
    /// Rounds ended so far (a waiting world watches it change).
    ended: u64,
    /// The result of the last round's wait, for every world it released.
    result: Option<Result<(), GpuError>>,
}

impl Lockstep {
    fn lock(&self) -> MutexGuard<'_, Round> {
        // A world that panicked left (its guard's drop) after the round's
        // bookkeeping was complete: the counts stay right.
        self.round.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// `worlds` worlds take part from now on.
    pub fn begin(&self, worlds: usize) {
        let mut round = self.lock();
        round.taking_part = worlds;
        round.arrived = 0;
        round.result = None;
    }

    /// The host's waits for the device since the batch was made (one per
    /// round).
    pub fn waits(&self) -> u64 {
        self.waits.load(Ordering::Relaxed)
    }

    /// Arrives; returns when the device has finished every submission made
    /// before the round ended, with `wait`'s result (run by the last world
    /// to arrive). Outside a step, `wait` runs at once.
    pub fn wait(&self, wait: &dyn Fn() -> Result<(), GpuError>) -> Result<(), GpuError> {
        let mut round = self.lock();
        if round.taking_part == 0 {
            drop(round);
            return wait();
        }
        round.arrived += 1;
        if round.arrived == round.taking_part {
            return self.end_round(round, wait);
        }
        let ended = round.ended;
        while round.ended == ended {
            round = self
                .released
                .wait(round)
                .unwrap_or_else(PoisonError::into_inner);
        }
        round.result.clone().unwrap_or(Ok(()))
    }

    /// A world stops taking part; ends the round for the others when they
    /// have all arrived.
    pub fn leave(&self, wait: &dyn Fn() -> Result<(), GpuError>) {
        let mut round = self.lock();
        round.taking_part = round.taking_part.saturating_sub(1);
        if round.taking_part > 0 && round.arrived == round.taking_part {
            // The waiting worlds get this wait's result.
            let _ = self.end_round(round, wait);
        }
    }

    /// Waits for the device for every world that arrived, and releases
    /// them.
    fn end_round(
        &self,
        mut round: MutexGuard<'_, Round>,
        wait: &dyn Fn() -> Result<(), GpuError>,
    ) -> Result<(), GpuError> {
        self.waits.fetch_add(1, Ordering::Relaxed);
        let result = wait();
        round.result = Some(result.clone());
        round.arrived = 0;
        round.ended += 1;
        self.released.notify_all();
        result
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;
    use std::sync::atomic::AtomicUsize;

    /// W worlds waiting n_k times cost max n_k waits, each world released
    /// only once the device (a counter here) has served every world of its
    /// round.
    #[test]
    fn a_round_waits_once_for_every_world() {
        let lockstep = Arc::new(Lockstep::default());
        let device_waits = Arc::new(AtomicUsize::new(0));
        let needs = [3usize, 7, 1, 5];
        lockstep.begin(needs.len());
        std::thread::scope(|s| {
            for &n in &needs {
                let (lockstep, device_waits) = (&lockstep, &device_waits);
                s.spawn(move || {
                    let wait = || {
                        device_waits.fetch_add(1, Ordering::SeqCst);
                        Ok(())
                    };
                    for k in 0..n {
                        lockstep.wait(&wait).unwrap();
                        // Released after the k-th round's wait at the
                        // earliest.
                        assert!(device_waits.load(Ordering::SeqCst) > k);
                    }
                    lockstep.leave(&wait);
                });
            }
        });
        assert_eq!(lockstep.waits(), 7);
        assert_eq!(device_waits.load(Ordering::SeqCst), 7);
        // Outside a step a wait is the caller's own, and not a round.
        lockstep.wait(&|| Ok(())).unwrap();
        assert_eq!(lockstep.waits(), 7);
    }

    /// A failed wait reaches every world of its round.
    #[test]
    fn a_failed_wait_reaches_every_world_of_its_round() {
        let lockstep = Lockstep::default();
        lockstep.begin(3);
        let failed = AtomicUsize::new(0);
        std::thread::scope(|s| {
            for _ in 0..3 {
                s.spawn(|| {
                    let wait = || {
                        Err(GpuError::DeviceLost {
                            message: "gone".into(),
                        })
                    };
                    if lockstep.wait(&wait).is_err() {
                        failed.fetch_add(1, Ordering::SeqCst);
                    }
                    lockstep.leave(&wait);
                });
            }
        });
        assert_eq!(failed.load(Ordering::SeqCst), 3);
        assert_eq!(lockstep.waits(), 1);
    }
}
