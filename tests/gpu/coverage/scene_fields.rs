//! Every scene field with a non-default value, on every GPU kernel.
//!
//! XPBD (`fields(dim)`, R^2, R^3, R^4), each against the golden path frame
//! by frame (`common::differential`: f64 on lavapipe bit for bit from the
//! start, f32 within the per-frame model):
//!
//! ```text
//! gravity            off-axis (every component nonzero)
//! particles          masses 0.05 … 1.55, gravity scales 1, 0.5, 2, 0, −0.3, 1.5
//!                    (cycled), radii 0.01 … 0.06, forces on every third,
//!                    initial velocities, one fixed anchor
//! distance           a chain from the anchor, compliance 1e-6
//! tether             anchor → every chain particle, compliance 1e-7, rest
//!                    = path length (slack until the chain swings out)
//! simplex measure    a strip of triangles (k = 2), compliance 1e-9, rest 10 % off
//! oriented measure   one N-simplex, compliance 1e-8, rest 5 % off
//! obstacles          three planes with tilted normals: μ = 0.7 with contact
//!                    compliance 1e-8, μ = 0.2, μ = 0 (no friction pass)
//! damping            rate 0.7 /s
//! solver             4 substeps × 3 iterations (λ ≠ 0 from the 2nd on)
//! ```
//! Stable: damped, compliant but stiff, landing on planes with friction.
//!
//! Barrier path (`barrier_fields`): gravity off-axis, gravity scales
//! 1, 0.5, 2, 0, −0.5, masses, forces and radii per particle, a plane and a
//! triangle mesh, against the per-frame `BarrierErrorModel`, and in f64 the
//! same Newton iterations and statuses substep by substep.

use super::*;

use common::differential::both;
use common::gpu::adapter_or_skip;
use hyperpbd::gpu::{GpuBarrierBackend, Precision};
use hyperpbd::{
    Backend, ConstraintFamily, ConstraintKind, Convergence, CpuBackend,
    IncrementalPotentialSettings, MinimisationStatus, Obstacle, Particle, Plan, SceneBuilder,
    Solver, State,
};
use hyperpbd_verify::compare::{Divergence, DivergenceModel, Frame};
use hyperpbd_verify::compare_barrier::BarrierErrorModel;

const SCALES: [f64; 6] = [1.0, 0.5, 2.0, 0.0, -0.3, 1.5];

fn fields(dim: usize) -> Scene {
    let mut rng = Lcg(900 + dim as u64);
    let mut gravity: Vec<f64> = (0..dim).map(|a| 0.3 + 0.2 * a as f64).collect();
    gravity[1] = -9.81;
    let mut b = SceneBuilder::new(dim)
        .dt(1.0 / 60.0)
        .substeps(4)
        .iterations(3)
        .gravity(gravity)
        .damping(0.7);
    let point = |rng: &mut Lcg, lead: &[f64]| -> Vec<f64> {
        (0..dim)
            .map(|a| lead.get(a).copied().unwrap_or(0.0) + 0.01 * rng.next())
            .collect()
    };
    let mut count = 0usize;
    let mut add = |b: &mut SceneBuilder, rng: &mut Lcg, x: Vec<f64>| -> usize {
        let k = count;
        count += 1;
        let mut p = Particle::new(x, 0.05 + 0.1 * k as f64)
            .with_gravity_scale(SCALES[k % SCALES.len()])
            .with_radius(0.01 + 0.01 * (k % 6) as f64)
            .with_velocity((0..dim).map(|_| 0.3 * rng.next()).collect());
        if k % 3 == 1 {
            p = p.with_force(
                (0..dim)
                    .map(|a| 0.2 * (a as f64 + 1.0) * rng.next())
                    .collect(),
            );
        }
        b.particle(p)
    };
    // A chain hanging from a fixed anchor, with tethers.
    let anchor = b.particle(Particle::fixed(point(&mut rng, &[0.0, 0.6])));
    let mut chain = vec![anchor];
    for i in 1..=5 {
        let x = point(&mut rng, &[0.08 * i as f64, 0.6]);
        chain.push(add(&mut b, &mut rng, x));
    }
    let links = chain.windows(2).map(|w| w.to_vec()).collect();
    b.family(ConstraintFamily::new(ConstraintKind::Distance, 1e-6, links));
    b.tethers(anchor, &chain, 1e-7);
    // A strip of triangles (squared area), rest 10 % off.
    let strip: Vec<usize> = (0..5)
        .map(|i| {
            let x = point(
                &mut rng,
                &[0.6 + 0.1 * i as f64, 0.2 + 0.1 * (i % 2) as f64],
            );
            add(&mut b, &mut rng, x)
        })
        .collect();
    let triangles: Vec<Vec<usize>> = strip.windows(3).map(|w| w.to_vec()).collect();
    let mut family = ConstraintFamily::new(ConstraintKind::SimplexMeasure, 1e-9, triangles);
    family.rest = Some(vec![0.9 * 0.25 * 0.01; strip.len() - 2]);
    b.family(family);
    // One N-simplex (oriented measure), rest 5 % off.
    let base = [-0.6, 0.15];
    let first = point(&mut rng, &base);
    let mut simplex = vec![add(&mut b, &mut rng, first)];
    for a in 0..dim {
        let mut x = point(&mut rng, &base);
        x[a] += 0.15;
        simplex.push(add(&mut b, &mut rng, x));
    }
    let volume = 0.15f64.powi(dim as i32) / (1..=dim).map(|k| k as f64).product::<f64>();
    let mut family = ConstraintFamily::new(ConstraintKind::OrientedMeasure, 1e-8, vec![simplex]);
    family.rest = Some(vec![0.95 * volume]);
    b.family(family);
    // Free particles just above and in the planes.
    for i in 0..7 {
        let x = point(&mut rng, &[-0.3 + 0.1 * i as f64, 0.02 * (i % 3) as f64]);
        add(&mut b, &mut rng, x);
    }
    let mut scene = b.build().expect("valid");
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: unit(dim, &[0.1, 1.0, 0.05, 0.02]),
        offset: -0.02,
        friction: 0.7,
        compliance: 1e-8,
        motion: Vec::new(),
    });
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: unit(dim, &[1.0, 0.3, -0.1, 0.1]),
        offset: -0.75,
        friction: 0.2,
        compliance: 0.0,
        motion: Vec::new(),
    });
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: unit(dim, &[-1.0, 0.25, 0.1]),
        offset: -0.85,
        friction: 0.0,
        compliance: 0.0,
        motion: Vec::new(),
    });
    valid(scene)
}

