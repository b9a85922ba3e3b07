//! The incremental-potential (barrier) path on the CPU golden backend:
//! closest points, the barrier law, the step filter, the seed's
//! backward-Euler example for both criteria, drops that must never reach
//! d ≤ 0, resting contact, sliding over a 4D triangle mesh, validation.
//!
//! Every bound is printed as `BOUND | name | measured | bound | rationale`.

mod common;

use common::Lcg;
use hyperpbd::barrier::{
    BarrierLaw, BarrierObstacles, FILTER_SAFETY, ParticleBarrier, evaluate_particle_barrier,
    filter_fraction,
};
use hyperpbd::geometry::closest_point_on_simplex;
use hyperpbd::{
    Backend, BackendError, Convergence, CpuBackend, IncrementalPotentialSettings, Kernel,
    MinimisationStatus, Obstacle, Particle, Plan, Scene, SceneError, Solver, StageName, State,
    StepError,
};

fn bound(name: &str, measured: f64, limit: f64, why: &str) {
    println!("BOUND | {name} | {measured:e} | {limit:e} | {why}");
    assert!(
        measured <= limit,
        "{name}: {measured:e} > {limit:e} ({why})"
    );
}

fn ip(kappa: f64, dhat: f64, convergence: Convergence, max_iterations: u32) -> Solver {
    Solver::IncrementalPotential(IncrementalPotentialSettings {
        barrier_stiffness: kappa,
        activation_distance: dhat,
        convergence,
        max_iterations,
    })
}

fn plane(normal: Vec<f64>, offset: f64) -> Obstacle {
    Obstacle::Hyperplane {
        normal,
        offset,
        friction: 0.0,
        compliance: 0.0,
    }
}

fn cpu(scene: &Scene) -> CpuBackend {
    let plan = Plan::compile(scene).expect("valid scene");
    CpuBackend::new(plan, &State::from_scene(scene)).expect("backend")
}

/// Smallest d over every free particle and obstacle of `scene` at `state`.
fn min_distance(scene: &Scene, state: &State) -> f64 {
    let obstacles = BarrierObstacles::compile(scene);
    let mut n = vec![0.0; scene.dim];
    let mut d = f64::INFINITY;
    for (i, p) in scene.particles.iter().enumerate() {
        for o in 0..obstacles.len() {
            d = d.min(obstacles.distance(o, state.position(i), p.radius, &mut n));
        }
    }
    d
}

// ---------------------------------------------------------------------------
// Closest point
// ---------------------------------------------------------------------------

/// q is the closest point of a convex set S to p iff (p − q)·(y − q) ≤ 0
/// for every y in S; for a simplex it suffices to check the vertices. The
/// witness must be a convex combination reproducing q.
#[test]
fn closest_point_satisfies_the_variational_inequality_in_r4() {
    let dim = 4;
    let mut rng = Lcg(7);
    let mut worst: f64 = 0.0;
    let mut worst_witness: f64 = 0.0;
    for k in 0..=3 {
        for _ in 0..400 {
            let vertices: Vec<f64> = (0..(k + 1) * dim).map(|_| rng.next()).collect();
            let p: Vec<f64> = (0..dim).map(|_| 2.0 * rng.next()).collect();
            let mut r = vec![0.0; dim];
            let c = closest_point_on_simplex(&p, &vertices, dim, &mut r);
            let q: Vec<f64> = (0..dim).map(|a| p[a] - r[a]).collect();
            let sum: f64 = c.witness[..=k].iter().sum();
            assert!(c.witness.iter().all(|&l| l >= 0.0), "negative witness");
            worst_witness = worst_witness.max((sum - 1.0).abs());
            for a in 0..dim {
                let from_witness: f64 = (0..=k).map(|j| c.witness[j] * vertices[j * dim + a]).sum();
                worst_witness = worst_witness.max((from_witness - q[a]).abs());
            }
            assert!((c.distance - r.iter().map(|x| x * x).sum::<f64>().sqrt()).abs() <= 1e-15);
            for j in 0..=k {
                let y = &vertices[j * dim..(j + 1) * dim];
                let inner: f64 = (0..dim).map(|a| r[a] * (y[a] - q[a])).sum();
                worst = worst.max(inner);
            }
        }
    }
    // Values are O(1); a Gram solve and a few dot products of O(1) terms
    // round at a few ulps each.
    bound(
        "closest point: max (p−q)·(v−q) over vertices",
        worst,
        1e-13,
        "O(1) coordinates, Gram solve of size ≤ 3: ~100 u",
    );
    bound(
        "closest point: witness consistency",
        worst_witness,
        1e-13,
        "Σλ = 1 and Σλv = q to ~100 u",
    );
}

