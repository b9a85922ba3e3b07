//! The invariant the parallel kernels rest on, checked once per plan.
//!
//! ```text
//! every element index < particle count
//! colour c of a family:   no dynamic particle (w > 0) in two of its elements
//! hyperplane contact:     no particle in two elements of the family
//!                         (friction runs over the whole family at once)
//! ```
//! `Plan::compile` builds plans that hold it (greedy colouring); a plan
//! assembled by hand might not, and a colour whose elements share a
//! dynamic particle would make two threads write one coordinate. So the
//! backend refuses such a plan with an error naming the family, colour and
//! particle, instead of racing.

use hyperpbd_core::{BackendError, Plan};

/// Checks the plan's colours (see the module doc).
pub fn check(plan: &Plan) -> Result<(), BackendError> {
    let count = plan.particle_count();
    // owner[p]: 1 + the index of the last colour (over all families) that
    // wrote p.
    let mut owner = vec![0usize; count];
    let mut stamp = 0usize;
    for (f, family) in plan.families.iter().enumerate() {
        let fail = |why: String| {
            BackendError::InvalidCall(format!("plan family {f} ({}): {why}", family.label))
        };
        let arity = family.arity.max(1);
        if family.elements.len() != arity * family.len()
            || family.color_starts.first().is_some_and(|&s| s != 0)
            || family
                .color_starts
                .last()
                .is_some_and(|&s| s != family.len())
            || family.color_starts.windows(2).any(|w| w[0] > w[1])
        {
            return Err(fail(
                "elements, rest values and colour ranges disagree".into(),
            ));
        }
        if let Some(&p) = family.elements.iter().find(|&&p| p as usize >= count) {
            return Err(fail(format!(
                "particle {p} is out of range ({count} particles)"
            )));
        }
        let whole_family = family.kind.is_inequality();
        if whole_family {
            stamp += 1;
        }
        for c in 0..family.color_count() {
            if !whole_family {
                stamp += 1;
            }
            for &p in
                &family.elements[arity * family.color_starts[c]..arity * family.color_starts[c + 1]]
            {
                let p = p as usize;
                if !(whole_family || plan.inverse_mass[p] > 0.0) {
                    continue;
                }
                if owner[p] == stamp {
                    return Err(fail(format!(
                        "particle {p} appears in two elements of colour {c}; elements of a colour \
                         (of a contact family: all its elements) must share no dynamic particle"
                    )));
                }
                owner[p] = stamp;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use hyperpbd_core::{ConstraintFamily, ConstraintKind, FamilyKind, Particle, SceneBuilder};

    fn chain_plan() -> Plan {
        let mut b = SceneBuilder::new(2);
        for i in 0..4 {
            b.particle(Particle::new(vec![i as f64, 0.0], 1.0));
        }
        b.family(ConstraintFamily::new(
            ConstraintKind::Distance,
            0.0,
            vec![vec![0, 1], vec![1, 2], vec![2, 3]],
        ));
        b.hyperplane(vec![0.0, 1.0], -1.0, 0.5);
        let scene = b.build().expect("valid");
        Plan::compile(&scene).expect("compiles")
    }

    #[test]
    fn compiled_plans_pass() {
        check(&chain_plan()).expect("a compiled plan is well coloured");
    }

    #[test]
    fn a_colour_sharing_a_dynamic_particle_is_refused() {
        let mut plan = chain_plan();
        // Merge the distance family's two colours into one.
        let family = &mut plan.families[0];
        family.color_starts = vec![0, family.len()];
        let error = check(&plan).expect_err("shared particle");
        assert!(error.to_string().contains("colour 0"), "{error}");
    }

    #[test]
    fn out_of_range_particles_are_refused() {
        let mut plan = chain_plan();
        plan.families[0].elements[0] = 99;
        let error = check(&plan).expect_err("out of range");
        assert!(error.to_string().contains("particle 99"), "{error}");
    }

    #[test]
    fn a_contact_family_repeating_a_particle_is_refused() {
        let mut plan = chain_plan();
        let contact = &mut plan.families[1];
        assert!(matches!(contact.kind, FamilyKind::HyperplaneContact { .. }));
        contact.elements[1] = contact.elements[0];
        assert!(check(&plan).is_err());
    }
}
