//! Friction on simplex meshes on the implicit path (issue 31 item 4):
//! the lagged friction of the hyperplanes (docs/implicit.md §7), with the
//! lag's normal (x^t − q)/|x^t − q| of each simplex within d^ at x^t.
//! Closed forms on the golden path — a particle sliding on a flat
//! triangulated square decelerates by μ λ/m ≈ μ g per unit time, a particle
//! on a triangulated incline under the friction angle stays, over it
//! slides at g (sin θ − μ cos θ) — the mesh against the hyperplane at its
//! height, the contact force of the mesh's friction, the new key's
//! validation, and gpu-f64 = golden bit for bit.
//! `cargo test --release --test implicit -- mesh_friction:: --nocapture | grep '^BOUND'`.

use crate::common;

use common::bound::{check_bound, print_bound};
use common::exact::{bits, f64_identical};
use common::gpu::adapter_or_skip;
use common::implicit_scenes::{G, balls_in_a_v, incline, particle, settings};
use hyperpbd::builders::triangle_grid;
use hyperpbd::core::barrier::BarrierLaw;
use hyperpbd::core::implicit::closed_forms::{
    barrier_gap_under_load, incline_acceleration, sticking_creep_speed,
};
use hyperpbd::{
    Backend, CpuBackend, MinimisationStatus, Obstacle, Plan, Scene, SceneError, Solver, State,
};

/// The law of the flat scenes (as the incline's: κ = 1e5, d^ = 1 mm).
const LAW: BarrierLaw = BarrierLaw {
    stiffness: 1e5,
    activation_distance: 1e-3,
};
/// The acceleration criterion's tolerance of every scene here (m/s²).
const TOLERANCE: f64 = 1e-4;
/// Height of the flat mesh / plane.
const HEIGHT: f64 = 0.5;
/// Radius of the sliding particle.
const RADIUS: f64 = 0.05;

/// A 1 kg ball (radius 5 cm) at rest height over y = `HEIGHT` in R^3,
/// moving at (2, 0, 1) m/s: on a 10 m triangulated square of `cells` ×
/// `cells` cells (2 cells² triangles) with μ, or (`cells` = 0) on the
/// hyperplane y = `HEIGHT` with μ. With one cell the slide (0.85 m, from
/// (−1.13, −0.41) along (2, 0, 1)) stays inside one triangle (x + z < 0).
fn flat(mu: f64, cells: usize) -> Scene {
    let mesh = (cells > 0).then(|| {
        let spacing = 10.0 / cells as f64;
        let grid = triangle_grid(3, [0, 2], cells + 1, spacing);
        shifted(grid, &[-5.0, HEIGHT, -5.0], mu)
    });
    sliding(vec![-1.13, 0.0, -0.41], vec![2.0, 0.0, 1.0], mu, mesh, 50)
}

/// A 1 kg ball (radius 5 cm) at `at` lifted to rest height over
/// y = `HEIGHT` (gravity −G along y), moving at `velocity`, on `mesh` or
/// (`None`) the hyperplane y = `HEIGHT`, with μ; Newton budget `budget`.
fn sliding(
    at: Vec<f64>,
    velocity: Vec<f64>,
    mu: f64,
    mesh: Option<Obstacle>,
    budget: u32,
) -> Scene {
    let dim = at.len();
    let gap = barrier_gap_under_load(&LAW, G).expect("a gap");
    let mut scene = Scene::new(dim, 1.0 / 60.0, 1, 1);
    let mut up = vec![0.0; dim];
    up[1] = 1.0;
    scene.gravity = Some((0..dim).map(|a| if a == 1 { -G } else { 0.0 }).collect());
    let mut position = at;
    position[1] = HEIGHT + RADIUS + gap;
    let mut p = particle(position, Some(1.0), RADIUS);
    p.velocity = Some(velocity);
    scene.particles.push(p);
    scene.obstacles.push(mesh.unwrap_or(Obstacle::Hyperplane {
        normal: up,
        offset: HEIGHT,
        friction: mu,
        compliance: 0.0,
        motion: Vec::new(),
    }));
    scene.solver = Solver::IncrementalPotential(settings(
        LAW.stiffness,
        LAW.activation_distance,
        TOLERANCE,
        budget,
    ));
    scene
}

