//! Loading a backend, and the timed runs every section shares.
//!
//! ```text
//! warm-up   one untimed step (first dispatches, page faults), then the
//!           initial state is written back
//! rep r     write the initial state; time each `step()` call alone
//!           (read-backs for error measures are outside the timer);
//!           sample_r = Σ step times
//! report    median over reps (the machine is shared, so single runs are
//!           noisy; min and max are kept beside the median); a run whose
//!           first rep lasts longer than `long_run` seconds is not repeated
//! ```
//! Every rep starts from the same state and the backends are deterministic,
//! so all reps compute the same numbers; the final-state hashes are compared
//! to prove it.

use hyperpbd::{Backend, BackendKind, Plan, State};
use std::time::Instant;

/// Loads `plan` with `state` on `backend` ([`hyperpbd::load`]), the error
/// as text.
pub fn load(backend: BackendKind, plan: Plan, state: &State) -> Result<Box<dyn Backend>, String> {
    hyperpbd::load(plan, state, backend).map_err(|e| e.to_string())
}

/// Median (mean of the middle two for an even count); NaN when empty.
pub fn median(samples: &[f64]) -> f64 {
    let mut v: Vec<f64> = samples.iter().copied().filter(|x| !x.is_nan()).collect();
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let m = v.len() / 2;
    if v.len() % 2 == 1 {
        v[m]
    } else {
        0.5 * (v[m - 1] + v[m])
    }
}

/// What a timed simulation produced.
#[derive(Debug, Clone)]
pub struct Simulation {
    /// Seconds spent in `step()` per rep.
    pub samples: Vec<f64>,
    /// Per-frame states of the first rep (initial first), when asked for.
    pub trajectory: Vec<State>,
    /// Final state of the first rep.
    pub final_state: State,
    /// Largest constraint violation any step reported (first rep).
    pub max_residual: f64,
    /// True when every rep ended in the same state (hash).
    pub reproducible: bool,
}

/// Runs `frames` steps `reps` times from `initial` (after one untimed
/// warm-up step), timing only the steps. A run whose first rep took more
/// than `long_run` seconds is not repeated (long runs average their own
/// noise; `samples.len()` says how many reps ran).
pub fn simulate(
    backend: &mut dyn Backend,
    initial: &State,
    frames: u64,
    reps: usize,
    long_run: f64,
    trajectory: bool,
) -> Result<Simulation, String> {
    backend.step().map_err(|e| format!("warm-up step: {e}"))?;
    let mut samples = Vec::with_capacity(reps);
    let mut first: Option<(Vec<State>, State, f64)> = None;
    let mut reproducible = true;
    for rep in 0..reps.max(1) {
        backend.write_state(initial).map_err(|e| e.to_string())?;
        let mut frames_seen = Vec::new();
        if trajectory && rep == 0 {
            frames_seen.push(initial.clone());
        }
        let mut elapsed = 0.0;
        let mut max_residual: f64 = 0.0;
        for frame in 1..=frames {
            let start = Instant::now();
            let report = backend.step().map_err(|e| format!("frame {frame}: {e}"))?;
            elapsed += start.elapsed().as_secs_f64();
            let r = report.max_violation();
            max_residual = if r.is_nan() {
                f64::NAN
            } else {
                max_residual.max(r)
            };
            if trajectory && rep == 0 {
                frames_seen.push(backend.read_state().map_err(|e| e.to_string())?);
            }
        }
        samples.push(elapsed);
        let long = elapsed > long_run;
        let last = backend.read_state().map_err(|e| e.to_string())?;
        match &first {
            None => first = Some((frames_seen, last, max_residual)),
            Some((_, state, _)) => reproducible &= state.hash() == last.hash(),
        }
        if long {
            break;
        }
    }
    let (trajectory, final_state, max_residual) =
        first.unwrap_or_else(|| unreachable!("at least one rep runs"));
    Ok(Simulation {
        samples,
        trajectory,
        final_state,
        max_residual,
        reproducible,
    })
}

/// Steps to time per rep so that a rep lasts about `target` seconds:
/// one warm-up step, then two timed steps to estimate the step time
/// (1 ≤ k ≤ 10,000).
pub fn calibrate(backend: &mut dyn Backend, target: f64) -> Result<u64, String> {
    backend.step().map_err(|e| e.to_string())?;
    let start = Instant::now();
    for _ in 0..2 {
        backend.step().map_err(|e| e.to_string())?;
    }
    let step = (start.elapsed().as_secs_f64() / 2.0).max(1e-9);
    Ok(((target / step).ceil() as u64).clamp(1, 10_000))
}

/// Seconds per step over `k` steps from `initial`.
pub fn timed_steps(backend: &mut dyn Backend, initial: &State, k: u64) -> Result<f64, String> {
    backend.write_state(initial).map_err(|e| e.to_string())?;
    let start = Instant::now();
    for _ in 0..k {
        backend.step().map_err(|e| e.to_string())?;
    }
    Ok(start.elapsed().as_secs_f64() / k.max(1) as f64)
}

/// Seconds per step, one sample per rep ([`calibrate`], then `reps` ×
/// [`timed_steps`]).
pub fn time_per_step(
    backend: &mut dyn Backend,
    initial: &State,
    reps: usize,
    target: f64,
) -> Result<Vec<f64>, String> {
    let k = calibrate(backend, target)?;
    (0..reps.max(1))
        .map(|_| timed_steps(backend, initial, k))
        .collect()
}