/// Closed forms: a point above a triangle's interior in R^4, one beside an
/// edge, one in a vertex region, and a point on the simplex (d = 0).
#[test]
fn closest_point_closed_forms() {
    let dim = 4;
    // Triangle in the x0-x1 plane.
    let tri = [0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0];
    let mut r = vec![0.0; dim];
    let c = closest_point_on_simplex(&[0.5, 0.5, 3.0, 4.0], &tri, dim, &mut r);
    assert_eq!(c.distance, 5.0);
    assert_eq!(c.face, 0b111);
    assert_eq!(c.witness, [0.5, 0.25, 0.25, 0.0]);
    // Beside the hypotenuse: closest point (1, 1).
    let c = closest_point_on_simplex(&[2.0, 2.0, 0.0, 0.0], &tri, dim, &mut r);
    assert_eq!(c.face, 0b110);
    assert!((c.distance - 2f64.sqrt()).abs() < 1e-15);
    // Vertex region of vertex 0.
    let c = closest_point_on_simplex(&[-1.0, -1.0, 1.0, 1.0], &tri, dim, &mut r);
    assert_eq!(c.face, 0b001);
    assert_eq!(c.distance, 2.0);
    // On the segment: distance exactly 0.
    let seg = [0.0, 0.0, 0.0, 0.0, 4.0, 0.0, 0.0, 0.0];
    let c = closest_point_on_simplex(&[1.0, 0.0, 0.0, 0.0], &seg, dim, &mut r);
    assert_eq!(c.distance, 0.0);
    assert_eq!(c.witness, [0.75, 0.25, 0.0, 0.0]);
    // Tetrahedron in R^4, point straight above its interior along x3.
    let tet = [
        0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0,
    ];
    let c = closest_point_on_simplex(&[0.25, 0.25, 0.25, -2.0], &tet, dim, &mut r);
    assert_eq!(c.face, 0b1111);
    assert_eq!(c.distance, 2.0);
    assert_eq!(r, vec![0.0, 0.0, 0.0, -2.0]);
}

// ---------------------------------------------------------------------------
// Barrier law, per-particle block, filter
// ---------------------------------------------------------------------------

#[test]
fn barrier_law_derivatives_match_finite_differences() {
    let law = BarrierLaw {
        stiffness: 3.0,
        activation_distance: 0.1,
    };
    let mut worst: f64 = 0.0;
    for k in 1..100 {
        let d = 0.1 * k as f64 / 100.0;
        let (b, b1, b2) = law.evaluate(d);
        assert!(b >= 0.0 && b1 <= 0.0 && b2 > 0.0, "signs at d = {d}");
        let e = 1e-6 * d;
        let fd1 = (law.evaluate(d + e).0 - law.evaluate(d - e).0) / (2.0 * e);
        let fd2 = (law.evaluate(d + e).1 - law.evaluate(d - e).1) / (2.0 * e);
        worst = worst.max((fd1 - b1).abs() / b1.abs().max(1e-3));
        worst = worst.max((fd2 - b2).abs() / b2.abs().max(1e-3));
    }
    bound(
        "barrier law: b', b'' vs central differences (relative)",
        worst,
        1e-5,
        "central difference with step 1e-6 d: truncation ~1e-12 relative, rounding ~u/1e-6 ~ 1e-10; 1e-5 leaves room for |b'''| d²",
    );
    assert_eq!(law.evaluate(0.1), (0.0, 0.0, 0.0));
    assert_eq!(law.evaluate(0.5), (0.0, 0.0, 0.0));
    assert_eq!(law.evaluate(0.0).0, f64::INFINITY);
    // C¹ at d^: b and b' go to zero continuously.
    let (b, b1, _) = law.evaluate(0.1 * (1.0 - 1e-9));
    assert!(b.abs() < 1e-18 && b1.abs() < 1e-9);
}

fn triangle_mesh_obstacles(dim: usize) -> (Scene, BarrierObstacles) {
    let mut scene = Scene::new(dim, 0.01, 1, 1);
    scene.obstacles.push(plane(
        (0..dim).map(|a| if a == 0 { 1.0 } else { 0.5 }).collect(),
        -0.05,
    ));
    let v = |x: [f64; 2]| {
        let mut p = vec![0.0; dim];
        p[0] = x[0];
        p[1] = x[1];
        p
    };
    scene.obstacles.push(Obstacle::SimplexMesh {
        vertices: vec![v([0.0, 0.0]), v([1.0, 0.0]), v([0.0, 1.0]), v([1.0, 1.0])],
        simplices: vec![vec![0, 1, 2], vec![1, 3, 2]],
    });
    let obstacles = BarrierObstacles::compile(&scene);
    (scene, obstacles)
}

