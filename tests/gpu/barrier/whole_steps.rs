//! Whole steps: GpuBarrierBackend against the CPU golden backend.

use super::*;

use hyperpbd::builders::triangle_grid;

use hyperpbd::gpu::GpuBarrierBackend;
use hyperpbd::{Backend, Convergence, CpuBackend, MinimisationStatus, Particle, Plan, State};
use hyperpbd_verify::compare_barrier::BarrierErrorModel;

fn solver(
    convergence: Convergence,
    kappa: f64,
    dhat: f64,
    max_iterations: u32,
) -> hyperpbd::Solver {
    hyperpbd::Solver::IncrementalPotential(hyperpbd::IncrementalPotentialSettings {
        barrier_stiffness: kappa,
        activation_distance: dhat,
        convergence,
        max_iterations,
        cg_iterations: None,
        warm_start: None,
        friction_slip_velocity: None,
    })
}

fn smallest_distance(scene: &Scene, state: &State) -> f64 {
    let geometry = BarrierObstacles::compile(scene);
    let mut n = vec![0.0; scene.dim];
    let mut d = f64::INFINITY;
    for (i, p) in scene.particles.iter().enumerate() {
        if p.fixed {
            continue;
        }
        for o in 0..geometry.len() {
            d = d.min(geometry.distance(o, state.position(i), p.radius, &mut n));
        }
    }
    d
}

/// Runs `steps` steps on the CPU and on the GPU at `precision`, checking the
/// divergence against [`BarrierErrorModel`] and d > 0 (in f64, on the GPU's
/// own state) after every step. Returns (worst ratio, steps with identical
/// states, smallest d on the GPU, "dx / bound, dv / bound" at the last step).
fn whole_steps(
    adapter: &wgpu::Adapter,
    scene: &Scene,
    precision: Precision,
    steps: u64,
) -> (f64, u64, f64, String) {
    let plan = Plan::compile(scene).expect("valid");
    let state = State::from_scene(scene);
    let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
    let mut gpu =
        GpuBarrierBackend::with_adapter(adapter, plan.clone(), &state, precision).expect("gpu");
    let mut model = BarrierErrorModel::new(&plan, precision);
    let mut scale = hyperpbd_verify::compare::coordinate_scale(&state);
    let mut worst: f64 = 0.0;
    let mut identical = 0;
    let mut smallest = f64::INFINITY;
    let mut last = String::new();
    for step in 1..=steps {
        let a = cpu.step().expect("cpu step");
        let b = gpu.step().expect("gpu step");
        assert_eq!(a.minimisation.len(), b.minimisation.len());
        for m in &b.minimisation {
            assert!(
                !matches!(m.status, MinimisationStatus::Refused(_)),
                "{precision}: {m:?}"
            );
        }
        let golden = cpu.read_state().expect("cpu state");
        let other = gpu.read_state().expect("gpu state");
        scale = scale.max(hyperpbd_verify::compare::coordinate_scale(&golden));
        model.advance(&a.minimisation, &b.minimisation, scale);
        let dx = hyperpbd_verify::compare::max_abs_diff(&golden.positions, &other.positions);
        let dv = hyperpbd_verify::compare::max_abs_diff(&golden.velocities, &other.velocities);
        let (px, pv) = (model.position_bound(), model.velocity_bound());
        assert!(
            dx <= px && dv <= pv,
            "{precision} step {step}: |dx| {dx:e}/{px:e}, |dv| {dv:e}/{pv:e}"
        );
        if dx == 0.0 && dv == 0.0 {
            identical += 1;
        }
        worst = worst.max(dx / px).max(dv / pv);
        last = format!("{dx:.2e} / {px:.2e}, {dv:.2e} / {pv:.2e}");
        let d = smallest_distance(scene, &other);
        assert!(
            scene.particles.iter().all(|p| p.fixed) || d > 0.0,
            "{precision} step {step}: GPU state at d = {d:e}"
        );
        smallest = smallest.min(d);
    }
    (worst, identical, smallest, last)
}

