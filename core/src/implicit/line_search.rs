//! Armijo backtracking on F's change (docs/implicit.md §7 step 10), the
//! one loop both backends run: the first trial is the certified fraction,
//! each rejection halves t.
//!
//! ```text
//! t = fraction;  up to MAX_HALVINGS + 1 trials:
//!   accept t when  F(x + tΔ) − F(x) ≤ ARMIJO · t · g·Δ  and  x + tΔ ≠ x
//!   else t /= 2
//! ```
//! Before the search, a direction that moves no coordinate ends at the
//! rounding floor (a non-finite slope is refused); after a failed search,
//! −½ g·Δ within F's resolution is the floor, else a refusal (§7 step 11).

use crate::{MinimisationStatus, Refusal};

/// Armijo's sufficient-decrease constant c.
pub const ARMIJO: f64 = 1e-4;

/// Halvings after the first trial.
pub const MAX_HALVINGS: u32 = 60;

/// The accepted step fraction, or `None` when no trial is accepted.
/// `trial(t)` evaluates x + tΔ: F's change there (+∞ when not finite) and
/// whether the trial point differs from x. An `Err` from it ends the
/// search.
pub fn armijo<E>(
    fraction: f64,
    slope: f64,
    mut trial: impl FnMut(f64) -> Result<(f64, bool), E>,
) -> Result<Option<f64>, E> {
    let mut t = fraction;
    for _ in 0..=MAX_HALVINGS {
        let (change, moved) = trial(t)?;
        if change <= ARMIJO * t * slope && moved {
            return Ok(Some(t));
        }
        t *= 0.5;
    }
    Ok(None)
}

/// How the Newton iteration ends before any trial, if it does: x + Δ = x in
/// every coordinate (`moved` false) is the rounding floor, a non-finite
/// slope g·Δ a refusal.
pub fn before_search(moved: bool, slope: f64) -> Option<MinimisationStatus> {
    if !slope.is_finite() {
        return Some(MinimisationStatus::Refused(Refusal::NonFinite {
            particle: 0,
        }));
    }
    (!moved).then_some(MinimisationStatus::RoundingFloor)
}

/// How the minimisation ends when no trial was accepted: −½ g·Δ ≤
/// `resolution` (F's change is below its rounding) is the floor, else
/// `NoDescent` at the Newton `residual`.
pub fn after_failed_search(slope: f64, resolution: f64, residual: f64) -> MinimisationStatus {
    if -0.5 * slope <= resolution {
        MinimisationStatus::RoundingFloor
    } else {
        MinimisationStatus::Refused(Refusal::NoDescent { residual })
    }
}
