//! Granular scenes: balls with particle–particle contact (`collisions`).
//!
//! Balls start on a jittered lattice with a gap (no initial overlap), so
//! everything that happens comes from gravity, the floor, walls and contacts.

use hyperpbd_core::{Collisions, Particle, Scene, SceneBuilder};

/// A deterministic jitter in [−1, 1) (64-bit LCG), so the builders, and
/// the shipped files, are the same on every machine.
struct Jitter(u64);

impl Jitter {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

/// Rounds to a multiple of 2^−20 so the JSON files stay short and exact.
fn tidy(x: f64) -> f64 {
    (x * 1_048_576.0).round() / 1_048_576.0
}

/// Balls on a lattice of `cells` (per axis) with spacing `2 r (1 + gap)`,
/// lowest layer (along `up`) resting at height r(1 + gap), jittered
/// sideways by up to `jitter · r`; all of mass `mass`.
fn lattice(b: &mut SceneBuilder, cells: &[usize], up: usize, r: f64, mass: f64, seed: u64) {
    let dim = cells.len();
    let spacing = 2.0 * r * 1.05;
    let mut jitter = Jitter(seed);
    let count: usize = cells.iter().product();
    let mut index = vec![0usize; dim];
    for _ in 0..count {
        let mut position = vec![0.0; dim];
        for a in 0..dim {
            let centered = index[a] as f64 - 0.5 * (cells[a] as f64 - 1.0);
            position[a] = if a == up {
                r * 1.05 + spacing * index[a] as f64
            } else {
                tidy(spacing * centered + 0.02 * r * jitter.next())
            };
        }
        b.particle(Particle::new(position, mass).with_radius(r));
        for a in 0..dim {
            index[a] += 1;
            if index[a] < cells[a] {
                break;
            }
            index[a] = 0;
        }
    }
}

/// 3D granular column collapse: a column of `side × side × height` balls
/// (r = 0.05 m) released on a floor with friction; ball–ball friction 0.5.
pub fn column3d(side: usize, height: usize) -> Scene {
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(4)
        .gravity_along(1, 9.81);
    lattice(&mut b, &[side, height, side], 1, 0.05, 0.01, 3);
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.5);
    b.scene_mut().collisions = Some(Collisions {
        friction: 0.5,
        margin: 0.01,
    });
    super::built(b)
}

/// 3D granular pit: `side × height × side` balls (r = 0.05 m) dropped
/// into a square pit (floor and four walls, friction 0.5) just wider than
/// the lattice; ball–ball friction 0.5; 8 substeps × 2 iterations.
/// `pit3d(26, 24)` is the ~16k-ball scene of the GPU contact benchmark
/// (benches/granular_gpu.rs).
pub fn pit3d(side: usize, height: usize) -> Scene {
    let r = 0.05;
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(8)
        .iterations(2)
        .gravity_along(1, 9.81);
    lattice(&mut b, &[side, height, side], 1, r, 0.01, 5);
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.5);
    let half = 0.5 * side as f64 * 2.0 * r * 1.05 + r;
    for a in [0, 2] {
        for sign in [1.0, -1.0] {
            let mut normal = vec![0.0; 3];
            normal[a] = sign;
            b.hyperplane(normal, -half, 0.5);
        }
    }
    b.scene_mut().collisions = Some(Collisions {
        friction: 0.5,
        margin: 0.01,
    });
    super::built(b)
}

/// 4D ball pit: 6 × 6 × 6 × 4 balls of two radii dropped into a pit
/// bounded by the floor x₃ = 0 and six walls ±x₀, ±x₁, ±x₂.
pub fn ballpit4d() -> Scene {
    let mut b = SceneBuilder::new(4)
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(4)
        .gravity_along(3, 9.81);
    lattice(&mut b, &[6, 6, 6, 4], 3, 0.1, 0.05, 4);
    for (k, p) in b.scene_mut().particles.iter_mut().enumerate() {
        if k % 3 == 0 {
            p.radius = 0.075;
        }
    }
    b.hyperplane(vec![0.0, 0.0, 0.0, 1.0], 0.0, 0.3);
    for a in 0..3 {
        for sign in [1.0, -1.0] {
            let mut normal = vec![0.0; 4];
            normal[a] = sign;
            b.hyperplane(normal, -0.75, 0.1);
        }
    }
    b.scene_mut().collisions = Some(Collisions {
        friction: 0.2,
        margin: 0.02,
    });
    super::built(b)
}

/// 2D sand pile: a 16 × 48 column of grains (r = 0.02 m) collapsing on a
/// rough floor into a pile; grain–grain friction 0.6. 20 substeps: grains
/// sliding off the top reach ~5 m/s, a quarter radius per substep.
pub fn sandpile2d() -> Scene {
    let mut b = SceneBuilder::new(2)
        .dt(1.0 / 60.0)
        .substeps(20)
        .iterations(4)
        .gravity_along(1, 9.81);
    lattice(&mut b, &[16, 48], 1, 0.02, 0.001, 2);
    b.hyperplane(vec![0.0, 1.0], 0.0, 0.6);
    b.scene_mut().collisions = Some(Collisions {
        friction: 0.6,
        margin: 0.004,
    });
    super::built(b)
}
