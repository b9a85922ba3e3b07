//! The simplex mesh hierarchy at scale (a plain timing run, not criterion:
//! its cases take seconds each). `cargo bench --bench mesh_hierarchy`.
//!
//! ```text
//! build/1M            SimplexHierarchy::build over a flat 1 002 528-triangle mesh
//! query/cpu           walks of 100 000 particle candidate boxes (reach d^ = 0.01)
//!                     over a 100 352-triangle mesh: queries per second
//! eval/{mesh,plane}   evaluate_particle_barrier of 100 489 particles over that
//!                     mesh / over one plane, one thread, and the ratio
//! gpu-{f32,f64}       BarrierKernels::evaluate of the same particles, one dispatch
//!                     + wait on resident buffers (lavapipe: NODEVICE_SELECT=1),
//!                     mesh and plane
//! xpbd/{mesh,plane}   CpuBackend (one thread) stepping 317² = 100 489 balls
//!                     (r = 0.02, μ = 0.3) resting on and sliding over the
//!                     flat 100 352-triangle mesh y = 0 / the plane y = 0:
//!                     XPBD_STEPS steps of 4 substeps × 2 iterations, per round;
//!                     XPBD_ROUNDS interleaved rounds, medians, and the ratio
//! ```
//! Every other case is run `REPEATS` times and the fastest is printed.
//! `cargo bench --bench mesh_hierarchy -- xpbd` runs only the xpbd case.
//!
//! `cargo bench` passes `--bench`; `cargo test --all-targets` runs this
//! binary without it: then a smoke run of every case once, on a 40 × 40
//! mesh (3 200 triangles) under 50² particles (xpbd: 20² balls, one step).

use std::hint::black_box;
use std::time::Instant;

use hyperpbd::barrier::{
    BarrierLaw, BarrierObstacles, ParticleBarrier, candidate_box, distance_margin,
    evaluate_particle_barrier,
};
use hyperpbd::core::geometry::SimplexHierarchy;
use hyperpbd::gpu::Precision;
use hyperpbd::gpu::barrier::BarrierKernels;
use hyperpbd::{Backend, CpuBackend, Obstacle, Particle, Plan, Scene, State};

const REPEATS: usize = 3;
const XPBD_STEPS: usize = 2;
const XPBD_ROUNDS: usize = 3;
const LAW: BarrierLaw = BarrierLaw {
    stiffness: 1e3,
    activation_distance: 0.01,
};

/// A flat `side` × `side` mesh in the plane y = 0 (cells 0.1).
fn grid(side: usize) -> (Vec<Vec<f64>>, Vec<Vec<usize>>) {
    let mut vertices = Vec::new();
    for j in 0..=side {
        for i in 0..=side {
            vertices.push(vec![i as f64 * 0.1, 0.0, j as f64 * 0.1]);
        }
    }
    let v = |i: usize, j: usize| j * (side + 1) + i;
    let mut simplices = Vec::new();
    for j in 0..side {
        for i in 0..side {
            simplices.push(vec![v(i, j), v(i + 1, j), v(i, j + 1)]);
            simplices.push(vec![v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]);
        }
    }
    (vertices, simplices)
}

/// `rows`² particles of radius 0.005 spread over the mesh at heights
/// 0.012–0.02 (the scenes of the CLI measurement in docs/barrier.md).
fn particles(side: usize, rows: usize) -> (Vec<f64>, Vec<f64>) {
    let s = side as f64 * 0.1 / rows as f64;
    let mut x = Vec::new();
    for j in 0..rows {
        for i in 0..rows {
            x.extend([
                (i as f64 + 0.5) * s,
                0.012 + 0.004 * ((i + j) % 3) as f64,
                (j as f64 + 0.5) * s,
            ]);
        }
    }
    (x, vec![0.005; rows * rows])
}

/// Whether this is a measuring run (`cargo bench` passes `--bench`), not
/// the smoke run of `cargo test --all-targets`.
fn measuring() -> bool {
    std::env::args().any(|a| a == "--bench")
}