fn drop_scene(count: usize, speed: f64, convergence: Convergence) -> Scene {
    let mut scene = Scene::new(3, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, -9.81, 0.0]);
    let mut rng = Lcg(3 + count as u64);
    for i in 0..count {
        scene.particles.push(
            Particle::new(
                vec![0.3 * rng.next(), 1.0 + 0.5 * rng.next(), 0.3 * rng.next()],
                1.0 + 0.5 * rng.next(),
            )
            .with_velocity(vec![0.0, -speed * (0.5 + 0.5 * rng.next()), 0.0])
            .with_radius(0.05),
        );
        if i % 7 == 3 {
            scene.particles.push(Particle::fixed(vec![5.0, -1.0, 0.0]));
        }
    }
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: vec![0.0, 1.0, 0.0],
        offset: 0.0,
        friction: 0.0,
        compliance: 0.0,
        motion: Vec::new(),
    });
    scene.solver = solver(convergence, 1e3, 0.01, 200);
    scene
}

#[test]
fn seed_example_on_the_gpu() {
    for precision in PRECISIONS {
        let Some((adapter, _)) = adapter_or_skip("seed_example_on_the_gpu", precision) else {
            continue;
        };
        for (dt, convergence, expected) in [
            (5e-6, Convergence::PackedGradient { tolerance: 1e-8 }, 1.0),
            (2e-6, Convergence::PackedGradient { tolerance: 1e-8 }, 0.0),
            (
                2e-6,
                Convergence::MaxAccelerationResidual { tolerance: 1e-3 },
                1.0,
            ),
        ] {
            let mut scene = Scene::new(1, dt, 1, 1);
            scene
                .particles
                .push(Particle::new(vec![0.0], 1.0).with_force(vec![1000.0]));
            scene.solver = solver(convergence, 1.0, 0.1, 20);
            let plan = Plan::compile(&scene).unwrap();
            let state = State::from_scene(&scene);
            let mut cpu = CpuBackend::new(plan.clone(), &state).unwrap();
            let mut gpu =
                GpuBarrierBackend::with_adapter(&adapter, plan, &state, precision).unwrap();
            let steps = (1e-3 / dt).round() as usize;
            let below_floor = precision == Precision::F32
                && matches!(convergence, Convergence::MaxAccelerationResidual { .. });
            if below_floor {
                // The acceleration residual of f32 positions cannot fall below
                // ~ε X / h² (X the coordinate, h = 2e-6: ε X / h² ≈ 3e4 X m/s²),
                // under the tolerance 1e-3 m/s² once X ≳ 1e-7 m. Those steps end
                // at the rounding floor (typed status, accepted), never with a
                // silently different criterion; the velocity then carries the
                // position rounding, ≤ 4 ε X / h per step.
                let mut floors = 0;
                for _ in 0..steps {
                    let report = gpu.step().expect("accepted");
                    match report.minimisation[0].status {
                        MinimisationStatus::Converged => {}
                        MinimisationStatus::RoundingFloor => floors += 1,
                        ref other => panic!("unexpected {other:?}"),
                    }
                }
                let v = gpu.read_state().unwrap().velocities[0];
                let bound = 4.0 * steps as f64 * precision.epsilon() * 5e-4 / dt;
                print_bound(
                    format_args!(
                        "seed example f32 dt {dt:e} max_acceleration_residual 1e-3 ({floors} of {steps} steps at the rounding floor): |v − 1|"
                    ),
                    format_args!("{:e}", (v - 1.0).abs()),
                    format_args!("{bound:e}"),
                    "position rounding ≤ 4 ε X / h per step, X ≤ 5e-4 m",
                );
                assert!(floors > 0, "f32 reaches its floor at dt 2e-6");
                assert!((v - 1.0).abs() <= bound);
                continue;
            }
            for _ in 0..steps {
                let a = cpu.step().unwrap();
                let b = gpu.step().unwrap();
                assert_eq!(b.minimisation[0].status, MinimisationStatus::Converged);
                if precision == Precision::F64 {
                    assert_eq!(
                        a.minimisation, b.minimisation,
                        "f64: same iterations and residuals"
                    );
                }
            }
            let v_cpu = cpu.read_state().unwrap().velocities[0];
            let v_gpu = gpu.read_state().unwrap().velocities[0];
            if precision == Precision::F64 {
                assert_eq!(
                    v_gpu.to_bits(),
                    v_cpu.to_bits(),
                    "f64 GPU is bit-identical to the golden path"
                );
            }
            // f32: each step's v = (x − x_prev)/h rounds at ε|x|/h ≤ 1.2e-7·5e-4/2e-6;
            // the packed floor at dt 2e-6 still converges at the warm start (0 exactly).
            let bound = if expected == 0.0 {
                0.0
            } else {
                64.0 * precision.epsilon() * 5e-4 / dt + 1e-9
            };
            print_bound(
                format_args!(
                    "seed example {precision} dt {dt:e} {}: |v − {expected}|",
                    convergence.as_str()
                ),
                format_args!("{:e}", (v_gpu - expected).abs()),
                format_args!("{bound:e}"),
                "v = (x − x_prev)/h rounds at ε|x|/h per step",
            );
            assert!(
                (v_gpu - expected).abs() <= bound,
                "{precision}: v = {v_gpu}"
            );
        }
    }
}