/// The gradient is the derivative of the energy; the Hessian block equals
/// the derivative of the gradient along n (where b'' n nᵀ is exact) and is
/// PSD; the dropped part b'∇²d is NSD.
#[test]
fn particle_block_matches_finite_differences_and_is_psd() {
    let dim = 4;
    let (_, obstacles) = triangle_mesh_obstacles(dim);
    let law = BarrierLaw {
        stiffness: 2.0,
        activation_distance: 0.2,
    };
    let mut rng = Lcg(11);
    let mut worst_gradient: f64 = 0.0;
    let mut worst_normal: f64 = 0.0;
    let mut out = ParticleBarrier::new(dim);
    let mut plus = ParticleBarrier::new(dim);
    let mut minus = ParticleBarrier::new(dim);
    let mut evaluated = 0;
    for _ in 0..300 {
        let x: Vec<f64> = vec![
            0.5 + 0.6 * rng.next(),
            0.5 + 0.6 * rng.next(),
            0.12 * rng.next(),
            0.12 * rng.next(),
        ];
        evaluate_particle_barrier(&law, &obstacles, &x, 0.0, &mut out);
        if out.min_distance <= 1e-3 || out.energy == 0.0 {
            continue;
        }
        evaluated += 1;
        let e = 1e-7;
        for a in 0..dim {
            let mut xp = x.clone();
            let mut xm = x.clone();
            xp[a] += e;
            xm[a] -= e;
            evaluate_particle_barrier(&law, &obstacles, &xp, 0.0, &mut plus);
            evaluate_particle_barrier(&law, &obstacles, &xm, 0.0, &mut minus);
            let fd = (plus.energy - minus.energy) / (2.0 * e);
            worst_gradient =
                worst_gradient.max((fd - out.gradient[a]).abs() / (1.0 + out.gradient[a].abs()));
        }
        // PSD: vᵀ H v ≥ 0 for random v.
        for _ in 0..8 {
            let w: Vec<f64> = (0..dim).map(|_| rng.next()).collect();
            let mut q = 0.0;
            for a in 0..dim {
                for c in 0..dim {
                    q += w[a] * out.hessian[a * dim + c] * w[c];
                }
            }
            assert!(q >= -1e-12 * (1.0 + out.hessian.iter().map(|h| h.abs()).sum::<f64>()));
        }
        // Along the gradient direction of a single active obstacle the
        // projected block is exact: compare u·H u with the second
        // difference of the energy along u when only one obstacle is active.
        let active = (0..obstacles.len())
            .filter(|&o| {
                let mut n = vec![0.0; dim];
                obstacles.distance(o, &x, 0.0, &mut n) < law.activation_distance
            })
            .count();
        if active == 1 {
            let norm = out.gradient.iter().map(|g| g * g).sum::<f64>().sqrt();
            let u: Vec<f64> = out.gradient.iter().map(|g| g / norm).collect();
            let h = 1e-5;
            let at = |t: f64, buf: &mut ParticleBarrier| {
                let y: Vec<f64> = (0..dim).map(|a| x[a] + t * u[a]).collect();
                evaluate_particle_barrier(&law, &obstacles, &y, 0.0, buf);
                buf.energy
            };
            let second = (at(h, &mut plus) - 2.0 * out.energy + at(-h, &mut minus)) / (h * h);
            let mut uhu = 0.0;
            for a in 0..dim {
                for c in 0..dim {
                    uhu += u[a] * out.hessian[a * dim + c] * u[c];
                }
            }
            worst_normal = worst_normal.max((second - uhu).abs() / (1.0 + uhu.abs()));
        }
    }
    assert!(
        evaluated > 50,
        "only {evaluated} samples had an active barrier"
    );
    bound(
        "particle barrier: gradient vs central difference of the energy",
        worst_gradient,
        1e-5,
        "step 1e-7: rounding ~u·E/1e-7 ≤ 1e-8 relative to 1 + |g|; truncation ~1e-14 b'''",
    );
    bound(
        "particle barrier: u·H·u along n vs second difference",
        worst_normal,
        1e-3,
        "second difference with step 1e-5: rounding ~u·E/1e-10 ~ 1e-5 relative to 1 + |uHu|, truncation ~1e-10 b''''",
    );
}

