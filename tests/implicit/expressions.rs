//! Expression families (and bending) on the coupled implicit step (issue
//! 29: ∇²C derived, the spring C²/(2α) with the PSD projection;
//! core/src/implicit/expression_spring.rs), on the CPU golden path.
//!
//! - The built-in distance and tether written as expressions take the same
//!   minimisations as the built-ins: restarted from the same state before
//!   every step, both converge and their iterates differ by at most the sum
//!   of the two stopping balls. With F = ½‖x − x̃‖²_M + h² E and ∇²F ⪰ M
//!   (a hanging chain is in tension, so the springs' exact Hessian is PSD),
//!   ‖x − x*‖_M ≤ ‖∇F(x)‖_{M⁻¹}; the criterion ‖∇ᵢF‖ ≤ tol mᵢ h² gives
//!   ‖∇F‖_{M⁻¹} ≤ tol h² √(Σ mᵢ), so per particle
//!   |xᵢ − x'ᵢ| ≤ 2 tol h² √(Σ m / mᵢ).
//! - A folded hinge (cosine bending) unfolds to flat on the implicit path;
//!   a cloth with bending steps with every minimisation converged, the same
//!   bytes on 1 and 2 threads.
//!
//! `cargo test --release --test implicit -- expressions:: --nocapture | grep '^BOUND'`.

use crate::common;

use common::bound::print_bound;
use common::expressions::as_expressions;
use common::implicit_scenes::{
    CHAIN_TOLERANCE as TOLERANCE, bending_cloth as cloth_with_bending, chain_of as chain,
    folded_hinge,
};
use hyperpbd::kinds::{BendingModel, Relation};
use hyperpbd::{Backend, ConstraintKind, MinimisationStatus, Scene, State};

/// Every minimisation of `report` converged.
fn converged(report: &hyperpbd::StepReport, what: &str, step: usize) {
    for m in &report.minimisation {
        assert_eq!(
            m.status,
            MinimisationStatus::Converged,
            "{what}, step {step}: {:?}",
            m.status
        );
    }
}

/// Steps `builtin` and `expression` `steps` times, the expression backend
/// restarted from the built-in's state before each step; the largest
/// |xᵢ − x'ᵢ| / (2 tol h² √(Σ m / mᵢ)) (module docs).
fn restarted_distance(builtin: &Scene, expression: &Scene, steps: usize) -> f64 {
    let mut a = common::cpu_backend(builtin, 1);
    let mut b = common::cpu_backend(expression, 1);
    let h = builtin.dt / f64::from(builtin.substeps);
    let masses: Vec<Option<f64>> = (builtin.particles.iter())
        .map(|p| (!p.fixed).then_some(p.mass.unwrap_or(1.0)))
        .collect();
    let total: f64 = masses.iter().flatten().sum();
    let dim = builtin.dim;
    let mut worst: f64 = 0.0;
    for step in 0..steps {
        let start = a.read_state().expect("state");
        b.write_state(&start).expect("restart");
        converged(&a.step().expect("built-in steps"), "built-in", step);
        converged(&b.step().expect("expression steps"), "expression", step);
        let (xa, xb) = (a.read_state().expect("a"), b.read_state().expect("b"));
        for (i, m) in masses.iter().enumerate() {
            let Some(m) = m else { continue };
            let bound = 2.0 * TOLERANCE * h * h * (total / m).sqrt();
            let d: f64 = (0..dim)
                .map(|k| (xa.positions[i * dim + k] - xb.positions[i * dim + k]).powi(2))
                .sum::<f64>()
                .sqrt();
            worst = worst.max(d / bound);
        }
    }
    worst
}

/// The 8-link chain of `kind` against its expression `norm(x1 - x0)` with
/// `relation`, restarted each step: within the two stopping balls.
fn expression_takes_the_built_in_minimisations(kind: ConstraintKind, relation: Relation) {
    let builtin = chain(kind, 8);
    let expression = as_expressions(&builtin, kind, "norm(x1 - x0)", relation);
    let ratio = restarted_distance(&builtin, &expression, 60);
    let name = format!("implicit_expression_{kind:?}").to_lowercase();
    print_bound(name, ratio, 1.0, "of the stopping balls");
    assert!(
        ratio <= 1.0,
        "{kind:?} as an expression: {ratio} of the bound"
    );
}

#[test]
fn a_distance_expression_takes_the_built_in_distance_minimisations() {
    expression_takes_the_built_in_minimisations(ConstraintKind::Distance, Relation::Equal);
}

#[test]
fn a_tether_expression_takes_the_built_in_tether_minimisations() {
    expression_takes_the_built_in_minimisations(ConstraintKind::Tether, Relation::AtMost);
}

#[test]
fn a_folded_hinge_unfolds_to_flat_on_the_implicit_path() {
    let scene = folded_hinge();
    let mut cpu = common::cpu_backend(&scene, 1);
    for step in 0..600 {
        converged(&cpu.step().expect("steps"), "hinge", step);
    }
    let x = cpu.read_state().expect("state").positions;
    // Flat: x3 in the plane z = 0 on the far side of the edge (y < 0). The
    // cosine's restoring force vanishes at flat (C ≈ −θ²/2 there, so the
    // energy is ≈ θ⁴/(8α)): the fold decays slowly near flat, and 10° after
    // 10 s from 90° is the check that it unfolded (not that it is at rest).
    let (y, z) = (x[10], x[11]);
    let from_flat = z.abs().atan2(-y).to_degrees();
    print_bound(
        "implicit_hinge_fold_after_10s_deg",
        from_flat,
        10.0,
        "from 90°",
    );
    assert!(from_flat <= 10.0, "x3 = {:?}", &x[9..12]);
}

#[test]
fn a_cloth_with_bending_steps_converged_with_the_same_bytes_on_any_thread_count() {
    for model in [BendingModel::Cosine, BendingModel::Quadratic] {
        let scene = cloth_with_bending(model);
        let run = |threads: usize| -> State {
            let mut cpu = common::cpu_backend(&scene, threads);
            for step in 0..30 {
                converged(&cpu.step().expect("steps"), "cloth", step);
            }
            cpu.read_state().expect("state")
        };
        let one = run(1);
        assert!(one.positions.iter().all(|v| v.is_finite()));
        assert_eq!(
            one.hash(),
            run(2).hash(),
            "{model:?}: 1 and 2 threads differ"
        );
    }
}