#[test]
fn whole_steps_match_the_golden_path() {
    for precision in PRECISIONS {
        let Some((adapter, _)) = adapter_or_skip("whole_steps_match_the_golden_path", precision)
        else {
            continue;
        };
        // f32: the acceleration residual's rounding floor is ~ε X / h² ≈ 1e-2 m/s²
        // in free flight (X = 2, h = 1/60) and ~b''(d) ε X / m ≈ 0.1–0.3 m/s² in
        // resting contact (b'' ≈ 4e5 N/m at d ≈ 5e-4); the tolerance sits above it.
        let tolerance = match precision {
            Precision::F32 => 1.0,
            Precision::F64 => 1e-4,
        };
        for (count, speed) in [(0, 1.0), (1, 1.0), (1, 100.0), (65, 10.0), (200, 100.0)] {
            let scene = drop_scene(
                count,
                speed,
                Convergence::MaxAccelerationResidual { tolerance },
            );
            let (worst, identical, smallest, last) = whole_steps(&adapter, &scene, precision, 60);
            print_bound(
                format_args!(
                    "whole step {precision}: drop on a plane, {count} particles at up to {speed} m/s, 60 steps ({identical} bit-identical, smallest d {smallest:.2e}; final |dx|, |dv| vs bound: {last})"
                ),
                format_args!("{worst:.3e}"),
                "1",
                "largest ratio to BarrierErrorModel (verify/src/compare_barrier.rs)",
            );
        }
        // A 4D triangle mesh (slide) and the packed criterion.
        let mut scene = Scene::new(4, 1.0 / 60.0, 2, 1);
        scene.gravity = Some(vec![0.0, 0.0, 0.0, -9.81]);
        scene.obstacles.push(triangle_grid(4, [0, 1], 3, 0.5));
        scene.particles.push(
            Particle::new(vec![0.1, 0.6, 0.0, 0.05], 1.0).with_velocity(vec![0.5, 0.0, 0.0, 0.0]),
        );
        let tolerance = match precision {
            Precision::F32 => 1e-4,
            Precision::F64 => 1e-9,
        };
        scene.solver = solver(Convergence::PackedGradient { tolerance }, 1e3, 0.02, 100);
        let (worst, identical, smallest, last) = whole_steps(&adapter, &scene, precision, 60);
        print_bound(
            format_args!(
                "whole step {precision}: slide over a 4D triangle mesh, 2 substeps, packed gradient, 60 steps ({identical} bit-identical, smallest d {smallest:.2e}; final |dx|, |dv| vs bound: {last})"
            ),
            format_args!("{worst:.3e}"),
            "1",
            "largest ratio to BarrierErrorModel",
        );
    }
}

