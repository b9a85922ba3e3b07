//! The element forces that XPBD with the primal residual carries from one
//! substep to the next (`consistent.rs`): their storage, the warm start of
//! a substep, and their part in the step's rollback.
//!
//! ```text
//! per family f, slot e:  d_e (arity · N values), λ_e, the material factor
//! substep start          d, λ *= (h / h_d)²  when h changed (both force · h²)
//!                        x = x~ + Σ_e d_e    (consistent::apply)
//! step                   saved before, put back when it fails or is reverted
//! write_state            d = 0, λ = 0        (a written state starts them over)
//! ```

use crate::consistent::{self, Carried, Factors, Scratch};
use hyperpbd_core::Plan;

/// The carried forces of a backend (empty for the standard update).
#[derive(Default)]
pub struct CarriedForces {
    /// d of every family's slots, family f's at `starts[f]..starts[f + 1]`.
    displacement: Vec<f64>,
    starts: Vec<usize>,
    /// Per family: the material elements' Newton factors.
    factors: Vec<Factors>,
    scratch: Scratch,
    /// The substep length d and λ were computed with (0: none yet).
    h: f64,
    /// d, λ and h before the current step.
    saved: (Vec<f64>, Vec<f64>, f64),
}

impl CarriedForces {
    /// Storage for `plan` (nothing unless it has `primal_residual`).
    pub fn new(plan: &Plan) -> Self {
        if !plan.primal_residual {
            return CarriedForces::default();
        }
        let mut starts = vec![0];
        for f in &plan.families {
            starts.push(starts[starts.len() - 1] + consistent::displacement_len(f, plan.dim));
        }
        CarriedForces {
            displacement: vec![0.0; starts[starts.len() - 1]],
            starts,
            factors: plan
                .families
                .iter()
                .map(|f| Factors::for_family(f, plan.dim))
                .collect(),
            ..CarriedForces::default()
        }
    }

    /// Family `f`'s share, with its multipliers `lambda`, and the scratch.
    pub fn family<'a>(
        &'a mut self,
        f: usize,
        lambda: &'a mut [f64],
    ) -> (Carried<'a>, &'a mut Scratch) {
        let carried = Carried {
            displacement: &mut self.displacement[self.starts[f]..self.starts[f + 1]],
            lambda,
            factors: &mut self.factors[f],
        };
        (carried, &mut self.scratch)
    }

    /// The substep begins (after the prediction): rescale to `plan.h`,
    /// then x += Σ d. A no-op for the standard update.
    pub fn warm_start(&mut self, plan: &Plan, x: &mut [f64], lambda: &mut [f64]) {
        if !plan.primal_residual {
            return;
        }
        if self.h != plan.h && self.h > 0.0 {
            let ratio = plan.h / self.h;
            let scale = ratio * ratio;
            self.displacement.iter_mut().for_each(|d| *d *= scale);
            lambda.iter_mut().for_each(|l| *l *= scale);
        }
        self.h = plan.h;
        for factors in &mut self.factors {
            factors.stamp += 1;
        }
        consistent::apply(plan, &self.displacement, &self.starts, x);
    }

    /// Keeps d, λ and h for the step's rollback.
    pub fn save(&mut self, plan: &Plan, lambda: &[f64]) {
        if plan.primal_residual {
            self.saved.0.clone_from(&self.displacement);
            self.saved.1.clear();
            self.saved.1.extend_from_slice(lambda);
            self.saved.2 = self.h;
        }
    }

    /// Puts back what [`CarriedForces::save`] kept.
    pub fn restore(&mut self, plan: &Plan, lambda: &mut [f64]) {
        if plan.primal_residual {
            self.displacement.clone_from(&self.saved.0);
            lambda.copy_from_slice(&self.saved.1);
            self.h = self.saved.2;
        }
    }

    /// Starts over from no force (a written state). A no-op for the
    /// standard update, whose multipliers a written state leaves alone
    /// (a kernel run alone after `write_state` reads them, as on the GPU).
    pub fn clear(&mut self, plan: &Plan, lambda: &mut [f64]) {
        if plan.primal_residual {
            self.displacement.fill(0.0);
            lambda.fill(0.0);
            self.h = 0.0;
        }
    }
}
