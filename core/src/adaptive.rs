//! The adaptive step: one place, for every backend.
//!
//! ```text
//! attempt 0     the plan's substeps s
//! attempt j     s · 2^j substeps over the same dt    (j = 1 … k, "adaptive")
//! a guard rejection → (state already rolled back) next attempt
//! any other error   → returned at once, never retried
//! all k + 1 rejected → the last attempt's GuardRejection, state unchanged
//! ```
//! A backend implements one attempt ([`Subdivided::attempt`]: the step with
//! its substeps multiplied by 2^j, transactional like `step`) and calls
//! [`step_adaptive`] from [`crate::Backend::step`]; the report of the
//! accepted attempt carries every attempt ([`crate::StepReport::attempts`]).

use crate::guard_rules::Attempt;
use crate::{Adaptive, BackendError, StepError, StepReport};

/// One attempt of a step with 2^`subdivision` times the plan's substeps.
pub trait Subdivided {
    /// Runs the step over the plan's dt with `plan.substeps << subdivision`
    /// substeps. On error the state is exactly as before the call.
    fn attempt(&mut self, subdivision: u32) -> Result<StepReport, BackendError>;
}

/// Steps `backend`, whose plan has `substeps` substeps and the policy
/// `adaptive` (`Plan::substeps`, `Plan::adaptive`): one attempt without
/// `adaptive`.
pub fn step_adaptive<B: Subdivided + ?Sized>(
    substeps: u32,
    adaptive: Option<Adaptive>,
    backend: &mut B,
) -> Result<StepReport, BackendError> {
    let most = adaptive.map_or(0, |a| a.max_subdivisions);
    let mut attempts = Vec::new();
    for subdivision in 0..=most {
        let substeps = substeps << subdivision;
        match backend.attempt(subdivision) {
            Ok(mut report) => {
                attempts.push(Attempt {
                    substeps,
                    rejection: None,
                });
                report.attempts = attempts;
                return Ok(report);
            }
            Err(BackendError::Step(StepError::GuardRejected(rejection))) if subdivision < most => {
                attempts.push(Attempt {
                    substeps,
                    rejection: Some(rejection),
                });
            }
            Err(e) => return Err(e),
        }
    }
    // `0..=most` is never empty: the loop always returns.
    Err(BackendError::InvalidCall(
        "adaptive step ran no attempt".into(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{GuardKind, GuardRejection, GuardSubject, StageName};

    /// Rejects every attempt below `accept_at` (never accepts for
    /// `u32::MAX`), or fails with a non-guard error; records the calls.
    struct Scripted {
        accept_at: u32,
        other_error: bool,
        calls: Vec<u32>,
    }

    fn rejection(substep: u32) -> GuardRejection {
        GuardRejection {
            guard: GuardKind::MaxSpeed,
            subject: GuardSubject::Particle(3),
            value: 2.0,
            limit: 1.0,
            substep,
        }
    }

    impl Subdivided for Scripted {
        fn attempt(&mut self, subdivision: u32) -> Result<StepReport, BackendError> {
            self.calls.push(subdivision);
            if self.other_error {
                return Err(StepError::NonFiniteParticle {
                    stage: StageName::Predict,
                    substep: 0,
                    particle: 1,
                }
                .into());
            }
            if subdivision < self.accept_at {
                return Err(StepError::GuardRejected(rejection(subdivision)).into());
            }
            Ok(StepReport::default())
        }
    }

    fn scripted(accept_at: u32, other_error: bool) -> Scripted {
        Scripted {
            accept_at,
            other_error,
            calls: Vec::new(),
        }
    }

    #[test]
    fn rejections_are_retried_with_doubled_substeps_and_all_reported() {
        let mut b = scripted(2, false);
        let policy = Some(Adaptive {
            max_subdivisions: 4,
        });
        let report = step_adaptive(3, policy, &mut b).expect("accepted at 2");
        assert_eq!(b.calls, vec![0, 1, 2]);
        let substeps: Vec<u32> = report.attempts.iter().map(|a| a.substeps).collect();
        assert_eq!(substeps, vec![3, 6, 12]);
        assert_eq!(report.attempts[0].rejection, Some(rejection(0)));
        assert_eq!(report.attempts[1].rejection, Some(rejection(1)));
        assert_eq!(report.attempts[2].rejection, None);
        assert_eq!(report.retries(), 2);
    }

    #[test]
    fn the_last_rejection_is_returned_when_every_attempt_fails() {
        let mut b = scripted(u32::MAX, false);
        let policy = Some(Adaptive {
            max_subdivisions: 3,
        });
        let e = step_adaptive(1, policy, &mut b).expect_err("never accepted");
        assert_eq!(b.calls, vec![0, 1, 2, 3]);
        assert_eq!(
            e,
            BackendError::Step(StepError::GuardRejected(rejection(3)))
        );
    }

    #[test]
    fn other_errors_and_plans_without_adaptive_are_not_retried() {
        let mut b = scripted(0, true);
        let policy = Some(Adaptive {
            max_subdivisions: 3,
        });
        let e = step_adaptive(1, policy, &mut b).expect_err("non-finite");
        assert!(matches!(
            e,
            BackendError::Step(StepError::NonFiniteParticle { .. })
        ));
        assert_eq!(b.calls, vec![0]);
        let mut b = scripted(1, false);
        let e = step_adaptive(1, None, &mut b).expect_err("no retry without adaptive");
        assert_eq!(
            e,
            BackendError::Step(StepError::GuardRejected(rejection(0)))
        );
        assert_eq!(b.calls, vec![0]);
        let mut b = scripted(0, false);
        let report = step_adaptive(2, None, &mut b).expect("accepted");
        assert_eq!(report.attempts.len(), 1);
        assert_eq!(report.attempts[0].substeps, 2);
    }
}
