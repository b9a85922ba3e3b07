//! The cases: a distance chain in R^N, triangles (squared area), the jittered
//! tesseract (oriented measure), contacts with sticking and sliding friction;
//! and a check that they are what they claim.

use super::*;

/// A chain of `n` particles in R^dim, links of 0.1 m along x0, first
/// particle fixed, over a plane x1 ≥ −0.5 with friction; positions
/// jittered ±1 cm so every link is violated, velocities ±0.5 m/s. (The CPU
/// projects distance with a dimension-specialised loop for N ≤ 4 and the
/// generic gather path above; both are checked.)
pub(super) fn chain(dim: usize, n: usize) -> Scene {
    let mut b = SceneBuilder::new(dim)
        .dt(1.0 / 60.0)
        .substeps(4)
        .iterations(1)
        .gravity_along(1, 9.81)
        .damping(0.5);
    let mut rng = Lcg(n as u64 + 31 * dim as u64);
    for i in 0..n {
        let x: Vec<f64> = (0..dim)
            .map(|a| match a {
                0 => 0.1 * i as f64 + 0.01 * rng.next(),
                1 => 0.3 + 0.01 * rng.next(),
                _ => 0.01 * rng.next(),
            })
            .collect();
        let v: Vec<f64> = (0..dim).map(|_| 0.5 * rng.next()).collect();
        let mut p = Particle::new(x, 0.2 + 0.1 * rng.next().abs());
        if i > 0 {
            p = p.with_velocity(v);
        }
        let index = b.particle(p);
        if i == 0 && n > 1 {
            b.fix(index);
        }
    }
    if n > 1 {
        let links = (1..n).map(|i| vec![i - 1, i]).collect();
        let mut family = ConstraintFamily::new(ConstraintKind::Distance, 1e-7, links);
        family.rest = Some(vec![0.1; n - 1]);
        b.family(family);
    }
    let mut normal = vec![0.0; dim];
    normal[1] = 1.0;
    b.hyperplane(normal, -0.5, 0.3);
    build(b)
}

pub(super) fn chain3d(n: usize) -> Scene {
    chain(3, n)
}

/// A zigzag strip of `n` particles in 3D with triangles (i, i+1, i+2) as
/// squared-area (k = 2) elements, rest 10 % off the authored value.
pub(super) fn triangles3d(n: usize) -> Scene {
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(4)
        .iterations(1)
        .gravity_along(1, 9.81)
        .damping(0.5);
    let mut rng = Lcg(7 + n as u64);
    for i in 0..n {
        let x = vec![
            0.1 * i as f64 + 0.01 * rng.next(),
            0.01 * rng.next(),
            0.1 * (i % 2) as f64 + 0.01 * rng.next(),
        ];
        let v = vec![0.3 * rng.next(), 0.3 * rng.next(), 0.3 * rng.next()];
        b.particle(Particle::new(x, 0.1 + 0.05 * rng.next().abs()).with_velocity(v));
    }
    let elements: Vec<Vec<usize>> = (2..n).map(|i| vec![i - 2, i - 1, i]).collect();
    // Right-ish triangles of legs 0.1: area ≈ 0.005, squared ≈ 2.5e-5.
    let mut family = ConstraintFamily::new(ConstraintKind::SimplexMeasure, 1e-9, elements);
    family.rest = Some(vec![2.2e-5; n.saturating_sub(2)]);
    b.family(family);
    build(b)
}

/// The soft tesseract (81 nodes, 384 oriented 4-simplices), nodes jittered
/// ±2 cm, velocities ±0.3 m/s: every element violated, all colors.
pub(super) fn tesseract_jittered() -> Scene {
    let mut scene = hyperpbd::scenes::tesseract();
    let mut rng = Lcg(4);
    for p in &mut scene.particles {
        for x in &mut p.position {
            *x += 0.02 * rng.next();
        }
        p.velocity = Some((0..4).map(|_| 0.3 * rng.next()).collect());
    }
    // Rest values of the unjittered block (authored explicitly: left
    // implicit they would be computed from the jittered geometry and every
    // element would start satisfied).
    let clean = hyperpbd::scenes::tesseract();
    let plan = Plan::compile(&clean).expect("tesseract compiles");
    for f in &plan.families {
        let Some(index) = f
            .label
            .strip_prefix("constraints[")
            .and_then(|l| l.strip_suffix(']'))
            .and_then(|l| l.parse::<usize>().ok())
        else {
            continue;
        };
        let mut rest = vec![0.0; f.len()];
        for (slot, &source) in f.source.iter().enumerate() {
            rest[source as usize] = f.rest[slot];
        }
        scene.constraints[index].rest = Some(rest);
    }
    scene
}

