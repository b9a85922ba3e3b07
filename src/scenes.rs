//! Built-in scenes: the demo and the examples shipped in `scenes/`.
//!
//! Each is a plain builder call, so the JSON files in `scenes/` can be
//! regenerated with `hyperpbd scene NAME --out scenes/NAME.json` and a test
//! checks that they still match.

mod bowl;
mod demo;
mod drape;
mod drum;
mod granular;
mod peer_cloth;
mod stretched_bar;
mod twirl;

pub use bowl::bowl3d;
pub use demo::{BELT_SPEED, demo};
pub use drape::{DOME_RATE, dome_height, dome_motion, drape3d};
pub use drum::{DRUM_RATE, DrumSpec, drum, drum_motion, drum_spec, drum3d, drum4d};
pub use granular::{ballpit4d, column3d, pit3d, sandpile2d};
use hyperpbd_core::builders::{BlockSpec, Grid, GridSpec};
use hyperpbd_core::kinds::BendingModel;
use hyperpbd_core::{Scene, SceneBuilder};
pub use peer_cloth::peer_cloth;
pub use stretched_bar::{BAR_POISSON, BAR_YOUNGS, bar_strains, stretched_bar};
pub use twirl::{TWIRL_RATE, twirl};

/// Names accepted by [`by_name`].
pub const NAMES: &[&str] = &[
    "cloth",
    "tesseract",
    "chain2d",
    "incline5d",
    "column3d",
    "ballpit4d",
    "sandpile2d",
    "barrier4d",
    "jelly4d",
    "demo",
    "drum3d",
    "drum4d",
    "twirl",
    "bowl3d",
    "drape3d",
];

/// Built-in scenes too large to ship as files; generate them with
/// `hyperpbd scene NAME --out FILE`.
pub const LARGE_NAMES: &[&str] = &["column3d_100k", "peer_cloth"];

/// A built-in scene by name.
pub fn by_name(name: &str) -> Option<Scene> {
    match name {
        "cloth" => Some(cloth(32)),
        "tesseract" => Some(tesseract()),
        "chain2d" => Some(chain2d()),
        "incline5d" => Some(incline5d()),
        "column3d" => Some(column3d(12, 30)),
        "column3d_100k" => Some(column3d(40, 64)),
        "peer_cloth" => Some(peer_cloth(128)),
        "ballpit4d" => Some(ballpit4d()),
        "sandpile2d" => Some(sandpile2d()),
        "barrier4d" => Some(barrier4d()),
        "jelly4d" => Some(jelly4d()),
        "demo" => Some(demo()),
        "drum3d" => Some(drum3d()),
        "drum4d" => Some(drum4d()),
        "twirl" => Some(twirl()),
        "bowl3d" => Some(bowl3d()),
        "drape3d" => Some(drape3d()),
        _ => None,
    }
}

/// A built-in scene from its builder (every built-in scene is valid).
fn built(b: SceneBuilder) -> Scene {
    b.build()
        .unwrap_or_else(|e| unreachable!("built-in scene is valid: {e}"))
}

/// The settings the 4D drops share: 1/60 s frames of 20 substeps and 2
/// iterations, gravity 9.81 m/s² along −x_3, damping 0.2 /s.
fn drop_in_4d() -> SceneBuilder {
    SceneBuilder::new(4)
        .dt(1.0 / 60.0)
        .substeps(20)
        .iterations(2)
        .gravity_along(3, 9.81)
        .damping(0.2)
}

/// The settings the 3D cloths share: 1/60 s frames of 10 substeps and 1
/// iteration, gravity 9.81 m/s² along −y, damping 0.1 /s.
fn cloth_in_3d() -> SceneBuilder {
    SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(1)
        .gravity_along(1, 9.81)
        .damping(0.1)
}

/// An `n × n` cloth of `spacing` at height `y` with the cosine fold over
/// every interior edge (compliance 1e-3).
fn folding_cloth(b: &mut SceneBuilder, n: usize, spacing: f64, y: f64) -> Grid {
    let grid = b.grid(&GridSpec::cloth(n, n, spacing, y));
    b.grid_bending(&grid, 1e-3, BendingModel::Cosine)
        .unwrap_or_else(|| unreachable!("a 2-grid has hinges"));
    grid
}