/// The f32 floor near d → 0: 200 particles hitting a plane at up to
/// 100 m/s are driven to d ~ 1e-5 within an iteration or two, where b'' is
/// ~1e9 N/m and the f32 acceleration residual cannot fall below
/// b'' ε X / m. There every particle ends at its rounding floor (the
/// expected Newton decrease is below the rounding of F's change) and the
/// minimisation reports `RoundingFloor`; a refusal would be typed and
/// rolled back. The GPU never hands back a state at d ≤ 0 (checked in f64
/// after every accepted step).
#[test]
fn f32_floor_near_contact_never_tunnels() {
    let Some((adapter, _)) =
        adapter_or_skip("f32_floor_near_contact_never_tunnels", Precision::F32)
    else {
        return;
    };
    let scene = drop_scene(
        200,
        100.0,
        Convergence::MaxAccelerationResidual { tolerance: 1e-3 },
    );
    let plan = Plan::compile(&scene).unwrap();
    let mut gpu =
        GpuBarrierBackend::with_adapter(&adapter, plan, &State::from_scene(&scene), Precision::F32)
            .unwrap();
    let (mut accepted, mut at_floor, mut refused) = (0, 0, 0);
    let mut smallest = f64::INFINITY;
    for _ in 0..30 {
        let before = gpu.read_state().unwrap();
        match gpu.step() {
            Ok(report) => {
                accepted += 1;
                at_floor += report
                    .minimisation
                    .iter()
                    .filter(|m| m.status == MinimisationStatus::RoundingFloor)
                    .count();
                let s = gpu.read_state().unwrap();
                let d = smallest_distance(&scene, &s);
                assert!(d > 0.0);
                smallest = smallest.min(d);
            }
            Err(hyperpbd::BackendError::Step(hyperpbd::StepError::MinimisationRefused {
                ..
            })) => {
                refused += 1;
                assert_eq!(gpu.read_state().unwrap().hash(), before.hash());
                break;
            }
            Err(e) => panic!("unexpected {e}"),
        }
    }
    println!(
        "f32 floor: 200 particles at up to 100 m/s, tolerance 1e-3 m/s²: {accepted} steps accepted ({at_floor} at the rounding floor), {refused} refused; smallest d {smallest:e}"
    );
    // A tolerance below the f32 floor must end in RoundingFloor (accepted,
    // reported), never in a refusal or a false convergence.
    assert_eq!(refused, 0, "a step below the f32 floor was refused");
    assert_eq!(accepted, 30);
    assert!(at_floor > 0, "no substep reported the rounding floor");
}

#[test]
fn gpu_infeasible_start_is_refused_before_anything_moves() {
    for precision in PRECISIONS {
        let Some((adapter, _)) = adapter_or_skip(
            "gpu_infeasible_start_is_refused_before_anything_moves",
            precision,
        ) else {
            continue;
        };
        let scene = drop_scene(
            3,
            1.0,
            Convergence::MaxAccelerationResidual { tolerance: 0.1 },
        );
        let plan = Plan::compile(&scene).unwrap();
        let mut gpu =
            GpuBarrierBackend::with_adapter(&adapter, plan, &State::from_scene(&scene), precision)
                .unwrap();
        gpu.step().unwrap();
        let mut bad = gpu.read_state().unwrap();
        bad.positions[3 + 1] = -0.5;
        gpu.write_state(&bad).unwrap();
        let written = gpu.read_state().unwrap();
        let err = gpu.step().expect_err("infeasible");
        let text = err.to_string();
        assert!(text.contains("particle 1 starts at distance"), "{text}");
        assert_eq!(gpu.read_state().unwrap().hash(), written.hash());
    }
}

/// A refusal after accepted substeps (the CPU twin is in tests/implicit/barrier/):
/// gravity pointing away from the plane moves the particle by h²g per
/// substep and adds as much speed, until the Newton slope ≈ m|Δ|² overflows
/// the precision (h²g = 1e153 m in f64, 1e18 m in f32). The refusal's
/// substep > 0 proves the state had moved; the GPU must restore it byte
/// for byte from its device copies.
#[test]
fn gpu_refusal_after_accepted_substeps_rolls_back_byte_for_byte() {
    for precision in PRECISIONS {
        let Some((adapter, _)) = adapter_or_skip(
            "gpu_refusal_after_accepted_substeps_rolls_back_byte_for_byte",
            precision,
        ) else {
            continue;
        };
        let mut scene = drop_scene(
            1,
            0.0,
            Convergence::MaxAccelerationResidual { tolerance: 1.0 },
        );
        let g = match precision {
            Precision::F32 => 1e22,
            Precision::F64 => 1e157,
        };
        scene.dt = 0.4;
        scene.substeps = 40; // h = 0.01
        scene.gravity = Some(vec![0.0, g, 0.0]);
        let plan = Plan::compile(&scene).unwrap();
        let mut gpu =
            GpuBarrierBackend::with_adapter(&adapter, plan, &State::from_scene(&scene), precision)
                .unwrap();
        let before = gpu.read_state().unwrap();
        let err = gpu.step().expect_err("the slope overflows");
        match &err {
            hyperpbd::BackendError::Step(hyperpbd::StepError::MinimisationRefused {
                substep,
                ..
            }) => assert!(
                *substep > 0,
                "{precision}: refused in substep 0: nothing moved"
            ),
            other => panic!("{precision}: unexpected {other:?}"),
        }
        assert_eq!(
            gpu.read_state().unwrap().hash(),
            before.hash(),
            "{precision}"
        );
        println!("{precision}: {err}");
    }
}