/// The scene is what the docs say: every family kind, three planes with
/// different μ (one frictionless: no friction pass for it), forces,
/// gravity scales and damping in the plan.
#[test]
fn fields_scene_has_every_field_non_default() {
    for dim in [2, 3, 4] {
        let plan = Plan::compile(&fields(dim)).expect("compiles");
        let kinds: Vec<&str> = plan.families.iter().map(|f| f.kind.name()).collect();
        for kind in [
            "distance",
            "tether",
            "simplex_measure",
            "oriented_measure",
            "hyperplane_contact",
        ] {
            assert!(
                kinds.contains(&kind),
                "R^{dim}: no {kind} family: {kinds:?}"
            );
        }
        assert!(
            plan.families
                .iter()
                .all(|f| f.compliance > 0.0 || f.kind.is_inequality())
        );
        let frictions = plan
            .substep_kernels
            .iter()
            .filter(|k| matches!(k, hyperpbd::Kernel::Friction { .. }))
            .count();
        assert_eq!(
            frictions, 2,
            "R^{dim}: friction passes for μ = 0.7 and 0.2 only"
        );
        assert!(plan.predict.gravity && plan.predict.force && plan.damping.is_some());
        assert!(plan.gravity.iter().all(|&g| g != 0.0));
        let scales: Vec<f64> = plan.gravity_scale.clone();
        for s in SCALES {
            assert!(scales.contains(&s), "R^{dim}: gravity scale {s}");
        }
        assert!(plan.iterations >= 2);
    }
}

/// R^2 caught lavapipe reassociating the contact kernel's
/// (n₀x₀ + n₁x₁) − r into n₀x₀ + (n₁x₁ − r) (WGSL cannot forbid it);
/// `kept()` in shaders/prelude.wgsl now rounds n·x as written, and this
/// test holds R^2 to the golden path bit for bit like R^3 and R^4.
#[test]
fn every_field_on_every_xpbd_kernel_2d() {
    both(
        "every_field_on_every_xpbd_kernel_2d",
        "fields 2D",
        &fields(2),
        30,
    );
}

#[test]
fn every_field_on_every_xpbd_kernel_3d() {
    both(
        "every_field_on_every_xpbd_kernel_3d",
        "fields 3D",
        &fields(3),
        30,
    );
}

#[test]
fn every_field_on_every_xpbd_kernel_4d() {
    both(
        "every_field_on_every_xpbd_kernel_4d",
        "fields 4D",
        &fields(4),
        30,
    );
}