/// `mesh` moved by `by`, with friction μ.
fn shifted(mesh: Obstacle, by: &[f64], mu: f64) -> Obstacle {
    let Obstacle::SimplexMesh {
        vertices,
        simplices,
        ..
    } = mesh
    else {
        unreachable!("a simplex mesh")
    };
    Obstacle::SimplexMesh {
        vertices: vertices
            .into_iter()
            .map(|v| v.iter().zip(by).map(|(a, b)| a + b).collect())
            .collect(),
        simplices,
        friction: mu,
        motion: Vec::new(),
    }
}

/// The incline of `tests/implicit_step.rs` (20°, R^2) with its plane
/// replaced by a chain of `segments` segments along it, 4 m in all,
/// centred on 0 (one segment: no vertex on the way of a 1 s slide).
fn mesh_incline(mu: f64, segments: usize) -> (Scene, f64) {
    let (mut scene, angle) = incline(mu);
    let (c, s) = (angle.cos(), angle.sin());
    let step = 4.0 / segments as f64;
    let vertices = (0..=segments)
        .map(|k| {
            let t = k as f64 * step - 2.0;
            vec![t * c, t * s]
        })
        .collect();
    let simplices = (0..segments).map(|k| vec![k, k + 1]).collect();
    scene.obstacles = vec![Obstacle::SimplexMesh {
        vertices,
        simplices,
        friction: mu,
        motion: Vec::new(),
    }];
    (scene, angle)
}

fn backend(scene: &Scene) -> CpuBackend {
    common::cpu_backend(scene, 1)
}

/// Steps `scene` `frames` times; `each(frame, before, after, statuses)`.
fn run(scene: &Scene, frames: usize, mut each: impl FnMut(usize, &State, &State)) -> State {
    let mut b = backend(scene);
    let mut before = b.read_state().expect("state");
    for frame in 0..frames {
        let report = b.step().unwrap_or_else(|e| panic!("frame {frame}: {e}"));
        for m in &report.minimisation {
            assert_eq!(
                m.status,
                MinimisationStatus::Converged,
                "frame {frame}: the residual bounds below assume the criterion was met"
            );
        }
        let after = b.read_state().expect("state");
        each(frame, &before, &after);
        before = after;
    }
    before
}

/// |v| without its y (normal) component.
fn tangential_speed(s: &State) -> f64 {
    let v = &s.velocities;
    (v.iter().map(|c| c * c).sum::<f64>() - v[1] * v[1]).sqrt()
}

