//! The coupled implicit step on the GPU in f32 (issue 16, item 4;
//! docs/implicit.md §12, docs/bounds.md "Coupled implicit step in f32")
//! against the golden path, step by step: before every step the CPU is
//! restarted from the GPU's state, both take the step, and the host
//! recomputes ∇F in f64 at both iterates (`hyperpbd::coupled_gradient`,
//! the golden gradient code) to bound their distance with the per-particle
//! modulus of `hyperpbd::compare_coupled`. Asserted every step: the bound
//! (where the module states one), every gap > 0 against the authored
//! geometry in f64, every value finite.
//! `cargo test --release --test gpu_coupled_f32 -- --nocapture | grep '^BOUND'`.

mod common;

use common::bound::print_bound;
use common::gpu::adapter_or_skip;
use common::implicit_scenes::{alternating_chain, head_on, incline, particle, settings, stack};
use hyperpbd::compare_coupled::coupled_step_bound;
use hyperpbd::{
    Backend, Collisions, ConstraintFamily, ConstraintKind, Obstacle, Plan, Scene, Solver, State,
    WarmStart, coupled_gradient,
};
use hyperpbd_gpu::{GpuCoupledBackend, Precision};

/// The smallest gap of any free particle to any obstacle and of any ball
/// pair (with collisions), in f64 against the authored geometry.
fn smallest_gap(plan: &Plan, x: &[f64]) -> f64 {
    let dim = plan.dim;
    let ip = plan.incremental_potential().expect("ip");
    let mut normal = vec![0.0; dim];
    let mut gap = f64::INFINITY;
    let n = plan.particle_count();
    for i in (0..n).filter(|&i| plan.inverse_mass[i] > 0.0) {
        let xi = &x[i * dim..(i + 1) * dim];
        for o in 0..ip.obstacles.len() {
            gap = gap.min(ip.obstacles.distance(o, xi, plan.radius[i], &mut normal));
        }
    }
    if ip.coupled.as_ref().is_some_and(|c| c.collisions) {
        for i in 0..n {
            for j in i + 1..n {
                let l = (0..dim)
                    .map(|a| (x[j * dim + a] - x[i * dim + a]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                gap = gap.min(l - plan.radius[i] - plan.radius[j]);
            }
        }
    }
    gap
}

/// `scene` with one substep per frame (same h): the bound is per
/// minimisation, and the CPU restarts from the GPU's state before each.
fn per_substep(mut scene: Scene) -> Scene {
    scene.dt /= f64::from(scene.substeps);
    scene.substeps = 1;
    scene
}

/// Steps `scene` `steps` times on the GPU in f32, the CPU restarted from
/// the GPU's state before every step; asserts the bound where stated and
/// gaps > 0, prints BOUND lines. Returns the worst measured / bound.
fn f32_against_cpu(test: &str, scene: Scene, steps: usize) -> Option<f64> {
    let (adapter, summary) = adapter_or_skip(test, Precision::F32)?;
    let scene = per_substep(scene);
    let plan = Plan::compile(&scene).expect("compiles");
    let state = State::from_scene(&scene);
    let mut cpu = common::cpu_backend(&scene, 1);
    let mut gpu = GpuCoupledBackend::with_adapter(&adapter, plan.clone(), &state, Precision::F32)
        .unwrap_or_else(|e| panic!("{test}: the GPU takes the coupled step in f32: {e}"));
    let has_gaps = smallest_gap(&plan, &state.positions).is_finite();
    let (mut worst, mut worst_at) = (0.0f64, (0, 0.0, 0.0));
    let (mut largest, mut closest) = (0.0f64, f64::INFINITY);
    let (mut fraction, mut unbounded) = (f64::INFINITY, None);
    let mut rounding_share = 0.0f64;
    let mut statuses = std::collections::BTreeMap::<String, usize>::new();
    for step in 0..steps {
        let start = gpu.read_state().expect("gpu state");
        cpu.write_state(&start).expect("cpu restart");
        let a = gpu
            .step()
            .unwrap_or_else(|e| panic!("{test}: gpu-f32 step {step}: {e}"));
        cpu.step()
            .unwrap_or_else(|e| panic!("{test}: cpu step {step}: {e}"));
        for m in &a.minimisation {
            *statuses.entry(format!("{:?}", m.status)).or_default() += 1;
        }
        let (x_gpu, x_cpu) = (
            gpu.read_state().expect("gpu").positions,
            cpu.read_state().expect("cpu").positions,
        );
        assert!(
            x_gpu.iter().all(|v| v.is_finite()),
            "{test}: step {step}: a non-finite GPU value"
        );
        if has_gaps {
            let gap = smallest_gap(&plan, &x_gpu);
            assert!(gap > 0.0, "{test}: step {step}: gap {gap:e} ≤ 0 in f32");
            closest = closest.min(gap);
        }
        let from = (&start.positions[..], &start.velocities[..]);
        let g_gpu = coupled_gradient(&plan, from, &plan.force, &x_gpu)
            .unwrap_or_else(|r| panic!("{test}: step {step}: ∇F at the GPU iterate: {r:?}"));
        let g_cpu = coupled_gradient(&plan, from, &plan.force, &x_cpu)
            .unwrap_or_else(|r| panic!("{test}: step {step}: ∇F at the CPU iterate: {r:?}"));
        largest = largest.max(hyperpbd::compare::max_abs_diff(&x_gpu, &x_cpu));
        match coupled_step_bound(&plan, from, &x_gpu, &x_cpu, &g_gpu, &g_cpu) {
            Ok(b) => {
                let (i, ratio) = b.worst();
                for k in 0..b.bound.len() {
                    assert!(
                        b.measured[k] <= b.bound[k],
                        "{test}: step {step}: particle {k}: |x_gpu − x_cpu| = {:e} > bound {:e} \
                         (‖g‖_A⁻¹ gpu {:e}, cpu {:e}, rounding {:e})",
                        b.measured[k],
                        b.bound[k],
                        b.gradient_norms.0,
                        b.gradient_norms.1,
                        b.rounding
                    );
                }
                fraction = fraction.min(b.modulus_fraction);
                let total = b.gradient_norms.0 + b.gradient_norms.1 + b.rounding;
                rounding_share = rounding_share.max(b.rounding / total);
                if ratio > worst {
                    worst = ratio;
                    worst_at = (step, b.measured[i], b.bound[i]);
                }
            }
            Err(why) => {
                unbounded.get_or_insert((step, why));
            }
        }
    }
    let rule = format!("f32 ({}), statuses {statuses:?}", summary.name);
    if let Some((step, why)) = &unbounded {
        print_bound(
            format!("gpu-f32 coupled {test} | position |x_gpu − x_cpu| | {steps}"),
            format_args!("{largest:e}"),
            format!("none stated (step {step}: {why})"),
            &rule,
        );
        return None;
    }
    print_bound(
        format!(
            "gpu-f32 coupled {test} | position, worst particle of worst step {} \
             (measured/bound {worst:.6}; min μ_i/m_i {fraction:.3}; max |dx| {largest:.3e}; \
             gradient rounding {rounding_share:.1e} of the bound) | {steps}",
            worst_at.0
        ),
        format_args!("{:.3e}", worst_at.1),
        format_args!("{:.3e}", worst_at.2),
        &rule,
    );
    if has_gaps {
        print_bound(
            format!("gpu-f32 coupled {test} | smallest gap (f64, authored geometry) | {steps}"),
            format_args!("{closest:.3e}"),
            "> 0",
            &rule,
        );
    }
    Some(worst)
}

#[test]
fn alternating_chain_in_f32() {
    f32_against_cpu("chain 1:1e6", alternating_chain(), 20);
}

#[test]
fn head_on_balls_in_f32() {
    f32_against_cpu("head-on", head_on(), 120);
}

#[test]
fn inclines_in_f32() {
    for (name, mu) in [("incline stick", 0.5), ("incline slide", 0.2)] {
        f32_against_cpu(name, incline(mu).0, 30);
    }
}

#[test]
fn stack_of_ten_balls_in_f32() {
    f32_against_cpu("stack of 10", stack().0, 30);
}

#[test]
fn glancing_balls_with_pair_friction_in_f32() {
    let mut glancing = head_on();
    glancing.particles[1].position[1] = 0.05;
    glancing.collisions = Some(Collisions {
        friction: 0.5,
        margin: 0.0,
    });
    f32_against_cpu("glancing balls, pair friction", glancing, 120);
}

/// Three balls on distance springs dropped into a V of two segments.
#[test]
fn simplex_mesh_obstacles_in_f32() {
    let mut scene = Scene::new(2, 1.0 / 60.0, 2, 1);
    scene.gravity = Some(vec![0.0, -9.81]);
    for k in 0..3 {
        let mut p = particle(vec![-0.25 + 0.25 * k as f64, 0.3], Some(1.0), 0.05);
        p.velocity = Some(vec![0.5, -1.0]);
        scene.particles.push(p);
    }
    scene.constraints.push(ConstraintFamily::new(
        ConstraintKind::Distance,
        1e-4,
        vec![vec![0, 1], vec![1, 2]],
    ));
    scene.obstacles.push(Obstacle::SimplexMesh {
        vertices: vec![vec![-1.0, 0.5], vec![0.0, -0.2], vec![1.0, 0.5]],
        simplices: vec![vec![0, 1], vec![1, 2]],
    });
    scene.collisions = Some(Collisions {
        friction: 0.0,
        margin: 0.0,
    });
    scene.solver = Solver::IncrementalPotential(settings(1e4, 0.02, 1e-3, 40));
    f32_against_cpu("three balls in a V of segments", scene, 80);
}

/// The 3D tetrahedron of distance, tether and measure springs on a
/// frictional plane ("previous" warm start, packed criterion).
#[test]
fn measures_tethers_and_previous_warm_start_in_f32() {
    let mut scene = Scene::new(3, 1.0 / 60.0, 2, 1);
    scene.gravity = Some(vec![0.0, -9.81, 0.0]);
    for (k, p) in [
        [0.0, 0.3, 0.0],
        [0.2, 0.32, 0.0],
        [0.0, 0.31, 0.2],
        [0.05, 0.5, 0.05],
    ]
    .into_iter()
    .enumerate()
    {
        let mut q = particle(p.to_vec(), Some(0.5 + 0.25 * k as f64), 0.02);
        q.velocity = Some(vec![0.3, 0.0, -0.1 * k as f64]);
        scene.particles.push(q);
    }
    scene
        .particles
        .push(particle(vec![0.0, 1.0, 0.0], None, 0.0));
    scene.constraints.push(ConstraintFamily::new(
        ConstraintKind::Distance,
        1e-5,
        vec![vec![0, 1], vec![1, 2], vec![2, 0], vec![0, 3]],
    ));
    scene.constraints.push(ConstraintFamily::new(
        ConstraintKind::Tether,
        1e-4,
        vec![vec![4, 3]],
    ));
    scene.constraints.push(ConstraintFamily::new(
        ConstraintKind::OrientedMeasure,
        1e-3,
        vec![vec![0, 1, 2, 3]],
    ));
    scene.constraints.push(ConstraintFamily::new(
        ConstraintKind::SimplexMeasure,
        1e-3,
        vec![vec![0, 1, 2]],
    ));
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: vec![0.0, 1.0, 0.0],
        offset: 0.0,
        friction: 0.4,
        compliance: 0.0,
    });
    let mut s = settings(1e4, 0.01, 1e-3, 40);
    s.convergence = hyperpbd::Convergence::PackedGradient { tolerance: 1e-9 };
    s.warm_start = Some(WarmStart::Previous);
    s.cg_iterations = Some(12);
    scene.solver = Solver::IncrementalPotential(s);
    f32_against_cpu("tetrahedron of springs on a frictional plane", scene, 80);
}