fn fastest(mut f: impl FnMut()) -> f64 {
    let repeats = if measuring() { REPEATS } else { 1 };
    (0..repeats)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn scene(obstacle: Obstacle) -> Scene {
    let mut scene = Scene::new(3, 1.0 / 60.0, 1, 1);
    scene.obstacles.push(obstacle);
    scene
}

/// `rows`² balls of radius 0.02 resting on y = 0 over the `side` × `side`
/// mesh, sliding at 0.5 m/s in directions that vary from ball to ball.
fn xpbd_scene(side: usize, rows: usize, obstacle: Obstacle) -> Scene {
    let mut scene = Scene::new(3, 1.0 / 60.0, 4, 2);
    scene.gravity = Some(vec![0.0, -9.81, 0.0]);
    let s = side as f64 * 0.1 / rows as f64;
    for j in 0..rows {
        for i in 0..rows {
            let angle = (i * 7 + j * 13) as f64 * 0.37;
            let x = vec![(i as f64 + 0.5) * s, 0.02, (j as f64 + 0.5) * s];
            let v = vec![0.5 * angle.cos(), 0.0, 0.5 * angle.sin()];
            let ball = Particle::new(x, 1.0).with_radius(0.02);
            scene.particles.push(ball.with_velocity(v));
        }
    }
    scene.obstacles.push(obstacle);
    scene
}

/// The xpbd case: interleaved rounds of `steps` steps on the mesh and on
/// the plane, one thread; medians and their ratio.
fn xpbd(side: usize, rows: usize, (steps, rounds): (usize, usize)) {
    let (vertices, simplices) = grid(side);
    let triangles = simplices.len();
    let mesh = Obstacle::SimplexMesh {
        vertices,
        simplices,
        friction: 0.3,
        motion: Vec::new(),
    };
    let plane = Obstacle::Hyperplane {
        normal: vec![0.0, 1.0, 0.0],
        offset: 0.0,
        friction: 0.3,
        compliance: 0.0,
        motion: Vec::new(),
    };
    let scenes = [xpbd_scene(side, rows, mesh), xpbd_scene(side, rows, plane)];
    let mut seconds = [vec![], vec![]];
    let mut ends = scenes.each_ref().map(State::from_scene);
    for _ in 0..rounds {
        for (k, scene) in scenes.iter().enumerate() {
            let plan = Plan::compile(scene).expect("valid scene");
            let state = State::from_scene(scene);
            let mut sim = CpuBackend::with_threads(plan, &state, 1).expect("cpu");
            let t = Instant::now();
            for _ in 0..steps {
                sim.step().expect("step");
            }
            seconds[k].push(t.elapsed().as_secs_f64());
            ends[k] = sim.read_state().expect("state");
        }
    }
    let median = |s: &mut Vec<f64>| {
        s.sort_by(f64::total_cmp);
        s[s.len() / 2]
    };
    let (mesh, plane) = (median(&mut seconds[0]), median(&mut seconds[1]));
    let n = scenes[0].particles.len();
    println!("xpbd/mesh: {n} balls on {triangles} triangles, {steps} steps in {mesh:.3} s");
    println!("xpbd/plane: {n} balls on y = 0, {steps} steps in {plane:.4} s");
    let apart = ends[0]
        .positions
        .iter()
        .zip(&ends[1].positions)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    println!(
        "xpbd mesh / plane: {:.2}x (medians of {rounds} interleaved rounds, one thread; final positions {apart:.1e} m apart)",
        mesh / plane
    );
    println!("xpbd/mesh final state hash {:016x}", ends[0].hash());
}

fn main() {
    if measuring() {
        xpbd(224, 317, (XPBD_STEPS, XPBD_ROUNDS));
    } else {
        xpbd(20, 20, (1, 1));
    }
    if std::env::args().any(|a| a == "xpbd") {
        return;
    }
    // (side of the built mesh, side of the queried mesh, particle rows)
    let (built, side, rows) = if measuring() {
        (708, 224, 317)
    } else {
        (40, 40, 50)
    };
    let (vertices, simplices) = grid(built);
    let t = fastest(|| {
        black_box(SimplexHierarchy::build(3, &vertices, &simplices));
    });
    println!("build: {} triangles in {t:.3} s", simplices.len());

    let (vertices, simplices) = grid(side);
    let mesh = BarrierObstacles::compile(&scene(Obstacle::SimplexMesh {
        vertices,
        simplices,
        friction: 0.0,
        motion: Vec::new(),
    }));
    let plane = BarrierObstacles::compile(&scene(Obstacle::Hyperplane {
        normal: vec![0.0, 1.0, 0.0],
        offset: 0.0,
        friction: 0.0,
        compliance: 0.0,
        motion: Vec::new(),
    }));
    let (x, r) = particles(side, rows);
    let n = r.len();
    let mut candidates = 0;
    let t = fastest(|| {
        let (mut lo, mut hi) = ([0.0; 3], [0.0; 3]);
        candidates = 0;
        for i in 0..n {
            let xi = &x[3 * i..3 * i + 3];
            candidate_box(
                xi,
                r[i],
                LAW.activation_distance,
                mesh.scale,
                distance_margin(3, f64::EPSILON),
                &mut lo,
                &mut hi,
            );
            candidates += mesh.hierarchy.walk(&lo, &hi).count();
        }
    });
    println!(
        "query/cpu: {n} walks over {} triangles in {t:.3} s: {:.2e} queries/s, {:.2} candidates each",
        mesh.simplex_count(),
        n as f64 / t,
        candidates as f64 / n as f64
    );
    let mut seconds = [0.0; 2];
    for (k, (name, obstacles)) in [("mesh", &mesh), ("plane", &plane)].into_iter().enumerate() {
        let mut out = ParticleBarrier::new(3);
        seconds[k] = fastest(|| {
            let mut energy = 0.0;
            for i in 0..n {
                evaluate_particle_barrier(&LAW, obstacles, &x[3 * i..3 * i + 3], r[i], &mut out);
                energy += out.energy;
            }
            black_box(energy);
        });
        println!(
            "eval/{name}: {n} particles in {:.4} s (one thread)",
            seconds[k]
        );
    }
    println!("eval mesh / plane: {:.1}x", seconds[0] / seconds[1]);

    for (name, precision) in [("gpu-f32", Precision::F32), ("gpu-f64", Precision::F64)] {
        let adapter = match hyperpbd::gpu::request_adapter(precision) {
            Ok((a, _)) => a,
            Err(e) => {
                println!("SKIPPED {name}: {e}");
                continue;
            }
        };
        for (what, obstacles) in [("mesh", &mesh), ("plane", &plane)] {
            let kernels = match BarrierKernels::new(&adapter, precision, 3, LAW, obstacles) {
                Ok(k) => k,
                Err(e) => {
                    println!("SKIPPED {name}/{what}: {e}");
                    continue;
                }
            };
            let batch = match kernels.prepare(&x, &r, &[], n) {
                Ok(b) => b,
                Err(e) => {
                    println!("SKIPPED {name}/{what}: {e}");
                    continue;
                }
            };
            let t = fastest(|| kernels.dispatch_evaluate(&batch, 1).expect("dispatch"));
            kernels.read(&batch).expect("no loop cut short");
            println!("{name}/{what}: {n} particles in {t:.4} s (one dispatch + wait)");
        }
    }
}
