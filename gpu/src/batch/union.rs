//! The stages of a GPU batch: the union of its worlds' stages, so that
//! worlds whose gravity, forces, friction or damping are zero (stages
//! their own plans compile away) share one schedule.
//!
//! ```text
//! fixed      every kernel but the responses below: the same list in
//!            every world (else the world is refused: "its stages")
//! optional   Friction{f} (μ_f > 0), Damping (rate > 0): the union over
//!            the worlds, after Velocity, friction in family order then
//!            damping — the order Plan::compile gives them
//! predict    gravity term on if any world's is, force term likewise
//! world k    runs the union; a response absent from its own plan is
//!            SKIPPED for it (Call::absent, read per world: friction.wgsl,
//!            integrate.wgsl); a predict term absent from its own plan is
//!            computed from its zeros:
//!              acc = +0;  acc += s·g_a  (g = 0 or s = 0: s·g_a = ±0)
//!                         acc += w·f_a  (f = 0: w·f_a = ±0)
//!            round to nearest: +0 + (±0) = +0 and y + (±0) = y for
//!            y ≠ 0, so acc (never −0: it starts at +0) is the value of
//!            the world's own kernel, which leaves the term out; then
//!            v + h·acc is the same expression on the same values
//! ```
//! So world k of the batch runs exactly its own single-world step, bit for
//! bit, signed zeros included (docs/sweeps.md). A lone world's union is
//! its own plan: one-world schedules and pinned hashes do not move.

use hyperpbd_core::{Kernel, Plan, PredictTerms, StageName};

/// The union of the stages of a batch's worlds (see the module docs).
pub(crate) struct Union {
    /// The substep kernels every world runs.
    kernels: Vec<Kernel>,
    /// The prediction terms every world runs.
    predict: PredictTerms,
}

/// An optional response kernel's place among the responses (friction in
/// family order, then damping); `None` for the fixed kernels.
fn response_rank(kernel: &Kernel) -> Option<usize> {
    match *kernel {
        Kernel::Friction { family } => Some(family),
        Kernel::Damping => Some(usize::MAX),
        Kernel::Predict
        | Kernel::Project { .. }
        | Kernel::Velocity
        | Kernel::Broadphase
        | Kernel::Collide
        | Kernel::Minimise
        | Kernel::GuardMeasure { .. }
        | Kernel::GuardSpeed
        | Kernel::Motion => None,
    }
}

impl Union {
    /// The union of `plans`' stages; `Err(k)` names the first world whose
    /// fixed kernels differ from world 0's or whose responses are not in
    /// the union's order (it cannot share the schedule).
    pub fn of(plans: &[Plan]) -> Result<Union, usize> {
        let fixed = |p: &Plan| -> Vec<Kernel> {
            p.substep_kernels
                .iter()
                .filter(|k| response_rank(k).is_none())
                .copied()
                .collect()
        };
        let Some(first) = plans.first() else {
            return Ok(Union {
                kernels: Vec::new(),
                predict: PredictTerms {
                    gravity: false,
                    force: false,
                },
            });
        };
        let shared = fixed(first);
        let mut responses: Vec<Kernel> = Vec::new();
        let mut predict = first.predict;
        for (k, plan) in plans.iter().enumerate() {
            if fixed(plan) != shared {
                return Err(k);
            }
            for kernel in &plan.substep_kernels {
                if response_rank(kernel).is_some() && !responses.contains(kernel) {
                    responses.push(*kernel);
                }
            }
            predict.gravity |= plan.predict.gravity;
            predict.force |= plan.predict.force;
        }
        responses.sort_by_key(response_rank);
        let mut kernels = Vec::with_capacity(shared.len() + responses.len());
        for kernel in shared {
            kernels.push(kernel);
            if kernel == Kernel::Velocity {
                kernels.append(&mut responses);
            }
        }
        let union = Union { kernels, predict };
        // Each world's own kernels are the union's less its absent
        // responses, in the same order (else the order assumed above is
        // not Plan::compile's, and the world is refused, not mis-run).
        for (k, plan) in plans.iter().enumerate() {
            let own: Vec<Kernel> = union
                .kernels
                .iter()
                .filter(|kernel| !union.absent(plan, kernel))
                .copied()
                .collect();
            if own != plan.substep_kernels {
                return Err(k);
            }
        }
        Ok(union)
    }

    /// Whether `kernel` (of the union) is a response `plan` itself does
    /// not call for: the world skips it.
    pub fn absent(&self, plan: &Plan, kernel: &Kernel) -> bool {
        response_rank(kernel).is_some() && !plan.substep_kernels.contains(kernel)
    }

    /// `plan` running the union's kernels and prediction terms (its own
    /// parameters: damping factor, μ, gravity, forces).
    pub fn plan_for(&self, plan: &Plan) -> Plan {
        let mut stages: Vec<StageName> = Vec::new();
        for k in &self.kernels {
            if stages.last() != Some(&k.stage()) {
                stages.push(k.stage());
            }
        }
        Plan {
            substep_kernels: self.kernels.clone(),
            stages,
            predict: self.predict,
            ..plan.clone()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use hyperpbd_core::{Particle, SceneBuilder};

    /// A falling particle over a plane of friction `mu`, damping `rate`,
    /// gravity `g` along axis 1.
    fn plan(mu: f64, rate: f64, g: f64) -> Plan {
        let mut b = SceneBuilder::new(2).gravity_along(1, g).damping(rate);
        b.particle(Particle::new(vec![0.0, 1.0], 1.0));
        b.hyperplane(vec![0.0, 1.0], 0.0, mu);
        Plan::compile(&b.build().expect("valid scene")).expect("plan")
    }

    #[test]
    fn the_union_holds_every_worlds_responses_in_compile_order() {
        let plans = [plan(0.0, 1.0, -9.81), plan(0.5, 0.0, 0.0)];
        let union = Union::of(&plans).expect("one schedule");
        let full = plan(0.5, 1.0, -9.81);
        assert_eq!(union.kernels, full.substep_kernels);
        assert!(union.predict.gravity);
        for p in &plans {
            let ran = union.plan_for(p);
            assert_eq!(ran.substep_kernels, full.substep_kernels);
            assert_eq!(ran.stages, full.stages);
            assert_eq!(ran.damping, p.damping);
        }
        assert!(union.absent(&plans[0], &Kernel::Friction { family: 0 }));
        assert!(!union.absent(&plans[0], &Kernel::Damping));
        assert!(union.absent(&plans[1], &Kernel::Damping));
        assert!(!union.absent(&plans[1], &Kernel::Velocity));
    }

    #[test]
    fn a_lone_world_is_its_own_union() {
        let p = plan(0.0, 0.0, 0.0);
        let union = Union::of(std::slice::from_ref(&p)).expect("one world");
        assert_eq!(union.plan_for(&p), p);
    }

    #[test]
    fn other_fixed_kernels_are_refused_by_world() {
        let mut other = plan(0.5, 1.0, -9.81);
        other.substep_kernels.retain(|k| *k != Kernel::Velocity);
        assert_eq!(Union::of(&[plan(0.5, 1.0, -9.81), other]).err(), Some(1));
    }
}