/// The filter keeps every trial point at d ≥ (1 − η) d0 for every
/// obstacle, planes exactly, simplices by the Lipschitz certificate.
#[test]
fn filter_fraction_is_certified() {
    let dim = 4;
    let (_, obstacles) = triangle_mesh_obstacles(dim);
    let mut rng = Lcg(5);
    let mut n = vec![0.0; dim];
    let mut cut = 0;
    for _ in 0..500 {
        let x: Vec<f64> = vec![
            0.5 + 0.6 * rng.next(),
            0.5 + 0.6 * rng.next(),
            0.3 * rng.next(),
            0.3 * rng.next(),
        ];
        if (0..obstacles.len()).any(|o| obstacles.distance(o, &x, 0.0, &mut n) <= 0.0) {
            continue;
        }
        let delta: Vec<f64> = (0..dim).map(|_| 3.0 * rng.next()).collect();
        let t = filter_fraction(&obstacles, &x, 0.0, &delta);
        assert!(t > 0.0 && t <= 1.0);
        if t < 1.0 {
            cut += 1;
        }
        for o in 0..obstacles.len() {
            let d0 = obstacles.distance(o, &x, 0.0, &mut n);
            for s in 0..=20 {
                let y: Vec<f64> = (0..dim)
                    .map(|a| x[a] + t * s as f64 / 20.0 * delta[a])
                    .collect();
                let d = obstacles.distance(o, &y, 0.0, &mut n);
                assert!(
                    d >= (1.0 - FILTER_SAFETY) * d0 * (1.0 - 1e-12),
                    "obstacle {o}: d {d} < (1 − η) d0 = {}",
                    (1.0 - FILTER_SAFETY) * d0
                );
            }
        }
    }
    assert!(cut > 50, "the filter cut only {cut} steps");
    // Plane, analytic: a step of twice the distance straight in is cut to η/2.
    let mut scene = Scene::new(2, 0.01, 1, 1);
    scene.obstacles.push(plane(vec![0.0, 1.0], 0.0));
    let planes = BarrierObstacles::compile(&scene);
    assert_eq!(
        filter_fraction(&planes, &[0.0, 1.0], 0.0, &[0.0, -2.0]),
        FILTER_SAFETY * 0.5
    );
    assert_eq!(filter_fraction(&planes, &[0.0, 1.0], 0.0, &[5.0, 2.0]), 1.0);
}

// ---------------------------------------------------------------------------
// The seed's backward-Euler example
// ---------------------------------------------------------------------------

/// One free unit-mass particle under a constant 1000 N force over a fixed
/// 1e-3 s horizon: the packed-gradient criterion (tolerance 1e-8, unit
/// mass·length) resolves forces only down to 1e-8 / dt², so at dt = 2e-6
/// (floor 2500 N) every step converges at the warm start and the particle
/// never moves: exactly 0 m/s. At dt = 5e-6 (floor 400 N) each step takes
/// the exact Newton step of the quadratic: backward Euler, 1 m/s. The
/// acceleration criterion (tolerance in length/time²) gives 1 m/s at both.
fn seed_example(dt: f64, convergence: Convergence) -> (f64, Vec<hyperpbd::MinimisationStatus>) {
    let mut scene = Scene::new(1, dt, 1, 1);
    scene
        .particles
        .push(Particle::new(vec![0.0], 1.0).with_force(vec![1000.0]));
    scene.solver = ip(1.0, 0.1, convergence, 20);
    let mut b = cpu(&scene);
    let steps = (1e-3 / dt).round() as usize;
    let mut statuses = Vec::new();
    for _ in 0..steps {
        let report = b.step().expect("step");
        assert_eq!(report.minimisation.len(), 1);
        let m = &report.minimisation[0];
        assert_eq!(m.criterion, convergence);
        assert!(m.initial_residual.is_some() && m.final_residual.is_some());
        statuses.push(m.status.clone());
    }
    (b.read_state().expect("state").velocities[0], statuses)
}

#[test]
fn seed_backward_euler_example_packed_gradient() {
    let packed = Convergence::PackedGradient { tolerance: 1e-8 };
    let (v, statuses) = seed_example(5e-6, packed);
    assert!(statuses.iter().all(|s| *s == MinimisationStatus::Converged));
    bound(
        "seed example: packed gradient, dt 5e-6: |v − 1 m/s|",
        (v - 1.0).abs(),
        1e-9,
        "200 exact Newton steps of a quadratic; each v rounds at ~u·|x|/h ~ 1e-13",
    );
    let (v, statuses) = seed_example(2e-6, packed);
    assert!(statuses.iter().all(|s| *s == MinimisationStatus::Converged));
    assert_eq!(
        v, 0.0,
        "dt 2e-6: converged at the warm start, identically 0 m/s"
    );
}

#[test]
fn seed_backward_euler_example_acceleration_residual() {
    let acceleration = Convergence::MaxAccelerationResidual { tolerance: 1e-3 };
    for dt in [5e-6, 2e-6] {
        let (v, statuses) = seed_example(dt, acceleration);
        assert!(statuses.iter().all(|s| *s == MinimisationStatus::Converged));
        bound(
            &format!("seed example: acceleration residual, dt {dt:e}: |v − 1 m/s|"),
            (v - 1.0).abs(),
            1e-9,
            "exact Newton steps of a quadratic; rounding ~u·|x|/h per step",
        );
    }
}

// ---------------------------------------------------------------------------
// Drops: d > 0 always
// ---------------------------------------------------------------------------

fn drop_scene(speed: f64, dhat: f64) -> Scene {
    let mut scene = Scene::new(3, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, -9.81, 0.0]);
    scene.particles.push(
        Particle::new(vec![0.3, 2.0, -0.1], 1.0)
            .with_velocity(vec![0.0, -speed, 0.0])
            .with_radius(0.05),
    );
    scene.obstacles.push(plane(vec![0.0, 1.0, 0.0], 0.0));
    scene.solver = ip(
        1e3,
        dhat,
        Convergence::MaxAccelerationResidual { tolerance: 1e-4 },
        200,
    );
    scene
}

