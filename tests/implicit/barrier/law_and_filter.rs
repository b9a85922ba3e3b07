//! The barrier law, the per-particle block and the step filter.

use super::*;

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
        friction: 0.0,
        motion: Vec::new(),
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