/// The GPU barrier path is bit-identical across runs on one adapter (no
/// float atomics, fixed reduction tree), in both precisions.
#[test]
fn gpu_barrier_path_is_deterministic() {
    for precision in PRECISIONS {
        let Some((adapter, _)) = adapter_or_skip("gpu_barrier_path_is_deterministic", precision)
        else {
            continue;
        };
        let scene = hyperpbd::scenes::barrier4d();
        let plan = Plan::compile(&scene).unwrap();
        let run = || {
            let mut gpu = GpuBarrierBackend::with_adapter(
                &adapter,
                plan.clone(),
                &State::from_scene(&scene),
                precision,
            )
            .unwrap();
            let mut reports = Vec::new();
            for _ in 0..30 {
                reports.push(gpu.step().unwrap().minimisation);
            }
            (gpu.read_state().unwrap().hash(), reports)
        };
        let (a, ra) = run();
        let (b, rb) = run();
        assert_eq!(a, b, "{precision}: two runs differ");
        assert_eq!(ra, rb, "{precision}: reports differ");
        println!("DETERMINISM | barrier4d {precision} 30 steps | {a:016x}");
    }
}

/// One particle thrown at a plane at 1e4 m/s (167 m per step at dt = 1/60,
/// from 2 m away) on the GPU, both precisions: no accepted state reaches
/// d ≤ 0 (checked in f64), and every step is accepted.
#[test]
fn gpu_drop_at_1e4_m_per_s_never_tunnels() {
    for precision in PRECISIONS {
        let Some((adapter, _)) =
            adapter_or_skip("gpu_drop_at_1e4_m_per_s_never_tunnels", precision)
        else {
            continue;
        };
        let tolerance = match precision {
            Precision::F32 => 1.0,
            Precision::F64 => 1e-4,
        };
        let mut scene = drop_scene(1, 1.0, Convergence::MaxAccelerationResidual { tolerance });
        scene.particles[0].velocity = Some(vec![0.0, -1e4, 0.0]);
        let plan = Plan::compile(&scene).unwrap();
        let mut gpu =
            GpuBarrierBackend::with_adapter(&adapter, plan, &State::from_scene(&scene), precision)
                .unwrap();
        let mut smallest = f64::INFINITY;
        let mut statuses = Vec::new();
        for _ in 0..120 {
            let report = gpu.step().expect("accepted");
            statuses.extend(report.minimisation.into_iter().map(|m| m.status));
            let d = smallest_distance(&scene, &gpu.read_state().unwrap());
            assert!(d > 0.0, "{precision}: d = {d:e}");
            smallest = smallest.min(d);
        }
        let floors = statuses
            .iter()
            .filter(|s| **s == MinimisationStatus::RoundingFloor)
            .count();
        println!(
            "{precision}: 1e4 m/s drop, 120 steps, smallest d {smallest:e}, {floors} at the rounding floor"
        );
    }
}