/// The slide of `scene` (one 1 kg ball at rest height over a flat floor
/// y = `HEIGHT`, initial velocity `v0` tangential) over `frames` frames
/// against the closed form of Coulomb friction μ.
fn check_slide(what: &str, scene: &Scene, mu: f64, frames: usize) {
    // Per step, the criterion |∇F_i|/(m h²) ≤ tol and the sliding branch
    // (slip ≫ ε_v h) give m Δv_t/h = −μ λ û + e, |e| ≤ m tol, û ∥ v_t':
    // | |v_t| − |v_t'| − h μ λ/m | ≤ h tol (+ the rounding of v = Δx/h,
    // a few ε |x|/h ≈ 1e-13), λ = −b'(d(x^t)) the lag's normal force.
    let h = scene.dt;
    let v0 = scene.particles[0].velocity.clone().expect("moving");
    let speed0 = v0.iter().map(|c| c * c).sum::<f64>().sqrt();
    let (mut worst_step, mut worst_load) = (0.0f64, 0.0f64);
    let end = run(scene, frames, |_, before, after| {
        let d = before.positions[1] - HEIGHT - RADIUS;
        let lambda = -LAW.evaluate(d).1;
        let drop = tangential_speed(before) - tangential_speed(after);
        worst_step = worst_step.max((drop - h * mu * lambda).abs());
        worst_load = worst_load.max((lambda - G).abs());
    });
    check_bound(
        &format!("mesh friction, {what}: max | |v_t| − |v_t'| − h μ λ_lag/m | per step (m/s)"),
        worst_step,
        h * TOLERANCE + 1e-12,
        "h · tolerance (the criterion) + the rounding of Δx/h",
    );
    // Over T: | |v_t(T)| − (|v_t(0)| − μ g T) | ≤ T (μ max|λ/m − g| + tol).
    let t = frames as f64 * h;
    let exact = speed0 - mu * G * t;
    assert!(exact > 0.0, "still sliding at T");
    check_bound(
        &format!("mesh friction, {what}: | |v_t(T)| − (|v_0| − μ g T) | at T = {t:.2} s (m/s)"),
        (tangential_speed(&end) - exact).abs(),
        t * (mu * worst_load + TOLERANCE) + 1e-12,
        "T (μ max|λ_lag/m − g| + tolerance): the lag carries the weight to the barrier's accuracy",
    );
    print_bound(
        format!("mesh friction, {what}: max |λ_lag/m − g| (m/s²)"),
        format_args!("{worst_load:e}"),
        "reported",
        "the normal force of the lag against the weight",
    );
    // Direction kept: friction opposes the slip over the whole tangent
    // ball (no per-axis clamp), so only the criterion's error e turns it:
    // the part of v(T) across v_0 is at most Σ|e| ≤ T tol.
    let along: f64 = end
        .velocities
        .iter()
        .zip(&v0)
        .map(|(a, b)| a * b)
        .sum::<f64>()
        / speed0;
    let across = (end.velocities.iter().map(|c| c * c).sum::<f64>() - along * along)
        .max(0.0)
        .sqrt();
    check_bound(
        &format!("mesh friction, {what}: |v(T) across v_0| (m/s)"),
        across,
        t * TOLERANCE,
        "T tol: friction is antiparallel to the slip over the whole tangent ball",
    );
}

#[test]
fn sliding_on_a_flat_mesh_decelerates_at_mu_g() {
    // 40 frames, 0.67 s; it stops at √5/(μ g) = 0.76 s.
    check_slide("flat R^3", &flat(0.3, 1), 0.3, 40);
}

/// The R^4 slide: a 1 kg ball (radius 5 cm) at rest height over
/// y = `HEIGHT`, moving at (2, 0, 1, −1) m/s from (3, ·, 0, −3), on the
/// cube [−5, 5]³ of the (x, z, w) hyperplane cut into its six Kuhn
/// tetrahedra (μ), or (`mesh` false) on the hyperplane y = `HEIGHT`. The
/// 1.02 m slide stays in the tetrahedron u_x ≥ u_z ≥ u_w.
fn flat4(mu: f64, mesh: bool) -> Scene {
    let mesh = mesh.then(|| {
        // Cube corner c (bits over x, z, w) at 10 c − 5.
        let vertices = (0..8)
            .map(|c: usize| {
                let at = |bit: usize| if c >> bit & 1 == 1 { 5.0 } else { -5.0 };
                vec![at(0), HEIGHT, at(1), at(2)]
            })
            .collect();
        let orders = [
            [0, 1, 2],
            [0, 2, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 0, 1],
            [2, 1, 0],
        ];
        let simplices = orders
            .iter()
            .map(|o| vec![0, 1 << o[0], (1 << o[0]) | (1 << o[1]), 7])
            .collect();
        Obstacle::SimplexMesh {
            vertices,
            simplices,
            friction: mu,
            motion: Vec::new(),
        }
    });
    // A simplex's step filter is the Lipschitz one, t* = d0/|Δ| (a
    // hyperplane's is exact): a 4 cm tangential step from d0 ≈ 0.8 mm
    // advances a few % per Newton iteration, so ~50 iterations a step
    // here (the hyperplane takes 2); the budget leaves room.
    let (at, velocity) = (vec![3.0, 0.0, 0.0, -3.0], vec![2.0, 0.0, 1.0, -1.0]);
    sliding(at, velocity, mu, mesh, 400)
}