fn drop_never_reaches_contact(speed: f64) {
    let scene = drop_scene(speed, 0.01);
    let mut b = cpu(&scene);
    let mut smallest = f64::INFINITY;
    for _ in 0..240 {
        let report = b.step().expect("step");
        for m in &report.minimisation {
            assert_eq!(m.status, MinimisationStatus::Converged, "{m:?}");
        }
        let s = b.read_state().expect("state");
        let d = min_distance(&scene, &s);
        assert!(d > 0.0, "speed {speed}: d = {d} <= 0");
        smallest = smallest.min(d);
    }
    println!("drop at {speed} m/s: smallest d over 240 steps {smallest:e}");
}

#[test]
fn drop_at_100_m_per_s_never_reaches_the_plane() {
    for speed in [1.0, 10.0, 100.0] {
        drop_never_reaches_contact(speed);
    }
}

/// The stability suite cites this one: 1e4 m/s at dt = 1/60 moves 167 m per
/// step toward a plane 2 m away, and the barrier path still never tunnels.
#[test]
fn drop_at_1e4_m_per_s_never_tunnels() {
    drop_never_reaches_contact(1e4);
}

/// A resting particle settles where the barrier force balances gravity:
/// −b'(d*) = m g. d* by bisection on the law; the simulated rest distance
/// must match it to the acceleration tolerance over the stiffness b''(d*).
#[test]
fn resting_particle_settles_at_the_force_balance() {
    let scene = drop_scene(0.0, 0.01);
    let law = BarrierLaw {
        stiffness: 1e3,
        activation_distance: 0.01,
    };
    let (mut lo, mut hi) = (1e-12, 0.01);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if -law.evaluate(mid).1 > 9.81 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let d_star = 0.5 * (lo + hi);
    let mut b = cpu(&scene);
    for _ in 0..600 {
        b.step().expect("step");
    }
    let s = b.read_state().expect("state");
    let d = min_distance(&scene, &s);
    let stiffness = law.evaluate(d_star).2;
    bound(
        "resting contact: |d − d*|",
        (d - d_star).abs(),
        1e-4 / stiffness + 1e-12,
        "converged to acceleration residual 1e-4 m/s²: force error ≤ m·1e-4, distance error ≤ that / b''(d*); settled after 10 s",
    );
    assert!(
        s.velocities.iter().all(|v| v.abs() < 1e-6),
        "{:?}",
        s.velocities
    );
}

// ---------------------------------------------------------------------------
// Sliding over a triangle mesh in 4D
// ---------------------------------------------------------------------------

/// A 4×4 grid of squares, each split into two triangles, in the x0-x1
/// plane of R^4; gravity along −x3. A particle launched along x0 at 1 m/s
/// slides across several triangles and edges (frictionless), x2 stays
/// exactly 0, the height stays in the barrier band, and d stays > 0 at
/// every step. The barrier is a sum over simplices, so near a shared edge
/// the neighbouring triangle's term (measured to its edge) pushes away
/// from that triangle with a horizontal component — the seed's "each cell's
/// barrier pushes away from itself" / "a shared edge carries both adjacent
/// cells' terms". Crossing edges therefore exchanges momentum with those
/// bumps, and the slide is not the ideal flat-plane slide; the test bounds
/// the travel against the flat value and prints the measured deviation.
#[test]
fn particle_slides_over_a_triangle_mesh_in_4d() {
    let dim = 4;
    let mut vertices = Vec::new();
    for i in 0..5 {
        for j in 0..5 {
            vertices.push(vec![i as f64 * 0.5, j as f64 * 0.5, 0.0, 0.0]);
        }
    }
    let mut simplices = Vec::new();
    for i in 0..4 {
        for j in 0..4 {
            let v = |a: usize, b: usize| a * 5 + b;
            simplices.push(vec![v(i, j), v(i + 1, j), v(i, j + 1)]);
            simplices.push(vec![v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]);
        }
    }
    let mut scene = Scene::new(dim, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, 0.0, 0.0, -9.81]);
    scene.particles.push(
        Particle::new(vec![0.1, 1.1, 0.0, 0.05], 1.0).with_velocity(vec![1.0, 0.0, 0.0, 0.0]),
    );
    scene.obstacles.push(Obstacle::SimplexMesh {
        vertices,
        simplices,
    });
    scene.solver = ip(
        1e3,
        0.02,
        Convergence::MaxAccelerationResidual { tolerance: 1e-4 },
        100,
    );
    scene.validate().expect("valid");
    let mut b = cpu(&scene);
    let mut smallest = f64::INFINITY;
    let steps = 90;
    for _ in 0..steps {
        let report = b.step().expect("step");
        assert_eq!(report.minimisation[0].status, MinimisationStatus::Converged);
        let s = b.read_state().expect("state");
        let d = min_distance(&scene, &s);
        assert!(d > 0.0);
        smallest = smallest.min(d);
    }
    let s = b.read_state().expect("state");
    let x = s.position(0);
    println!("slide: final {x:?}, smallest d {smallest:e}");
    assert_eq!(x[2], 0.0, "no force has a component along x2");
    assert!(
        x[3] > 0.0 && x[3] < 0.02,
        "height {} outside the barrier band",
        x[3]
    );
    assert!(x[0] > 1.0, "crossed several triangles (x0 = {})", x[0]);
    bound(
        "slide: |x0 − (x0(0) + v t)| / (v t)",
        (x[0] - (0.1 + 1.5)).abs() / 1.5,
        0.1,
        "per-simplex barrier sum: edge bumps of height ~d^ exchange momentum; 10% of the flat-plane travel (not a rounding bound)",
    );
    assert!(smallest > 0.0);
}