/// `n` particles in R^dim over the hyperplane with unit normal tilted 20°
/// from +x1 towards +x0, μ = 0.6 > tan 20°: particle i penetrates by 1–5 mm
/// (even i) or floats 1–5 cm above (odd i); every sixth slides fast along
/// the plane (2 m/s: 8.3 mm per substep against a static bound μ·w·λ ≤
/// 3.1 mm), the others stick (≤ 1 mm/s: ≤ 0.07 mm per substep with gravity's
/// tangential part, against ≥ 0.6 mm).
pub(super) fn contacts(dim: usize, n: usize) -> Scene {
    let theta: f64 = 20f64.to_radians();
    let mut b = SceneBuilder::new(dim)
        .dt(1.0 / 60.0)
        .substeps(4)
        .iterations(1)
        .gravity_along(1, 9.81)
        .damping(0.5);
    let mut normal = vec![0.0; dim];
    normal[0] = theta.sin();
    normal[1] = theta.cos();
    let mut tangent = vec![0.0; dim];
    tangent[0] = theta.cos();
    tangent[1] = -theta.sin();
    let offset = 0.1;
    b.hyperplane(normal.clone(), offset, 0.6);
    let mut rng = Lcg(11 + dim as u64 * 1000 + n as u64);
    for i in 0..n {
        let depth = if i % 2 == 0 {
            -(0.001 + 0.002 * (1.0 + rng.next()))
        } else {
            0.01 + 0.02 * (1.0 + rng.next())
        };
        let along = 0.05 * i as f64;
        let mut x: Vec<f64> = (0..dim)
            .map(|a| (offset + depth) * normal[a] + along * tangent[a])
            .collect();
        for c in x.iter_mut().skip(2) {
            *c = 0.1 * rng.next();
        }
        let speed = if i % 6 == 0 { 2.0 } else { 1e-3 * rng.next() };
        let v: Vec<f64> = (0..dim).map(|a| speed * tangent[a]).collect();
        b.particle(Particle::new(x, 0.5 + 0.25 * rng.next().abs()).with_velocity(v));
    }
    build(b)
}

/// The cases are what they claim: the families, colors and the
/// static-friction regimes the bounds rely on.
#[test]
fn cases_cover_every_family_kind_and_sizes_not_dividing_the_workgroup() {
    let tess = Plan::compile(&tesseract_jittered()).unwrap();
    assert!(matches!(tess.families[0].kind, FamilyKind::OrientedMeasure));
    assert_eq!(tess.dim, 4);
    let tri = Plan::compile(&triangles3d(37)).unwrap();
    assert_eq!(tri.families[0].kind, FamilyKind::SimplexMeasure { k: 2 });
    assert_eq!(tri.dim, 3);
    for n in [37, 129] {
        let chain = Plan::compile(&chain3d(n)).unwrap();
        assert_eq!(chain.families[0].kind, FamilyKind::Distance);
        assert_ne!(n % 64, 0);
        assert!(chain.families[1].kind.is_inequality());
    }
    let one = Plan::compile(&contacts(3, 1)).unwrap();
    assert_eq!(one.particle_count(), 1);
    assert!(
        one.substep_kernels
            .contains(&Kernel::Friction { family: 0 })
    );
    for (dim, n) in [(3, 129), (5, 37)] {
        let plan = Plan::compile(&contacts(dim, n)).unwrap();
        assert!(
            plan.substep_kernels
                .contains(&Kernel::Friction { family: 0 })
        );
        assert!(plan.substep_kernels.contains(&Kernel::Damping));
    }
}