fn barrier_fields(tolerance: f64) -> Scene {
    let mut scene = Scene::new(3, 1.0 / 60.0, 2, 1);
    scene.gravity = Some(vec![0.8, -9.81, -0.4]);
    let scales = [1.0, 0.5, 2.0, 0.0, -0.5];
    let mut rng = Lcg(77);
    for (k, s) in scales.iter().enumerate() {
        let mut p = Particle::new(
            vec![
                0.2 * k as f64 - 0.4,
                0.08 + 0.05 * k as f64,
                0.1 * rng.next(),
            ],
            0.3 + 0.4 * k as f64,
        )
        .with_gravity_scale(*s)
        .with_radius(0.01 + 0.005 * k as f64)
        .with_velocity(vec![0.5 * rng.next(), -1.0 - k as f64, 0.2 * rng.next()]);
        if k % 2 == 0 {
            p = p.with_force(vec![0.5, -1.5 * k as f64, 0.25]);
        }
        scene.particles.push(p);
    }
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: unit(3, &[0.05, 1.0, 0.0]),
        offset: 0.0,
        friction: 0.0,
        compliance: 0.0,
        motion: Vec::new(),
    });
    scene.obstacles.push(Obstacle::SimplexMesh {
        vertices: vec![
            vec![-0.5, 0.05, -0.5],
            vec![0.6, 0.05, -0.5],
            vec![-0.5, 0.02, 0.6],
        ],
        simplices: vec![vec![0, 1, 2]],
        friction: 0.0,
        motion: Vec::new(),
    });
    scene.solver = Solver::IncrementalPotential(IncrementalPotentialSettings {
        barrier_stiffness: 2e3,
        activation_distance: 0.03,
        convergence: Convergence::MaxAccelerationResidual { tolerance },
        max_iterations: 100,
        cg_iterations: None,
        warm_start: None,
        friction_slip_velocity: None,
    });
    valid(scene)
}

/// `frames` frames of the barrier path on the GPU, each also on the CPU
/// from the GPU's previous state, within the per-frame `BarrierErrorModel`;
/// in f64 the same iterations and statuses substep by substep (the ln of
/// shaders/ln_f64.wgsl differs from libm's by rounding only, far below the
/// decisions these scenes make). Returns the largest measured / bound.
pub fn barrier_frames(
    adapter: &wgpu::Adapter,
    name: &str,
    scene: &Scene,
    frames: u64,
    precision: Precision,
) -> f64 {
    let plan = Plan::compile(scene).expect("valid");
    let state = State::from_scene(scene);
    let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
    let mut gpu =
        GpuBarrierBackend::with_adapter(adapter, plan.clone(), &state, precision).expect("gpu");
    let mut model = BarrierErrorModel::new(&plan, precision);
    let mut worst: f64 = 0.0;
    for frame in 1..=frames {
        let start = gpu.read_state().expect("gpu state");
        cpu.write_state(&start).expect("cpu write_state");
        let a = cpu.step().expect("cpu step");
        let b = gpu
            .step()
            .unwrap_or_else(|e| panic!("{name} {precision} frame {frame}: {e}"));
        for m in &b.minimisation {
            assert!(
                !matches!(m.status, MinimisationStatus::Refused(_)),
                "{name} {precision} frame {frame}: {m:?}"
            );
        }
        if precision == Precision::F64 {
            let shape = |r: &hyperpbd::StepReport| {
                r.minimisation
                    .iter()
                    .map(|m| (m.iterations, m.status.clone()))
                    .collect::<Vec<_>>()
            };
            assert_eq!(
                shape(&a),
                shape(&b),
                "{name} f64 frame {frame}: Newton iterations and statuses per substep"
            );
        }
        let (x, y) = (
            cpu.read_state().expect("cpu"),
            gpu.read_state().expect("gpu"),
        );
        let bounds = model
            .frame_bounds(Frame {
                start: &start,
                golden: (&a, &x),
                other: (&b, &y),
            })
            .expect("bounds");
        let d = Divergence::new(frame, &x, &y, bounds);
        assert!(d.within(), "{name} {precision} frame {frame}: {d:?}");
        worst = worst.max(d.ratio());
    }
    worst
}

#[test]
fn barrier_path_with_gravity_scales_masses_and_forces() {
    for precision in [Precision::F32, Precision::F64] {
        let Some((adapter, _)) = adapter_or_skip(
            "barrier_path_with_gravity_scales_masses_and_forces",
            precision,
        ) else {
            return;
        };
        let tolerance = match precision {
            Precision::F32 => 1.0,
            Precision::F64 => 1e-6,
        };
        let worst = barrier_frames(
            &adapter,
            "barrier fields",
            &barrier_fields(tolerance),
            40,
            precision,
        );
        common::bound::print_bound(
            format_args!("barrier fields 3D {precision}: 40 frames, per-frame model"),
            format_args!("{worst:.3e}"),
            "1",
            "largest measured / bound of BarrierErrorModel, one frame from the GPU's state",
        );
    }
}

/// The barrier scene has what the docs list.
#[test]
fn barrier_fields_scene_is_what_it_says() {
    let scene = barrier_fields(1e-6);
    let plan = Plan::compile(&scene).unwrap();
    assert!(plan.incremental_potential().is_some());
    let scales: Vec<f64> = plan.gravity_scale.clone();
    assert_eq!(scales, vec![1.0, 0.5, 2.0, 0.0, -0.5]);
    assert!(plan.force.iter().any(|&f| f != 0.0));
}