// ---------------------------------------------------------------------------
// Plan, rollback, validation, JSON
// ---------------------------------------------------------------------------

#[test]
fn barrier_scene_compiles_to_the_minimise_stage_only() {
    let scene = drop_scene(1.0, 0.01);
    let plan = Plan::compile(&scene).unwrap();
    assert_eq!(plan.stages, vec![StageName::Minimise]);
    assert_eq!(plan.substep_kernels, vec![Kernel::Minimise]);
    assert!(plan.families.is_empty());
    assert!(plan.incremental_potential().is_some());
    let mut xpbd = scene.clone();
    xpbd.solver = Solver::Xpbd;
    let plan = Plan::compile(&xpbd).unwrap();
    assert!(plan.incremental_potential().is_none());
    assert!(!plan.stages.contains(&StageName::Minimise));
}

#[test]
fn an_infeasible_start_is_refused_before_anything_moves() {
    let scene = drop_scene(1.0, 0.01);
    let mut b = cpu(&scene);
    b.step().unwrap();
    let mut bad = b.read_state().unwrap();
    bad.positions[1] = -1.0; // below the plane
    b.write_state(&bad).unwrap();
    let err = b.step().unwrap_err();
    match &err {
        BackendError::Step(StepError::MinimisationRefused { report, .. }) => {
            assert_eq!(report.initial_residual, None);
        }
        other => panic!("unexpected {other:?}"),
    }
    let after = b.read_state().unwrap();
    assert_eq!(after.hash(), bad.hash());
    println!("{err}");
}

/// A refusal after accepted substeps: gravity of 1e157 m/s² pointing away
/// from the plane moves the particle by h²g = 1e153 m in substep 0; every
/// substep adds as much speed, until the Newton slope −g·Δ ≈ m|Δ|² overflows
/// (|Δ| ≈ 1.3e154) and the minimisation is refused as non-finite. The state
/// has moved by then (asserted through the refusal's substep > 0), and the
/// step must restore it byte for byte.
#[test]
fn a_refusal_after_accepted_substeps_rolls_back_byte_for_byte() {
    let mut scene = drop_scene(0.0, 0.01);
    scene.dt = 0.2;
    scene.substeps = 20; // h = 0.01
    scene.gravity = Some(vec![0.0, 1e157, 0.0]);
    scene.solver = ip(
        1e3,
        0.01,
        Convergence::MaxAccelerationResidual { tolerance: 1.0 },
        4,
    );
    let mut b = cpu(&scene);
    let before = b.read_state().unwrap();
    let err = b.step().unwrap_err();
    match &err {
        BackendError::Step(StepError::MinimisationRefused {
            substep, reason, ..
        }) => {
            assert!(*substep > 0, "refused in substep {substep}: nothing moved");
            assert!(
                matches!(reason, hyperpbd::Refusal::NonFinite { particle: 0 }),
                "{reason:?}"
            );
        }
        other => panic!("unexpected {other:?}"),
    }
    assert_eq!(b.read_state().unwrap().hash(), before.hash());
    println!("{err}");
}

#[test]
fn empty_and_all_fixed_barrier_scenes_step() {
    let mut scene = drop_scene(1.0, 0.01);
    scene.particles.clear();
    let mut b = cpu(&scene);
    assert!(b.step().unwrap().minimisation.is_empty());
    let mut scene = drop_scene(1.0, 0.01);
    scene.particles = vec![Particle::fixed(vec![0.0, -1.0, 0.0])];
    let mut b = cpu(&scene);
    b.step().unwrap();
}

fn err(scene: &Scene) -> SceneError {
    scene.validate().expect_err("should be rejected")
}

