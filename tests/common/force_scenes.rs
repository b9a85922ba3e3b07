//! Scenes and checks of the contact-force tests (tests/cpu/contact_forces.rs,
//! tests/gpu/contact_forces.rs): a floor, a box, a stack of two balls, an
//! incline, and the closed forms they rest at.

use super::implicit_scenes::particle;
use super::motion_scenes::G;
use hyperpbd::motion::Motion;
use hyperpbd::{Collisions, ConstraintFamily, ConstraintKind, ContactForces, Obstacle, Scene};

/// A plane through the origin with unit normal `normal`, friction μ.
pub fn plane(normal: Vec<f64>, friction: f64, motion: Vec<Motion>) -> Obstacle {
    Obstacle::Hyperplane {
        normal,
        offset: 0.0,
        friction,
        compliance: 0.0,
        motion,
    }
}

/// |got − want| / |want| (want ≠ 0).
pub fn relative(got: &[f64], want: &[f64]) -> f64 {
    let diff: f64 = got.iter().zip(want).map(|(g, w)| (g - w) * (g - w)).sum();
    let size: f64 = want.iter().map(|w| w * w).sum();
    (diff / size).sqrt()
}

pub fn assert_close(what: &str, got: &[f64], want: &[f64], bound: f64) {
    let r = relative(got, want);
    println!("BOUND {what}: relative error {r:.3e} / {bound:.0e}  ({got:?} vs {want:?})");
    assert!(r <= bound, "{what}: {got:?} vs {want:?}, relative {r:.3e}");
}

/// Σ_i F_i − Σ_o F_o (0 where only obstacle contacts act: every
/// particle's contact force is some obstacle's force on it).
pub fn imbalance(f: &ContactForces) -> Vec<f64> {
    let mut sum = vec![0.0; f.dim];
    for chunk in f.particles.chunks(f.dim) {
        for (s, c) in sum.iter_mut().zip(chunk) {
            *s += c;
        }
    }
    for chunk in f.obstacles.chunks(f.dim) {
        for (s, c) in sum.iter_mut().zip(chunk) {
            *s -= c;
        }
    }
    sum
}

/// Every force's bits, obstacles then particles.
pub fn bits(f: &ContactForces) -> Vec<u64> {
    f.obstacles
        .iter()
        .chain(&f.particles)
        .map(|v| v.to_bits())
        .collect()
}

/// m g of total mass `m` along −y in R^dim.
pub fn weight(dim: usize, m: f64) -> Vec<f64> {
    let mut w = vec![0.0; dim];
    w[1] = -m * G;
    w
}

/// The force holding up a total mass `m` at rest: −m g (along +y).
pub fn support(dim: usize, m: f64) -> Vec<f64> {
    weight(dim, m).iter().map(|c| -c).collect()
}

/// Gravity −G along y, the plane y = 0 (friction μ), no particles.
pub fn on_floor(dim: usize, substeps: u32, iterations: u32, mu: f64) -> Scene {
    let mut s = Scene::new(dim, 1.0 / 60.0, substeps, iterations);
    s.gravity = Some(weight(dim, 1.0));
    let mut n = vec![0.0; dim];
    n[1] = 1.0;
    s.obstacles = vec![plane(n, mu, Vec::new())];
    s
}

/// A square of four 0.5 kg particles (side 0.2, radius 0.05) with rigid
/// edges and diagonals, resting on the floor.
pub fn square_box(mut s: Scene) -> Scene {
    let r = 0.05;
    for (x, y) in [(0.0, r), (0.2, r), (0.2, r + 0.2), (0.0, r + 0.2)] {
        s.particles.push(particle(vec![x, y], Some(0.5), r));
    }
    let edges = vec![
        vec![0, 1],
        vec![1, 2],
        vec![2, 3],
        vec![3, 0],
        vec![0, 2],
        vec![1, 3],
    ];
    s.constraints = vec![ConstraintFamily::new(ConstraintKind::Distance, 0.0, edges)];
    s
}

/// Ball A (1 kg) on the floor, ball B (2 kg) resting on A.
pub fn stack(mut s: Scene) -> Scene {
    s.particles.push(particle(vec![0.0, 0.1], Some(1.0), 0.1));
    s.particles.push(particle(vec![0.0, 0.3], Some(2.0), 0.1));
    s.collisions = Some(Collisions {
        friction: 0.0,
        margin: 0.01,
    });
    s
}

/// A 1.5 kg particle on the plane through 0 tilted by θ (normal
/// (−sin θ, cos θ)), friction μ.
pub fn incline(s: Scene, theta: f64, mu: f64) -> (Scene, Vec<f64>) {
    let mut s = s;
    let n = vec![-theta.sin(), theta.cos()];
    s.obstacles = vec![plane(n.clone(), mu, Vec::new())];
    let r = 0.1;
    s.particles
        .push(particle(vec![r * n[0], r * n[1]], Some(1.5), r));
    (s, n)
}
