//! Simplex meshes on the XPBD path on the GPU (shaders/mesh_contact.wgsl):
//! balls dropped and sliding on triangulated floors and a tilted ramp
//! beside a distance chain, segments in R^2, triangles in R^3 (also 1 000 m
//! from the world origin, where f32 works relative to the scene origin),
//! tetrahedra in R^4 — gpu-f64 the golden path bit for bit, reports
//! included, and gpu-f32 the f32 reference bit for bit, every frame, on
//! lavapipe, with the floor moving (a belt with a keyframed lift in R^2, a
//! turntable 1 000 m out in R^3, a tilt in R^4: core/src/moving_mesh.rs)
//! and the ramp static; the built-in `bowl3d` (36 balls in contact with each other
//! and a curved mesh); a batch of worlds sweeping the floor's μ from 0, each world
//! its own run. On another adapter nothing is claimed bit for bit, and no
//! per-frame model bounds a mesh contact yet: the largest difference is
//! printed (`MESH | … | unbounded`) and the run must stay finite and
//! resting on the floor.

use crate::common;

use common::exact::{assert_f32_reference_step, bits, f32_identical, f64_identical};
use common::gpu::adapter_or_skip;
use common::meshes::floor;
use common::motion_scenes::{belt, spin};
use hyperpbd::motion::Motion;
use hyperpbd::{
    Backend, ConstraintFamily, ConstraintKind, CpuBackend, F32Reference, Obstacle, Particle, Plan,
    Scene, State,
};
use hyperpbd_gpu::{GpuBackend, Precision, SceneOrigin};
use hyperpbd_verify::compare::max_abs_diff;

const G: f64 = 9.81;

/// `floor` turned by `angle` in the (e_0, e_1) plane about the origin
/// (a ramp), with its own μ.
fn ramp(dim: usize, angle: f64, friction: f64) -> Obstacle {
    let Obstacle::SimplexMesh {
        vertices,
        simplices,
        ..
    } = floor(dim, 0.0, 1.0, 3, 0.0)
    else {
        unreachable!("floor is a mesh")
    };
    let (s, c) = angle.sin_cos();
    let vertices = vertices
        .into_iter()
        .map(|mut v| {
            let (x, y) = (v[0], v[1]);
            v[0] = c * x - s * y + 3.0;
            v[1] = s * x + c * y;
            v
        })
        .collect();
    Obstacle::SimplexMesh {
        vertices,
        simplices,
        friction,
        motion: Vec::new(),
    }
}

/// Six balls (r = 0.1) over a floor of `cells` cells a side (μ = 0.4),
/// two of them over a grid vertex and an edge, sliding along e_0 and e_2;
/// two over a ramp (μ = 0.2); a three-link distance chain falling on the
/// floor; every position shifted by `shift` along e_0.
fn scene(dim: usize, cells: usize, shift: f64) -> Scene {
    let mut s = Scene::new(dim, 1.0 / 60.0, 4, 2);
    let mut g = vec![0.0; dim];
    g[1] = -G;
    s.gravity = Some(g);
    let ball = |x0: f64, height: f64, slide: f64| {
        let mut x = vec![0.13; dim];
        x[0] = x0 + shift;
        x[1] = height;
        let mut v = vec![0.0; dim];
        v[0] = slide;
        v[dim - 1] += 0.3 * slide;
        Particle::new(x, 1.0).with_radius(0.1).with_velocity(v)
    };
    s.particles = vec![
        ball(-0.6, 0.12, 1.0),
        ball(0.0, 0.3, 0.0),
        ball(0.5, 0.105, -0.7),
        ball(-0.25, 0.2, 0.4),
        ball(3.1, 0.4, 0.0),
        ball(3.3, 0.6, 0.5),
    ];
    // A grid vertex and an edge midpoint of the floor (cells of 2/cells).
    let step = 2.0 / cells as f64;
    let mut on_vertex = vec![0.0; dim];
    on_vertex[0] = -1.0 + step + shift;
    on_vertex[1] = 0.15;
    s.particles
        .push(Particle::new(on_vertex.clone(), 1.0).with_radius(0.1));
    let mut on_edge = on_vertex;
    on_edge[0] += 0.5 * step;
    s.particles
        .push(Particle::new(on_edge, 2.0).with_radius(0.1));
    let first = s.particles.len();
    for k in 0..3 {
        let mut x = vec![-0.2; dim];
        x[0] = -0.5 + 0.25 * k as f64 + shift;
        x[1] = 0.5;
        s.particles.push(Particle::new(x, 0.5).with_radius(0.05));
    }
    let links = (0..2).map(|k| vec![first + k, first + k + 1]).collect();
    s.constraints = vec![ConstraintFamily::new(ConstraintKind::Distance, 0.0, links)];
    let shifted = |o: Obstacle| match o {
        Obstacle::SimplexMesh {
            vertices,
            simplices,
            friction,
            motion,
        } => Obstacle::SimplexMesh {
            vertices: vertices
                .into_iter()
                .map(|mut v| {
                    v[0] += shift;
                    v
                })
                .collect(),
            simplices,
            friction,
            motion,
        },
        other => other,
    };
    s.obstacles = vec![
        shifted(floor(dim, 0.0, 1.0, cells, 0.4)),
        shifted(ramp(dim, -0.3, 0.2)),
    ];
    s
}