#[test]
fn barrier_validation_names_the_field() {
    let base = drop_scene(1.0, 0.01);
    let mut s = base.clone();
    s.solver = ip(
        0.0,
        0.01,
        Convergence::PackedGradient { tolerance: 1e-8 },
        5,
    );
    assert!(
        matches!(err(&s), SceneError::NonPositive { path, .. } if path == "solver.barrier_stiffness")
    );
    s.solver = ip(
        1.0,
        -1.0,
        Convergence::PackedGradient { tolerance: 1e-8 },
        5,
    );
    assert!(
        matches!(err(&s), SceneError::NonPositive { path, .. } if path == "solver.activation_distance")
    );
    s.solver = ip(1.0, 0.1, Convergence::PackedGradient { tolerance: 0.0 }, 5);
    assert!(
        matches!(err(&s), SceneError::NonPositive { path, .. } if path == "solver.convergence.tolerance")
    );
    s.solver = ip(
        1.0,
        0.1,
        Convergence::PackedGradient {
            tolerance: f64::NAN,
        },
        5,
    );
    assert!(matches!(err(&s), SceneError::NonFinite { .. }));
    s.solver = ip(1.0, 0.1, Convergence::PackedGradient { tolerance: 1.0 }, 0);
    assert!(
        matches!(err(&s), SceneError::NonPositive { path, .. } if path == "solver.max_iterations")
    );

    let mut s = base.clone();
    s.particles[0].position[1] = 0.05; // exactly the radius: d = 0
    assert!(matches!(
        err(&s),
        SceneError::BarrierInfeasible { obstacle: 0, .. }
    ));

    let mut s = base.clone();
    s.damping = Some(hyperpbd::Damping { rate: 1.0 });
    assert!(matches!(err(&s), SceneError::UnsupportedBySolver { path, .. } if path == "damping"));

    let mut s = base.clone();
    s.collisions = Some(hyperpbd::Collisions {
        friction: 0.0,
        margin: 0.0,
    });
    assert!(
        matches!(err(&s), SceneError::UnsupportedBySolver { path, .. } if path == "collisions")
    );

    let mut s = base.clone();
    s.obstacles[0] = Obstacle::Hyperplane {
        normal: vec![0.0, 1.0, 0.0],
        offset: 0.0,
        friction: 0.3,
        compliance: 0.0,
    };
    assert!(
        matches!(err(&s), SceneError::UnsupportedBySolver { path, .. } if path == "obstacles[0].friction")
    );

    let mut s = base.clone();
    s.particles.push(Particle::new(vec![0.0, 3.0, 0.0], 1.0));
    s.constraints.push(hyperpbd::ConstraintFamily::new(
        hyperpbd::ConstraintKind::Distance,
        0.0,
        vec![vec![0, 1]],
    ));
    assert!(
        matches!(err(&s), SceneError::UnsupportedBySolver { path, .. } if path == "constraints")
    );

    let mesh = |vertices: Vec<Vec<f64>>, simplices: Vec<Vec<usize>>| {
        let mut s = base.clone();
        s.obstacles.push(Obstacle::SimplexMesh {
            vertices,
            simplices,
        });
        s
    };
    let square = vec![
        vec![0.0, -1.0, 0.0],
        vec![1.0, -1.0, 0.0],
        vec![0.0, -1.0, 1.0],
        vec![2.0, -1.0, 0.0],
    ];
    // Collinear triangle.
    assert!(matches!(
        err(&mesh(square.clone(), vec![vec![0, 1, 3]])),
        SceneError::DegenerateSimplex { path, .. } if path == "obstacles[1].simplices[0]"
    ));
    assert!(matches!(
        err(&mesh(square.clone(), vec![vec![0, 1, 2], vec![0, 1, 7]])),
        SceneError::VertexOutOfRange { path, index: 7, count: 4 } if path == "obstacles[1].simplices[1][2]"
    ));
    assert!(matches!(
        err(&mesh(square.clone(), vec![vec![0, 0]])),
        SceneError::DegenerateSimplex { .. }
    ));
    assert!(matches!(
        err(&mesh(square.clone(), vec![vec![0, 1, 2], vec![0, 1]])),
        SceneError::WrongSimplexArity { .. }
    ));
    assert!(matches!(
        err(&mesh(vec![vec![0.0, 1.0]], vec![])),
        SceneError::WrongLength { .. }
    ));
    // A simplex mesh under XPBD.
    let mut s = mesh(square, vec![vec![0, 1, 2]]);
    s.validate().expect("valid barrier scene");
    s.solver = Solver::Xpbd;
    s.obstacles.remove(0);
    assert!(matches!(
        err(&s),
        SceneError::UnsupportedBySolver { solver: "xpbd", .. }
    ));
}