#[test]
fn sliding_on_tetrahedra_in_r4_decelerates_at_mu_g() {
    // √6/(μ g) = 0.83 s to rest; 45 frames = 0.75 s.
    check_slide("flat R^4 (tetrahedra)", &flat4(0.3, true), 0.3, 45);
    let frames = 60;
    check_bound(
        "mesh vs hyperplane, R^4 tetrahedra μ=0.3: max |Δx| over 1 s (m)",
        apart(&flat4(0.3, true), &flat4(0.3, false), frames),
        TOLERANCE,
        "tol T²",
    );
}

#[test]
fn a_mesh_slope_under_the_friction_angle_holds() {
    // μ = 0.5 > tan 20°: the smoothed static branch creeps at the closed
    // form ε_v (1 − √(1 − tan θ/μ)); over T = 1 s, plus ½ tol T² for the
    // criterion's acceleration error.
    let (scene, angle) = mesh_incline(0.5, 40);
    let creep = sticking_creep_speed(1e-3, angle, 0.5).expect("sticks");
    let end = run(&scene, 60, |_, _, _| {});
    let start = &scene.particles[0].position;
    let slid = -((end.positions[0] - start[0]) * angle.cos()
        + (end.positions[1] - start[1]) * angle.sin());
    check_bound(
        "mesh friction, incline μ=0.5 > tan 20°: creep after 1 s (m)",
        slid.abs(),
        creep * 1.0 + 0.5 * TOLERANCE,
        "ε_v (1 − √(1 − tan θ/μ)) T + ½ tol T²",
    );
}

#[test]
fn a_mesh_slope_over_the_friction_angle_slides_at_the_coulomb_acceleration() {
    // 40 segments of 0.1 m: the slide crosses nine vertices.
    let (scene, angle) = mesh_incline(0.2, 40);
    let end = run(&scene, 60, |_, _, _| {});
    let start = &scene.particles[0].position;
    let slid = -((end.positions[0] - start[0]) * angle.cos()
        + (end.positions[1] - start[1]) * angle.sin());
    let exact = 0.5 * incline_acceleration(G, angle, 0.2);
    check_bound(
        "mesh friction, incline μ=0.2 < tan 20°: |s − ½ g (sin θ − μ cos θ) t²| / that, t = 1 s",
        (slid - exact).abs() / exact,
        0.02,
        "as the hyperplane's (tests/implicit_step.rs): backward Euler's lag",
    );
}

/// max |x_a − x_b| over `frames` frames of two scenes stepped together.
fn apart(a: &Scene, b: &Scene, frames: usize) -> f64 {
    let (mut p, mut q) = (backend(a), backend(b));
    let mut worst = 0.0f64;
    for frame in 0..frames {
        p.step().unwrap_or_else(|e| panic!("a, frame {frame}: {e}"));
        q.step().unwrap_or_else(|e| panic!("b, frame {frame}: {e}"));
        let (x, y) = (p.read_state().expect("a"), q.read_state().expect("b"));
        worst = worst.max(hyperpbd_verify::compare::max_abs_diff(
            &x.positions,
            &y.positions,
        ));
    }
    worst
}