/// The demo: an `n × n` cloth (1 m square, rigid edges and shear springs)
/// dropped from 0.5 m onto a ground plane with friction 0.4, light damping.
pub fn cloth(n: usize) -> Scene {
    let spacing = 1.0 / (n.max(2) - 1) as f64;
    let mut b = cloth_in_3d();
    let mut spec = GridSpec::cloth(n, n, spacing, 0.5);
    // A slight tilt so the cloth lands corner first and folds.
    spec.origin[1] = 0.5;
    let grid = b.grid(&spec);
    let tilt = 0.2;
    for i in 0..grid.len() {
        let p = &mut b.scene_mut().particles[grid.first + i];
        p.position[1] += tilt * p.position[0];
        p.radius = 0.25 * spacing;
    }
    b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.4);
    built(b)
}

/// An `n × n` 1 m cloth (edges + shear diagonals, rigid) hanging from the
/// two corners of its far edge: 10 substeps, 1 iteration, gravity, no
/// obstacle — the benchmark cloth, distance projections only.
pub fn hanging_cloth(n: usize) -> Scene {
    let spacing = 1.0 / (n.max(2) - 1) as f64;
    let mut b = SceneBuilder::new(3)
        .dt(1.0 / 60.0)
        .substeps(10)
        .iterations(1)
        .gravity_along(1, 9.81);
    let grid = b.grid(&GridSpec::cloth(n, n, spacing, 1.0));
    b.fix(grid.index(&[0, n - 1]));
    b.fix(grid.index(&[n - 1, n - 1]));
    built(b)
}

/// A soft tesseract in R^4: a 2×2×2×2-cell Kuhn block (81 nodes, 384
/// oriented 4-simplices, slightly compliant, plus the simplices' edges as
/// compliant springs for shear) dropped onto the hyperplane x_3 = 0 with
/// friction.
pub fn tesseract() -> Scene {
    let mut b = drop_in_4d();
    b.soft_block(&BlockSpec {
        cells: vec![2, 2, 2, 2],
        origin: vec![-0.5, -0.5, -0.5, 0.3],
        spacing: 0.5,
        mass: 0.05,
        compliance: 1e-6,
        edge_compliance: Some(1e-5),
    });
    b.hyperplane(vec![0.0, 0.0, 0.0, 1.0], 0.0, 0.5);
    built(b)
}

/// A soft 4D jelly: a tesseract 0.5 m across (3⁴ nodes, 2⁴ cells of
/// 4! Kuhn 4-simplices = 384 elements) of compressible Neo-Hookean
/// material (E = 20 kPa, ν = 0.25, ρ = 400 kg/m⁴; lumped masses from the
/// density) dropped from 0.3 m onto a floor with friction 0.5.
pub fn jelly4d() -> Scene {
    let mut b = drop_in_4d();
    let (nodes, spacing) = (3usize, 0.25);
    for i in 0..nodes.pow(4) {
        let position: Vec<f64> = (0..4)
            .map(|a| {
                let c = (i / nodes.pow(a as u32)) % nodes;
                let lift = if a == 3 { 0.3 } else { -0.25 };
                lift + c as f64 * spacing
            })
            .collect();
        let mut particle = hyperpbd_core::Particle::new(position, 1.0);
        particle.mass = None;
        b.particle(particle);
    }
    let node = |c: &[usize]| (0..4).map(|a| c[a] * nodes.pow(a as u32)).sum::<usize>();
    let mut elements = Vec::new();
    for cell in 0..(nodes - 1).pow(4) {
        let corner: Vec<usize> = (0..4)
            .map(|a| (cell / (nodes - 1).pow(a as u32)) % (nodes - 1))
            .collect();
        for simplex in hyperpbd_core::builders::kuhn_simplices(4) {
            elements.push(
                simplex
                    .iter()
                    .map(|offset| node(&[0, 1, 2, 3].map(|a| corner[a] + offset[a])))
                    .collect(),
            );
        }
    }
    b.family(
        hyperpbd_core::ConstraintFamily::material(
            hyperpbd_core::ConstraintKind::NeoHookean,
            2.0e4,
            0.25,
            elements,
        )
        .with_density(400.0),
    );
    b.hyperplane(vec![0.0, 0.0, 0.0, 1.0], 0.0, 0.5);
    built(b)
}