#[test]
fn barrier_scene_json_round_trips() {
    let text = r#"{
      "dim": 2, "dt": 0.01,
      "gravity": [0.0, -9.81],
      "particles": [{"position": [0.5, 1.0], "mass": 1.0}],
      "obstacles": [
        {"type": "hyperplane", "normal": [0.0, 1.0]},
        {"type": "simplex_mesh", "vertices": [[0.0, 0.5], [1.0, 0.5]], "simplices": [[0, 1]]}
      ],
      "solver": {"type": "incremental_potential", "barrier_stiffness": 100.0,
                 "activation_distance": 0.05,
                 "convergence": {"kind": "max_acceleration_residual", "tolerance": 1e-6},
                 "max_iterations": 30}
    }"#;
    let scene = Scene::from_json_str(text).expect("parses");
    assert_eq!(
        scene.solver,
        ip(
            100.0,
            0.05,
            Convergence::MaxAccelerationResidual { tolerance: 1e-6 },
            30
        )
    );
    let again = Scene::from_json_str(&scene.to_json_string()).expect("round trip");
    assert_eq!(again, scene);
    let xpbd =
        Scene::from_json_str(r#"{"dim": 1, "dt": 0.1, "solver": {"type": "xpbd"}}"#).unwrap();
    assert_eq!(xpbd.solver, Solver::Xpbd);
    assert!(!xpbd.to_json_string().contains("solver"));
    for bad in [
        r#"{"dim": 1, "dt": 0.1, "solver": {"type": "incremental_potential", "barrier_stiffness": 1, "activation_distance": 1, "convergence": {"kind": "packed_gradient", "tolerance": 1}, "max_iterations": 3, "extra": 1}}"#,
        r#"{"dim": 1, "dt": 0.1, "solver": {"type": "incremental_potential", "barrier_stiffness": 1, "activation_distance": 1, "convergence": {"kind": "energy", "tolerance": 1}, "max_iterations": 3}}"#,
        r#"{"dim": 1, "dt": 0.1, "obstacles": [{"type": "simplex_mesh", "vertices": [[0.0]]}]}"#,
        r#"{"dim": 1, "dt": 0.1, "obstacles": [{"type": "hyperplane", "normal": [1.0], "simplices": []}]}"#,
    ] {
        let e = Scene::from_json_str(bad).expect_err(bad);
        assert!(matches!(e, SceneError::Json { .. }), "{e}");
    }
}

/// 200 particles of mixed mass hitting a plane at up to 100 m/s with an
/// acceleration tolerance of 1e-4 m/s²: deep in the barrier (d ~ 1e-5,
/// b'' ~ 1e9 N/m) the f64 residual's rounding floor b'' u X / m can exceed
/// the tolerance. Those minimisations end `RoundingFloor` (typed, accepted)
/// — never refused, never at d ≤ 0.
#[test]
fn many_fast_particles_end_converged_or_at_the_rounding_floor() {
    let mut scene = Scene::new(3, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, -9.81, 0.0]);
    let mut rng = Lcg(203);
    for _ in 0..200 {
        scene.particles.push(
            Particle::new(
                vec![0.3 * rng.next(), 1.0 + 0.5 * rng.next(), 0.3 * rng.next()],
                1.0 + 0.5 * rng.next(),
            )
            .with_velocity(vec![0.0, -100.0 * (0.5 + 0.5 * rng.next()), 0.0])
            .with_radius(0.05),
        );
    }
    scene.obstacles.push(plane(vec![0.0, 1.0, 0.0], 0.0));
    scene.solver = ip(
        1e3,
        0.01,
        Convergence::MaxAccelerationResidual { tolerance: 1e-4 },
        200,
    );
    let mut b = cpu(&scene);
    let (mut converged, mut floor) = (0, 0);
    let mut smallest = f64::INFINITY;
    for _ in 0..120 {
        let report = b.step().expect("accepted");
        for m in &report.minimisation {
            match m.status {
                MinimisationStatus::Converged => converged += 1,
                MinimisationStatus::RoundingFloor => floor += 1,
                ref other => panic!("unexpected {other:?}"),
            }
        }
        let d = min_distance(&scene, &b.read_state().unwrap());
        assert!(d > 0.0);
        smallest = smallest.min(d);
    }
    println!(
        "200 particles at up to 100 m/s: {converged} converged, {floor} at the rounding floor, smallest d {smallest:e}"
    );
}

/// Golden: the CPU barrier path is bit-identical across runs and machines
/// (libm for ln, no contraction, fixed reduction tree). If this hash
/// changes, the barrier path's arithmetic changed: say why in the commit
/// and update the constant.
#[test]
fn barrier4d_golden_hash() {
    let scene = hyperpbd::scenes::barrier4d();
    let run = || {
        let mut b = cpu(&scene);
        for _ in 0..60 {
            b.step().expect("step");
        }
        b.read_state().expect("state").hash()
    };
    let first = run();
    assert_eq!(first, run(), "two runs differ");
    println!("barrier4d after 60 steps: {first:016x}");
    assert_eq!(
        first, BARRIER4D_HASH,
        "barrier4d golden hash changed: {first:016x}"
    );
}

const BARRIER4D_HASH: u64 = 0x1e50_ebc2_b2ec_adce;