/// Runs `scene` `frames` frames on the GPU at both precisions against
/// the golden path (f64) and the f32 reference (f32), bit for bit where
/// the adapter's rule claims it.
fn against_the_references(test: &str, name: &str, (scene, shift): (&Scene, f64), frames: u64) {
    let plan = Plan::compile(scene).expect("scene compiles");
    let state = State::from_scene(scene);
    for precision in [Precision::F64, Precision::F32] {
        let Some((adapter, summary)) = adapter_or_skip(test, precision) else {
            return;
        };
        let mut gpu = GpuBackend::with_adapter(&adapter, plan.clone(), &state, precision)
            .unwrap_or_else(|e| panic!("{name} {precision}: GPU backend: {e}"));
        let mut golden = CpuBackend::new(plan.clone(), &state).expect("CPU backend");
        let exact = match precision {
            Precision::F64 => f64_identical(&summary),
            Precision::F32 => f32_identical(&summary),
        };
        // The f32 reference, where the GPU is held to it bit for bit.
        let mut reference = (precision == Precision::F32 && exact).then(|| {
            let origin = SceneOrigin::for_state(plan.dim, &state.positions, precision);
            F32Reference::new(plan.clone(), &state, origin.as_slice()).expect("f32 reference")
        });
        let (mut largest, mut touched) = (0.0f64, 0usize);
        for frame in 1..=frames {
            let report = gpu
                .step()
                .unwrap_or_else(|e| panic!("{name} {precision}: GPU step {frame}: {e}"));
            let sg = gpu.read_state().expect("GPU read_state");
            touched = touched.max(report.active_contacts);
            match (precision, exact) {
                (Precision::F64, true) => {
                    let golden_report = golden.step().expect("CPU step");
                    let sc = golden.read_state().expect("CPU read_state");
                    assert!(
                        bits(&sc) == bits(&sg),
                        "{name} f64 frame {frame}: not the golden path bit for bit: \
                         max |dx| {:e}, max |dv| {:e}",
                        max_abs_diff(&sc.positions, &sg.positions),
                        max_abs_diff(&sc.velocities, &sg.velocities)
                    );
                    let golden_report = hyperpbd::StepReport {
                        threads: report.threads,
                        ..golden_report
                    };
                    assert_eq!(golden_report, report, "{name} f64 frame {frame}: reports");
                }
                (Precision::F32, true) => {
                    let reference = reference.as_mut().expect("made for exact f32");
                    assert_f32_reference_step(name, frame, reference, &report, &sg);
                }
                (_, false) => {
                    golden.step().expect("CPU step");
                    let sc = golden.read_state().expect("CPU read_state");
                    largest = largest.max(max_abs_diff(&sc.positions, &sg.positions));
                    assert!(sg.positions.iter().all(|c| c.is_finite()), "{name}");
                }
            }
        }
        assert!(touched > 0, "{name} {precision}: no ball touched a mesh");
        let last = gpu.read_state().expect("GPU read_state");
        for (i, p) in last.positions.chunks_exact(plan.dim).enumerate() {
            // Over the floor (top at y = 0): no ball went through it.
            if (p[0] - shift).abs() < 0.9 {
                assert!(
                    p[1] > 0.0,
                    "{name} {precision}: particle {i} at y = {}",
                    p[1]
                );
            }
        }
        match exact {
            true => println!("MESH | {name} | {frames} frames | {precision} | exact"),
            false => println!(
                "MESH | {name} | {frames} frames | {precision} | max |dx| vs the CPU {largest:e} | unbounded"
            ),
        }
    }
}