/// A 2D rope bridge: 21 particles on a parabola between two fixed ends
/// 2 m apart, 20 rigid links; it swings from the authored sag towards the
/// catenary and settles under damping.
///
/// (A chain released sideways from one end would be a whip: chaotic, so
/// rounding differences grow exponentially and CPU/GPU trajectories can only
/// be compared on invariants. The bridge stays near a stable equilibrium.)
pub fn chain2d() -> Scene {
    let mut b = SceneBuilder::new(2)
        .dt(1.0 / 60.0)
        .substeps(20)
        .iterations(2)
        .gravity_along(1, 9.81)
        .damping(1.0);
    let count = 21;
    for i in 0..count {
        let x = 2.0 * i as f64 / (count - 1) as f64;
        let y = 2.0 - 0.6 * x * (2.0 - x) / 1.0;
        let p = hyperpbd_core::Particle::new(vec![x, y], 0.1);
        let index = b.particle(p);
        if i == 0 || i == count - 1 {
            b.fix(index);
        }
    }
    let links = (1..count).map(|i| vec![i - 1, i]).collect();
    b.family(hyperpbd_core::ConstraintFamily::new(
        hyperpbd_core::ConstraintKind::Distance,
        0.0,
        links,
    ));
    b.hyperplane(vec![0.0, 1.0], 0.0, 0.3);
    built(b)
}

/// Four particles on a 20° incline in R^5 with μ = 0.2 < tan 20° ≈ 0.364:
/// they slide down the x_0 direction with acceleration g (sin θ − μ cos θ).
pub fn incline5d() -> Scene {
    let theta: f64 = 20f64.to_radians();
    let mut b = SceneBuilder::new(5)
        .dt(1.0 / 60.0)
        .substeps(10)
        .gravity_along(1, 9.81);
    // Normal tilted from +x1 towards +x0 by θ.
    let normal = vec![theta.sin(), theta.cos(), 0.0, 0.0, 0.0];
    b.hyperplane(normal.clone(), 0.0, 0.2);
    for k in 0..4 {
        let mut x = vec![0.0; 5];
        x[2 + (k % 3)] = k as f64;
        b.particle(hyperpbd_core::Particle::new(x, 1.0));
    }
    built(b)
}

/// The incremental-potential (barrier) path in R^4: a 4 × 4 block of
/// particles thrown down at 2 to 20 m/s onto a flat triangulated square
/// (18 triangles in the x0-x1 plane) with a backstop hyperplane below it;
/// κ = 1000, d^ = 0.02, maximum acceleration residual 1e-3 m/s².
pub fn barrier4d() -> Scene {
    use hyperpbd_core::{Convergence, IncrementalPotentialSettings, Particle, Solver};
    let mut b = SceneBuilder::new(4).gravity(vec![0.0, 0.0, 0.0, -9.81]);
    b.triangle_grid([0, 1], 4, 0.5);
    b.hyperplane(vec![0.0, 0.0, 0.0, 1.0], -0.5, 0.0);
    for i in 0..4 {
        for j in 0..4 {
            let k = f64::from(i * 4 + j);
            b.particle(
                Particle::new(
                    vec![
                        0.2 + 0.35 * f64::from(i),
                        0.2 + 0.35 * f64::from(j),
                        0.0,
                        0.3,
                    ],
                    1.0,
                )
                .with_velocity(vec![0.3, 0.0, 0.0, -(2.0 + 1.2 * k)])
                .with_radius(0.02),
            );
        }
    }
    b.scene_mut().solver = Solver::IncrementalPotential(IncrementalPotentialSettings {
        barrier_stiffness: 1000.0,
        activation_distance: 0.02,
        convergence: Convergence::MaxAccelerationResidual { tolerance: 1e-3 },
        max_iterations: 100,
        cg_iterations: None,
        warm_start: None,
        friction_slip_velocity: None,
    });
    built(b)
}