#[test]
fn a_mesh_with_friction_moves_as_the_hyperplane_at_its_height() {
    // The mesh's distance and lag normal are the plane's up to rounding;
    // each step's minimiser stops within tol of the exact acceleration, so
    // two runs differ by at most 2 tol in acceleration per step:
    // |x_mesh − x_plane| ≤ tol T² over T (both stop by the same criterion).
    let frames = 60;
    let t = frames as f64 / 60.0;
    let bound = TOLERANCE * t * t;
    let flat_apart = apart(&flat(0.3, 1), &flat(0.3, 0), frames);
    check_bound(
        "mesh vs hyperplane, flat μ=0.3 (slides, stops at 0.76 s): max |Δx| over 1 s (m)",
        flat_apart,
        bound,
        "tol T²",
    );
    // On a fine grid the slide crosses edges: where two triangles are
    // within d^ of x each has its own barrier (and so its own lag), as a
    // mesh without friction already does; reported, not a plane's bound.
    let fine = apart(&flat(0.3, 20), &flat(0.3, 0), frames);
    print_bound(
        "mesh vs hyperplane, flat μ=0.3 on a 20 × 20 grid (edges crossed): max |Δx| over 1 s (m)",
        format_args!("{fine:e}"),
        "reported",
        "each triangle within d^ of an edge carries its own barrier and lag",
    );
    let chain = apart(&mesh_incline(0.2, 40).0, &incline(0.2).0, frames);
    print_bound(
        "mesh vs hyperplane, incline μ=0.2 on 40 segments (nine vertices crossed): max |Δx| over 1 s (m)",
        format_args!("{chain:e}"),
        "reported",
        "both segments at a vertex carry a barrier and a lag",
    );
    for mu in [0.5, 0.2] {
        let (mesh, _) = mesh_incline(mu, 1);
        let (plane, _) = incline(mu);
        check_bound(
            &format!("mesh vs hyperplane, incline μ={mu}: max |Δx| over 1 s (m)"),
            apart(&mesh, &plane, frames),
            bound,
            "tol T²",
        );
    }
}

#[test]
fn the_mesh_reports_its_friction_as_contact_force() {
    // Held on the incline (μ = 0.5), the mesh's force on the particle is
    // its weight's opposite: normal m g cos θ, friction m g sin θ, to the
    // criterion's tol (m tol, relative tol/g) once at rest.
    let (scene, angle) = mesh_incline(0.5, 40);
    let plan = Plan::compile(&scene).expect("valid");
    let mut b = CpuBackend::with_threads(plan, &State::from_scene(&scene), 1).expect("loads");
    b.request_contact_forces(true)
        .expect("the CPU reports forces");
    let mut last = None;
    for _ in 0..60 {
        last = b.step().expect("step").contact_forces;
    }
    let f = last.expect("reported");
    let push = f.obstacle(0);
    let (n, along) = ([-angle.sin(), angle.cos()], [angle.cos(), angle.sin()]);
    let normal = push[0] * n[0] + push[1] * n[1];
    let friction = push[0] * along[0] + push[1] * along[1];
    let bound = TOLERANCE / G + 1e-12;
    check_bound(
        "mesh friction force: |normal − m g cos θ| / m g",
        (normal - G * angle.cos()).abs() / G,
        bound,
        "tol/g: the accepted iterate's residual",
    );
    check_bound(
        "mesh friction force: |friction − m g sin θ| / m g (up the slope)",
        (friction - G * angle.sin()).abs() / G,
        bound,
        "tol/g: the accepted iterate's residual",
    );
    let own = f.particle(0);
    assert!(
        (own[0] - push[0]).abs() <= 1e-12 * G && (own[1] - push[1]).abs() <= 1e-12 * G,
        "the particle's force is the mesh's: {own:?} vs {push:?}"
    );
}