/// `scene` with its floor moving by `motion` (the ramp stays).
fn moving_floor(mut s: Scene, motion: Vec<Motion>) -> Scene {
    if let Obstacle::SimplexMesh { motion: m, .. } = &mut s.obstacles[0] {
        *m = motion;
    }
    s
}

#[test]
fn mesh_contacts_match_the_references_in_r2() {
    // The floor a belt with a keyframed lift.
    let mut belt_and_lift = belt(0.2, 2);
    belt_and_lift.push(Motion::Keyframes {
        times: vec![0.1, 0.4],
        translations: vec![vec![0.0; 2], vec![0.0, 0.05]],
    });
    against_the_references(
        "mesh_contacts_match_the_references_in_r2",
        "mesh R^2, the floor a belt and lift",
        (&moving_floor(scene(2, 8, 0.0), belt_and_lift), 0.0),
        40,
    );
}

#[test]
fn mesh_contacts_match_the_references_in_r3_far_from_the_origin() {
    // The floor a turntable about a point 1 000 m out (f32 works relative
    // to the scene origin: the frame map's e = Rᵀ(o − b) − o).
    let turning = spin([0, 2], vec![1000.0, 0.0, 0.13], 1.0);
    against_the_references(
        "mesh_contacts_match_the_references_in_r3_far_from_the_origin",
        "mesh R^3 at x = 1000, the floor turning",
        (&moving_floor(scene(3, 6, 1000.0), turning), 1000.0),
        30,
    );
}

#[test]
fn mesh_contacts_match_the_references_in_r4() {
    // The floor tilting in (e1, e3) while it slides along e0.
    let mut tilt = spin([1, 3], vec![0.0; 4], 0.2);
    tilt.extend(belt(0.1, 4));
    against_the_references(
        "mesh_contacts_match_the_references_in_r4",
        "mesh R^4, the floor tilting",
        (&moving_floor(scene(4, 2, 0.0), tilt), 0.0),
        20,
    );
}

#[test]
fn the_bowl_with_particle_contact_matches_the_references() {
    // Mesh contact among the particle contact stage's host dispatches.
    against_the_references(
        "the_bowl_with_particle_contact_matches_the_references",
        "bowl3d",
        (&hyperpbd::scenes::bowl3d(), 0.0),
        30,
    );
}

#[test]
fn every_world_of_a_mesh_friction_sweep_is_its_own_run() {
    // μ of the floor from 0 (its friction stage absent in that world).
    let worlds: Vec<Scene> = [0.0, 0.25, 0.6]
        .into_iter()
        .map(|mu| {
            let mut s = scene(3, 4, 0.0);
            if let Obstacle::SimplexMesh { friction, .. } = &mut s.obstacles[0] {
                *friction = mu;
            }
            s
        })
        .collect();
    crate::batch::f64_worlds_are_their_own_runs("gpu_batch mesh friction", &worlds, 20);
}
