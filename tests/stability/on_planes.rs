//! Particles exactly on hyperplanes.

use super::*;

on_every_backend!(on_hyperplane,);

/// Particles exactly on hyperplanes (n·x = offset + radius to the last
/// bit in f64): one on the ground y = 0, one on a 20° incline with
/// μ = 0.6 > tan 20° (static friction holds it), under gravity, 2 s.
/// Each particle is inside the other's half-space (hyperplanes are
/// infinite), so only its own plane touches it.
fn on_hyperplane(kind: BackendKind) {
    let case = "on_hyperplane";
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .gravity_along(1, 9.81);
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.5);
    b.particle(Particle::new(vec![5.0, 0.0, 0.2], 1.0));
    let theta: f64 = 20f64.to_radians();
    // A plane through (2, 0, 0) tilted about z, whose particle sits on it
    // at radius 0.1: n·x = offset + r with offset chosen from x itself.
    let normal = vec![theta.sin(), theta.cos(), 0.0];
    let x = vec![2.0, 0.5, 0.0];
    let offset = normal[0] * x[0] + normal[1] * x[1] - 0.1;
    b.hyperplane(normal, offset, 0.6);
    b.particle(Particle::new(x, 1.0).with_radius(0.1));
    let scene = b.build().expect("valid");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 120);
    check_energy(case, kind, &m, 0.0, "resting contact");
    // A contact projection solves its own constraint exactly; what remains
    // is the rounding of n·x at coordinates up to 5 m: 8 ε · 5 m.
    let bound = 8.0 * epsilon(kind) * 5.0;
    check_residual(
        case,
        kind,
        "max penetration (m)",
        m.residual,
        bound,
        "rounding of n·x: 8 ε · 5 m",
    );
    let drift = (0..2)
        .map(|i| {
            m.last
                .position(i)
                .iter()
                .zip(initial.position(i))
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max);
    // Static friction cancels the tangential motion each substep; gravity
    // pushes at most g h² into the plane per substep, corrected exactly:
    // the particles do not move beyond rounding.
    check_residual(
        case,
        kind,
        "max drift from the start (m)",
        drift,
        1200.0 * 8.0 * epsilon(kind) * 5.0,
        "rounding of n·x per substep, 1200 substeps",
    );
}
