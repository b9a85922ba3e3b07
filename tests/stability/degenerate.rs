//! Degenerate and inverted geometry: a sliver tetrahedron, inverted
//! tetrahedra, a zero oriented rest measure, coincident particles.

use super::*;

on_every_backend!(
    oriented_near_degenerate,
    oriented_inverted,
    oriented_zero_rest_refused,
    coincident_distance,
);

/// The oriented volume of tetrahedron `points` (flat, 4 × 3).
fn tet_volume(points: &[f64]) -> f64 {
    let mut grad = vec![0.0; 12];
    let mut scratch = hyperpbd::geometry::Scratch::new();
    hyperpbd::geometry::oriented_measure(points, 3, &mut grad, &mut scratch)
}

/// A sliver tetrahedron just above the degeneracy floor (height 1e-9 m on
/// a 1 m base: volume ratio 1e-9 against the floor's 1e-12), rigid, with
/// its edges as rigid springs, falling onto a plane: the volume gradient
/// is nearly zero across the sliver for the base vertices, so
/// Δλ = −C / Σ w |∇C|² is large — it must not throw the particles away.
fn oriented_near_degenerate(kind: BackendKind) {
    let case = "oriented_near_degenerate";
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(2)
        .gravity_along(1, 9.81);
    let flat = 1e-9;
    for p in [
        [0.0, 0.5, 0.0],
        [1.0, 0.5, 0.0],
        [0.0, 0.5, 1.0],
        [0.3, 0.5 + flat, 0.3],
    ] {
        b.particle(Particle::new(p.to_vec(), 0.25).with_radius(0.01));
    }
    b.family(ConstraintFamily::new(
        ConstraintKind::OrientedMeasure,
        0.0,
        vec![vec![0, 1, 2, 3]],
    ));
    let edges = vec![
        vec![0, 1],
        vec![0, 2],
        vec![0, 3],
        vec![1, 2],
        vec![1, 3],
        vec![2, 3],
    ];
    b.family(ConstraintFamily::new(ConstraintKind::Distance, 0.0, edges));
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.5);
    let scene = b.build().expect("a sliver above the floor is valid");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 90);
    check_energy(case, kind, &m, 0.0, "dissipative: starts at rest");
    check_residual(
        case,
        kind,
        "max |C| edges + contact (m)",
        m.residual,
        0.01,
        "1% of the 1 m edge",
    );
    // Once it lies on the plane the sliver is flattened: gravity pushes
    // every vertex g h² = 2.7e-5 m into the plane per substep, 27 000
    // times the sliver's height, and the contacts' accumulated multipliers
    // hold the vertices on the plane against the volume correction (each
    // iteration releases only the correction's share). So |C| reaches
    // |rest| — the sliver goes flat — but it never inverts (|C| would be
    // 2 |rest|) and never throws a vertex away. Bound: |rest| plus the
    // rounding of the determinant, ε · 56 · Π|e_j| / 3! (docs/bounds.md's
    // measure model, N = 3, k = 3).
    let rest = tet_volume(&initial.positions).abs();
    let edges = [1.0, 1.0, (0.18f64).sqrt()];
    let rounding = epsilon(kind) * 56.0 * edges.iter().product::<f64>() / 6.0;
    check_residual(
        case,
        kind,
        "max |C| volume (m^3)",
        m.measure_residual,
        rest + rounding,
        "flattened on the plane, never inverted: |rest| + determinant rounding",
    );
}

/// A soft 2 × 2 × 2 Kuhn block (48 rigid tetrahedra with rigid edges) whose
/// centre node starts pushed through a face, inverting the tetrahedra
/// around it (rest values from the undisturbed block). The volume
/// constraints must turn them back, not explode.
fn oriented_inverted(kind: BackendKind) {
    let case = "oriented_inverted";
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(4)
        .gravity_along(1, 9.81);
    let grid = b.soft_block(&BlockSpec {
        cells: vec![2, 2, 2],
        origin: vec![-0.5, 0.1, -0.5],
        spacing: 0.5,
        mass: 0.1,
        compliance: 0.0,
        edge_compliance: Some(0.0),
    });
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.5);
    let scene = b.build().expect("valid");
    let plan = Plan::compile(&scene).expect("compiles");
    let mut initial = State::from_scene(&scene);
    // The centre node (1, 1, 1) moves 0.75 m along +x: through the face at
    // x = 0.5 of the cells on its +x side.
    let centre = grid.index(&[1, 1, 1]);
    initial.positions[3 * centre] += 0.75;
    let inverted = count_inverted(&plan, &initial);
    assert!(inverted > 0, "the test must start with inverted tetrahedra");
    let Some(mut backend) =
        load_or_skip(case, kind, plan.clone(), &initial).unwrap_or_else(|e| panic!("{case}: {e}"))
    else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 120);
    // Starting violated: the correction of the displaced node, up to its
    // 0.75 m displacement in one substep, may become kinetic energy.
    let h = plan.h;
    let released = 0.5 * 0.1 * (0.75 / h) * (0.75 / h);
    check_energy(
        case,
        kind,
        &m,
        released,
        "starts violated: ½ m (0.75 m / h)² may be released",
    );
    let left = count_inverted(&plan, &m.last) as f64;
    report(
        case,
        kind,
        "ok",
        "inverted tets at start / end",
        left,
        &format!("0 of {inverted} ({inverted} at the start)"),
    );
    assert_eq!(left, 0.0, "{case}: tetrahedra left inverted");
    // It starts 0.75 m violated, so the residual is judged after the 2 s.
    check_residual(
        case,
        kind,
        "|C| edges + contact after 2 s (m)",
        m.final_residual,
        0.01 * 0.5,
        "1% of the 0.5 m cell edge",
    );
}

