//! Resting contact: a particle on a hyperplane stays put.

use super::*;

/// Runs a single particle of radius `r` placed at `x0` against one
/// hyperplane for `steps` steps; returns the largest displacement from `x0`
/// seen after any step.
fn rest_run(
    normal: &[f64],
    offset: f64,
    friction: f64,
    gravity: Vec<f64>,
    x0: &[f64],
    r: f64,
    steps: usize,
) -> f64 {
    let mut b = SceneBuilder::new(x0.len())
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(1)
        .gravity(gravity);
    b.particle(Particle::new(x0.to_vec(), 0.7).with_radius(r));
    b.hyperplane(normal.to_vec(), offset, friction);
    let scene = b.build().expect("valid scene");
    let mut sim = backend(&scene);
    let mut worst: f64 = 0.0;
    for _ in 0..steps {
        let report = step(&mut sim);
        assert_eq!(
            report.active_contacts, 1,
            "the resting particle lost contact"
        );
        let st = state(&mut sim);
        assert!(all_finite(&st));
        worst = worst.max(norm(&sub(st.position(0), x0)));
    }
    worst
}

/// A particle resting on a hyperplane stays put for 1000 steps (10⁴
/// substeps), with and without friction.
///
/// Each substep, prediction pushes the particle h²g into the plane and the
/// contact projection puts n·x back to offset + r; nothing is left to move
/// except rounding. Bounds, per case (‖x0‖ the distance scale, N = 10⁴
/// substeps):
///
/// - **axis-aligned normal** (e_y, gravity −e_y), μ = 0 and μ = 0.5: the
///   tangential arithmetic is exact (normal components are exactly 0, so
///   every tangential update adds exactly 0) and the normal coordinate is
///   reset to the rest height each substep with at most two roundings
///   (fl(w·dl), the add): |Δx| ≤ 2u·|rest| + 2u·h²g. Bound 4u‖x0‖.
/// - **tilted normal in R^4** ((1,2,−2,4)/5, gravity −g n), μ = 0.5: static
///   friction cancels the tangential displacement every substep and dynamic
///   friction zeroes the tangential velocity, so each substep leaves at most
///   ~2u‖x‖ of position rounding that is not fed back as velocity: it can
///   only accumulate linearly. Bound 2·N·u‖x0‖ ≈ 2e-12 relative (the
///   issue's "~1e-12 relative").
/// - **tilted normal, μ = 0**: a frictionless particle on a plane is in
///   neutral equilibrium tangentially. The ≤ 2u‖x‖ rounding of the two
///   position updates per substep (predict, projection) is reconstructed
///   into a tangential velocity δ/h that nothing removes, so the drift is
///   bounded by Σ_k (k+1)·2u‖x‖ = u‖x‖N(N+1) — quadratic in N, ≈ 1e-8
///   relative here — plus ½·|g_t|·t² from the rounding of gravity's
///   tangential part (|g_t| ≤ u·g·√N_dim·2). This is the floor of
///   position-based velocity, not a physical effect. Measured: the kicks
///   have the same sign every substep (the state repeats), so the drift is
///   systematic — 2.3e-9 m after 1000 steps, ×4 per doubling of the run.
#[test]
fn resting_particle_on_hyperplane_stays_put() {
    let offset = 0.25;
    let r = 0.1;
    let steps = 1000;
    let substeps_total = (steps * 10) as f64;
    let rest: f64 = offset + r; // the plan computes the same fl(offset + r)
    for mu in [0.0, 0.5] {
        // Axis-aligned plane in R^3.
        let x0 = vec![0.3, rest, -0.2];
        let d = rest_run(
            &[0.0, 1.0, 0.0],
            offset,
            mu,
            vec![0.0, -G, 0.0],
            &x0,
            r,
            steps,
        );
        let bound = 4.0 * U * norm(&x0);
        eprintln!(
            "resting (axis-aligned plane, R^3, mu {mu}): max displacement {d:e} / bound {bound:e} (4u|x0|)"
        );
        assert!(
            d <= bound,
            "resting particle moved {d:e} > {bound:e} on an axis-aligned plane (mu {mu})"
        );

        // Tilted plane in R^4; gravity along −n.
        let n = [0.2, 0.4, -0.4, 0.8]; // (1,2,-2,4)/5, |(1,2,-2,4)| = 5 exactly
        // A generic tangent (every component nonzero): (0.4, 0.2, 0.8, 0)
        // minus its normal part.
        let t = [0.4, 0.2, 0.8, 0.0];
        let t = unit(&sub(&t, &scale(dot(&t, &n), &n)));
        let x0: Vec<f64> = (0..4).map(|a| rest * n[a] + 0.6 * t[a]).collect();
        let gravity = scale(-G, &n);
        let d = rest_run(&[1.0, 2.0, -2.0, 4.0], offset, mu, gravity, &x0, r, steps);
        let x_scale = norm(&x0);
        let (bound, why) = if mu > 0.0 {
            (
                2.0 * substeps_total * U * x_scale,
                "2·N·u|x0|: static friction, linear accumulation",
            )
        } else {
            let time = steps as f64 / 60.0;
            let g_t = 2.0 * U * G * 2.0; // 2u·g·√4
            (
                U * x_scale * substeps_total * (substeps_total + 1.0) + 0.5 * g_t * time * time,
                "u|x0|N(N+1) + g_t t²/2: frictionless, rounding fed back as velocity",
            )
        };
        eprintln!(
            "resting (tilted plane, R^4, mu {mu}): max displacement {d:e} ({:e} relative) / bound {bound:e} ({why})",
            d / x_scale
        );
        assert!(
            d <= bound,
            "resting particle moved {d:e} > {bound:e} on a tilted plane (mu {mu})"
        );
    }
}