#[test]
fn mesh_friction_is_validated_with_its_path() {
    let json = |friction: &str| {
        format!(
            r#"{{"dim": 2, "dt": 0.01, "particles": [{{"position": [0, 1], "mass": 1}}], "obstacles": [{{"type": "simplex_mesh", "vertices": [[-1, 0], [1, 0]], "simplices": [[0, 1]], "friction": {friction}}}], "solver": {{"type": "incremental_potential", "barrier_stiffness": 100, "activation_distance": 0.1, "convergence": {{"kind": "packed_gradient", "tolerance": 1e-8}}, "max_iterations": 20}}}}"#
        )
    };
    match Scene::from_json_str(&json("-0.5")) {
        Err(SceneError::NegativeFriction { path, value }) => {
            assert_eq!((path.as_str(), value), ("obstacles[0].friction", -0.5));
        }
        other => panic!("{other:?}"),
    }
    let scene = Scene::from_json_str(&json("0.4")).expect("valid");
    let plan = Plan::compile(&scene).expect("compiles");
    let coupled = plan
        .incremental_potential()
        .and_then(|ip| ip.coupled.as_ref())
        .expect("mesh friction is a term of the coupled step");
    assert_eq!(coupled.simplex_friction, vec![0.4]);
    assert!(coupled.plane_friction.is_empty());
    let text = scene.to_json_string();
    assert!(text.contains("\"friction\":0.4"), "{text}");
    assert_eq!(Scene::from_json_str(&text).expect("reads"), scene);
    // Without friction: no coupled term, and the key is not written.
    let plain = Scene::from_json_str(&json("0")).expect("valid");
    let plan = Plan::compile(&plain).expect("compiles");
    assert!(plan.incremental_potential().expect("ip").coupled.is_none());
    assert!(!plain.to_json_string().contains("friction"));
    let mut bad = scene.clone();
    if let Obstacle::SimplexMesh { friction, .. } = &mut bad.obstacles[0] {
        *friction = f64::NAN;
    }
    match bad.validate() {
        Err(SceneError::NonFinite { path, .. }) => assert_eq!(path, "obstacles[0].friction"),
        other => panic!("{other:?}"),
    }
    // Offset and compliance are still not mesh keys.
    let offset = json("0.4").replace(r#""friction": 0.4"#, r#""offset": 1"#);
    let err = Scene::from_json_str(&offset)
        .expect_err("no offset")
        .to_string();
    assert!(
        err.starts_with("obstacles[0]: a simplex_mesh takes only"),
        "{err}"
    );
}

/// Steps `scene` on the golden path and on gpu-f64; on an exact adapter
/// (lavapipe) every state and every minimisation report is the same bits.
fn gpu_f64_is_golden(test: &str, scene: &Scene, frames: usize) {
    use hyperpbd_gpu::{GpuCoupledBackend, Precision};
    let Some((adapter, summary)) = adapter_or_skip(test, Precision::F64) else {
        return;
    };
    let plan = Plan::compile(scene).expect("compiles");
    let mut cpu = backend(scene);
    let mut gpu =
        GpuCoupledBackend::with_adapter(&adapter, plan, &State::from_scene(scene), Precision::F64)
            .expect("the GPU takes the coupled step");
    let exact = f64_identical(&summary);
    let mut worst = 0.0f64;
    for frame in 0..frames {
        let a = cpu
            .step()
            .unwrap_or_else(|e| panic!("{test}: cpu {frame}: {e}"));
        let b = gpu
            .step()
            .unwrap_or_else(|e| panic!("{test}: gpu {frame}: {e}"));
        let (x, y) = (
            cpu.read_state().expect("cpu"),
            gpu.read_state().expect("gpu"),
        );
        worst = worst.max(hyperpbd_verify::compare::max_abs_diff(
            &x.positions,
            &y.positions,
        ));
        if exact {
            assert!(bits(&x) == bits(&y), "{test}: frame {frame}: states differ");
            assert_eq!(a.minimisation, b.minimisation, "{test}: frame {frame}");
        }
    }
    let bound = if exact { 0.0 } else { TOLERANCE };
    check_bound(
        &format!("gpu-f64 mesh friction {test}: max |x_gpu − x_cpu| over {frames} frames (m)"),
        worst,
        bound,
        if exact {
            "bit for bit on a non-contracting adapter"
        } else {
            "an adapter that may contract: the criterion's scale"
        },
    );
}

#[test]
fn gpu_f64_mesh_friction_is_the_golden_path() {
    gpu_f64_is_golden("flat_slide", &flat(0.3, 20), 20);
    gpu_f64_is_golden("incline_stick", &mesh_incline(0.5, 40).0, 20);
    gpu_f64_is_golden("incline_slide", &mesh_incline(0.2, 40).0, 20);
    // Springs, ball pairs and two lags at the V's vertex.
    let mut v = balls_in_a_v();
    if let Obstacle::SimplexMesh { friction, .. } = &mut v.obstacles[0] {
        *friction = 0.4;
    }
    gpu_f64_is_golden("v_of_segments", &v, 40);
}
