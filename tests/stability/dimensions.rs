//! R^8, R^9 (CPU only), the empty scene and one particle.

use super::*;

on_every_backend!(eight_dimensions, nine_dimensions, empty_scene, one_particle,);

/// R^8: a 3 × 3 sheet (edges, shear, and its triangles as a squared-area
/// family) and a soft 8-simplex with rigid edges, dropped onto a tilted
/// hyperplane with friction, damped, 2 s, 10 substeps × 4 iterations.
///
/// Measured while writing this: with 1 or 2 iterations the rigid
/// 8-simplex (36 coupled edges in 9 colors) gains energy after it lands
/// (+307 J at 2 iterations, the edges left 3 cm off): Gauss–Seidel stopped
/// that far from convergence turns the unconverged edge corrections into
/// velocity every substep. From 4 iterations on it is dissipative; the
/// docs/stability.md says so.
fn eight_dimensions(kind: BackendKind) {
    let case = "eight_dimensions";
    let dim = 8;
    let mut b = SceneBuilder::new(dim)
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(4)
        .gravity_along(7, 9.81)
        .damping(0.5);
    let mut sheet = GridSpec::cloth(3, 3, 0.25, 0.0);
    sheet.axes = vec![0, 1];
    sheet.origin = vec![0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.6];
    sheet.mass = 0.1;
    let grid = b.grid(&sheet);
    let mut triangles = Vec::new();
    for i in 0..2 {
        for j in 0..2 {
            let (a, c, d, e) = (
                grid.index(&[i, j]),
                grid.index(&[i + 1, j]),
                grid.index(&[i, j + 1]),
                grid.index(&[i + 1, j + 1]),
            );
            triangles.push(vec![a, c, d]);
            triangles.push(vec![c, e, d]);
        }
    }
    b.family(ConstraintFamily::new(
        ConstraintKind::SimplexMeasure,
        1e-6,
        triangles,
    ));
    let first = b.scene().particles.len();
    for k in 0..=dim {
        let mut x = vec![1.0; dim];
        x[7] = 1.0;
        if k > 0 {
            x[k - 1] += 0.3;
        }
        b.particle(Particle::new(x, 0.05).with_radius(0.02));
    }
    let simplex: Vec<usize> = (first..=first + dim).collect();
    b.family(ConstraintFamily::new(
        ConstraintKind::OrientedMeasure,
        1e-8,
        vec![simplex.clone()],
    ));
    let mut edges = Vec::new();
    for (a, &i) in simplex.iter().enumerate() {
        for &j in &simplex[a + 1..] {
            edges.push(vec![i, j]);
        }
    }
    b.family(ConstraintFamily::new(ConstraintKind::Distance, 0.0, edges));
    let mut normal = vec![0.05; dim];
    normal[7] = 1.0;
    b.hyperplane(normal, 0.0, 0.4);
    let scene = b.build().expect("valid");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 120);
    check_energy(case, kind, &m, 0.0, "dissipative: starts at rest");
    check_residual(
        case,
        kind,
        "max |C| (m)",
        m.residual,
        0.01 * 0.25,
        "1% of the 0.25 m sheet link",
    );
}

/// R^9: the CPU runs it (a falling particle on a plane); the GPU kernels
/// are generated for dimensions 1..=8 and refuse it with a typed
/// `GpuError::Unsupported` — never a fallback.
fn nine_dimensions(kind: BackendKind) {
    let case = "nine_dimensions";
    let dim = 9;
    let mut b = SceneBuilder::new(dim)
        .dt(1.0 / 60.0)
        .substeps(4)
        .gravity_along(8, 9.81);
    let mut up = vec![0.0; dim];
    up[8] = 1.0;
    b.hyperplane(up, 0.0, 0.3);
    let mut x = vec![0.0; dim];
    x[8] = 0.5;
    b.particle(Particle::new(x, 1.0).with_radius(0.01));
    let scene = b.build().expect("valid");
    let plan = Plan::compile(&scene).expect("valid");
    let initial = State::from_scene(&scene);
    match load_or_skip(case, kind, plan, &initial) {
        Ok(None) => {}
        Ok(Some(mut backend)) => {
            assert_eq!(kind, BackendKind::Cpu, "only the CPU runs R^9");
            let m = run(case, backend.as_mut(), &initial, 60);
            check_energy(case, kind, &m, 0.0, "inelastic landing");
            check_residual(
                case,
                kind,
                "max penetration (m)",
                m.residual,
                8.0 * epsilon(kind),
                "rounding of n·x at |x| ≤ 1 m",
            );
        }
        Err(e) => {
            assert_ne!(kind, BackendKind::Cpu);
            assert!(
                matches!(e, BackendError::Gpu(GpuError::Unsupported { .. })),
                "{e:?}"
            );
            report(
                case,
                kind,
                "refused: GpuError::Unsupported",
                "-",
                0.0,
                &e.to_string(),
            );
        }
    }
}

/// No particles at all: the plan has no kernels; steps succeed and change
/// nothing.
fn empty_scene(kind: BackendKind) {
    let case = "empty_scene";
    let scene = SceneBuilder::new(3)
        .gravity_along(1, 9.81)
        .build()
        .expect("valid");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 5);
    assert!(m.last.is_empty());
    report(case, kind, "ok", "particles after 5 steps", 0.0, "0");
}

/// One particle thrown onto a plane with friction: it lands, slides,
/// stops.
fn one_particle(kind: BackendKind) {
    let case = "one_particle";
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(8)
        .gravity_along(1, 9.81);
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.5);
    b.particle(
        Particle::new(vec![0.1, 0.3, -0.2], 0.7)
            .with_velocity(vec![1.5, 0.0, 0.5])
            .with_radius(0.02),
    );
    let scene = b.build().expect("valid");
    let Some((mut backend, initial)) = start(case, kind, &scene) else {
        return;
    };
    let m = run(case, backend.as_mut(), &initial, 90);
    check_energy(case, kind, &m, 0.0, "inelastic landing, friction");
    check_residual(
        case,
        kind,
        "max penetration (m)",
        m.residual,
        8.0 * epsilon(kind) * 1.0,
        "rounding of n·x at |x| ≤ 1 m",
    );
}