/// Elements of the plan's oriented family whose signed volume has the
/// opposite sign of its rest value.
fn count_inverted(plan: &Plan, state: &State) -> usize {
    let family = plan
        .families
        .iter()
        .find(|f| f.kind == FamilyKind::OrientedMeasure)
        .expect("oriented family");
    let mut points = vec![0.0; 12];
    family
        .elements
        .chunks_exact(4)
        .zip(&family.rest)
        .filter(|(element, rest)| {
            for (j, &i) in element.iter().enumerate() {
                points[3 * j..3 * j + 3].copy_from_slice(state.position(i as usize));
            }
            tet_volume(&points) * **rest < 0.0
        })
        .count()
}

/// An oriented rest measure of zero (a collapsed simplex) has no
/// orientation to preserve: a typed refusal, the same for every backend
/// (validation runs before any backend sees the scene).
fn oriented_zero_rest_refused(kind: BackendKind) {
    let case = "oriented_zero_rest_refused";
    let mut b = SceneBuilder::new(2);
    for p in [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]] {
        b.particle(Particle::new(p.to_vec(), 1.0));
    }
    b.family(ConstraintFamily::new(
        ConstraintKind::OrientedMeasure,
        0.0,
        vec![vec![0, 1, 2]],
    ));
    let error = Plan::compile(b.scene()).expect_err("a collinear triangle must be refused");
    assert!(
        matches!(error, SceneError::DegenerateRest { .. }),
        "{error:?}"
    );
    report(
        case,
        kind,
        "refused: SceneError::DegenerateRest",
        "-",
        0.0,
        &error.to_string(),
    );
}

/// Two distance elements with rest 0.5 m whose particles start
/// coincident: pair A at rest (∇C does not exist: the element makes no
/// response and stays violated by exactly its rest length — DESIGN: no
/// invented direction), pair B with one particle moving at 1 m/s (after
/// the first prediction the direction exists and the link is restored).
fn coincident_distance(kind: BackendKind) {
    let case = "coincident_distance";
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(2)
        .gravity_along(1, 9.81);
    b.particle(Particle::new(vec![0.0, 1.0, 0.0], 1.0));
    b.particle(Particle::new(vec![0.0, 1.0, 0.0], 1.0));
    b.particle(Particle::new(vec![2.0, 1.0, 0.0], 1.0));
    b.particle(Particle::new(vec![2.0, 1.0, 0.0], 1.0).with_velocity(vec![1.0, 0.0, 0.0]));
    let mut a = ConstraintFamily::new(ConstraintKind::Distance, 0.0, vec![vec![0, 1]]);
    a.rest = Some(vec![0.5]);
    let mut pair_b = ConstraintFamily::new(ConstraintKind::Distance, 0.0, vec![vec![2, 3]]);
    pair_b.rest = Some(vec![0.5]);
    b.family(a);
    b.family(pair_b);
    let scene = b.build().expect("coincident particles are valid input");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let steps = 60;
    let mut last = None;
    let mut energy_gain: f64 = f64::NEG_INFINITY;
    let mut energy_scale: f64 = 0.0;
    for step in 0..steps {
        let r = backend
            .step()
            .unwrap_or_else(|e| panic!("{case}: step {step}: {e}"));
        let s = backend.read_state().expect("read_state");
        assert!(
            s.positions
                .iter()
                .chain(&s.velocities)
                .all(|c| c.is_finite())
        );
        let (gain, scale) = energy(backend.plan(), &initial, &s);
        energy_gain = energy_gain.max(gain);
        energy_scale = energy_scale.max(scale);
        last = Some(r);
    }
    let r = last.expect("steps ran");
    let pair_a = r.residuals[0].max_violation;
    let pair_b = r.residuals[1].max_violation;
    // Pair B starts violated by 0.5 m: restoring it in one substep may
    // release ½ (m/2) (0.5 m / h)² (the reduced mass of the pair).
    let h = backend.plan().h;
    let released = 0.5 * 0.5 * (0.5 / h) * (0.5 / h);
    let m = Measured {
        energy_gain,
        energy_scale,
        residual: 0.0,
        measure_residual: 0.0,
        final_residual: 0.0,
        last: initial,
    };
    check_energy(
        case,
        kind,
        &m,
        released,
        "pair B starts 0.5 m short: ½ (m/2) (0.5 m / h)² may be released",
    );
    report(
        case,
        kind,
        "ok",
        "pair A (coincident, at rest) |C| (m)",
        pair_a,
        "= rest 0.5 (no direction exists: no response, by design)",
    );
    assert_eq!(pair_a, 0.5, "{case}: a coincident pair makes no response");
    check_residual(
        case,
        kind,
        "pair B (coincident, moving) |C| at the end (m)",
        pair_b,
        0.005,
        "1% of the 0.5 m rest length",
    );
}