/// f32 far from the world origin: the same drop 1e5 m away (scene and
/// plane moved together) stays within the bound of the scene at the origin,
/// because `GpuBarrierBackend` stores f32 positions relative to a scene
/// origin and shifts the obstacles with them (`gpu/src/origin.rs`). In f32
/// world coordinates every position there would be rounded to
/// ulp(1e5)/2 = 3.9e-3 m, above that bound.
#[test]
fn f32_far_from_the_origin_keeps_the_accuracy_of_the_origin() {
    let precision = Precision::F32;
    let Some((adapter, _)) = adapter_or_skip(
        "f32_far_from_the_origin_keeps_the_accuracy_of_the_origin",
        precision,
    ) else {
        return;
    };
    let offset = 1e5;
    let tolerance = Convergence::MaxAccelerationResidual { tolerance: 1.0 };
    let near = drop_scene(65, 10.0, tolerance);
    let mut far = near.clone();
    for p in &mut far.particles {
        p.position[0] += offset;
        p.position[1] += offset;
    }
    let Obstacle::Hyperplane { offset: plane, .. } = &mut far.obstacles[0] else {
        unreachable!("drop_scene has one plane");
    };
    *plane += offset;

    let plan = Plan::compile(&far).expect("valid");
    let state = State::from_scene(&far);
    let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
    let mut gpu =
        GpuBarrierBackend::with_adapter(&adapter, plan.clone(), &state, precision).expect("gpu");
    // The model of the scene at the origin: coordinates of size |x_near|.
    let mut model = BarrierErrorModel::new(&plan, precision);
    let near_scale = hyperpbd_verify::compare::coordinate_scale(&State::from_scene(&near));
    let mut worst: f64 = 0.0;
    for step in 1..=30 {
        let a = cpu.step().expect("cpu step");
        let b = gpu.step().expect("gpu step");
        model.advance(&a.minimisation, &b.minimisation, near_scale);
        let golden = cpu.read_state().expect("cpu state");
        let other = gpu.read_state().expect("gpu state");
        let dx = hyperpbd_verify::compare::max_abs_diff(&golden.positions, &other.positions);
        let bound = model.position_bound();
        assert!(dx <= bound, "step {step}: |dx| {dx:e} > {bound:e}");
        let d = smallest_distance(&far, &other);
        assert!(d > 0.0, "step {step}: GPU state at d = {d:e}");
        worst = worst.max(dx / bound);
    }
    print_bound(
        "barrier f32 drop at 1e5 m",
        format_args!("{worst:.3e} of the bound at the origin"),
        "1",
        "origin shift; without it ulp(1e5)/2 = 3.9e-3 m per coordinate",
    );
}

/// The packed-gradient residual the GPU reports against the CPU's at the
/// same iterate: the first minimisation of the first step, which both start
/// from the same state, so only the order of the sum differs (a tree on the
/// GPU, a loop on the CPU): |r_gpu − r_cpu| ≤ (n + 2) ε r for n particle
/// terms, then a square root. (A reduction that rounds differently —
/// a 1e-7 relative nudge of one pairwise sum — shows at once; the whole
/// steps above may legitimately differ in their stopping points.)
#[test]
fn the_first_packed_residual_matches_the_golden_path_to_the_order_of_its_sum() {
    let test = "the_first_packed_residual_matches_the_golden_path_to_the_order_of_its_sum";
    let Some((adapter, _)) = adapter_or_skip(test, Precision::F64) else {
        return;
    };
    for count in [2, 65, 200] {
        let scene = drop_scene(count, 10.0, Convergence::PackedGradient { tolerance: 1e-9 });
        let plan = Plan::compile(&scene).expect("valid");
        let state = State::from_scene(&scene);
        let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
        let mut gpu =
            GpuBarrierBackend::with_adapter(&adapter, plan, &state, Precision::F64).expect("gpu");
        let a = cpu.step().expect("cpu step");
        let b = gpu.step().expect("gpu step");
        let (Some(golden), Some(got)) = (
            a.minimisation[0].initial_residual,
            b.minimisation[0].initial_residual,
        ) else {
            panic!("{count} particles: no initial residual");
        };
        let n = scene.particles.len() as f64;
        let bound = (n + 2.0) * f64::EPSILON * golden.abs();
        let measured = (got - golden).abs();
        print_bound(
            format_args!("first packed residual f64, {count} particles (cpu {golden:e})"),
            format_args!("{measured:.3e}"),
            format!("{bound:.3e}"),
            "(n + 2) ε r: the two summation orders",
        );
        assert!(measured <= bound, "{count}: {got:e} vs {golden:e}");
    }
}
