//! The coupled implicit step on the GPU (issue 16, item 4;
//! `GpuCoupledBackend`, `shaders/coupled.wgsl`) against the golden path:
//! every evidence scene of `tests/implicit/step.rs` stepped on both, frame
//! by frame, and scenes for the branches they miss (measures and tethers;
//! a 100-bead chain and an anchor sunk into a floor, written for mutants
//! M114–M116 of docs/mutation.md), and material families (StVK,
//! Neo-Hookean: hanging blocks, tetrahedra dropped onto a plane with their
//! frame Hessians clipped, an embedded sheet, a crushed triangle, an
//! inverted start, R^4 and R^5 simplices). In f64 on lavapipe every state, and every minimisation's
//! report (residuals, Newton and CG iterations, status), is bit-identical
//! to the CPU's; on an adapter without that guarantee (it may contract
//! a·b + c) the GPU run is held to the scene's own evidence bound instead.
//! `cargo test --release --test gpu -- coupled:: --nocapture | grep '^BOUND'`.
//! The f32 step has its own residual-driven bound: tests/gpu/coupled_f32.rs.

use crate::common;

use common::bound::print_bound;
use common::exact::{bits, f64_identical, f64_rule};
use common::gpu::adapter_or_skip;
use common::implicit_scenes::{
    alternating_chain, balls_in_a_v, glancing, head_on, incline, particle, settings,
    spring_tetrahedron, stack,
};
use hyperpbd::{
    Backend, BackendError, Collisions, ConstraintFamily, ConstraintKind, GpuError, Obstacle, Plan,
    Scene, Solver, State,
};
use hyperpbd_gpu::{GpuCoupledBackend, Precision};

/// Steps `scene` `frames` times on the CPU and on the GPU (f64); on
/// lavapipe asserts identical bits of every state and identical reports,
/// elsewhere `evidence` (measured, bound) of every GPU state.
fn differential(test: &str, scene: &Scene, frames: usize, evidence: impl Fn(&State) -> (f64, f64)) {
    differential_with(test, scene, frames, evidence, |_, _| {});
}

/// [`differential`], with `golden_state` called on every CPU state and
/// its frame's minimisation reports.
fn differential_with(
    test: &str,
    scene: &Scene,
    frames: usize,
    evidence: impl Fn(&State) -> (f64, f64),
    mut golden_state: impl FnMut(&State, &[hyperpbd::MinimisationReport]),
) {
    let Some((adapter, summary)) = adapter_or_skip(test, Precision::F64) else {
        return;
    };
    let plan = Plan::compile(scene).expect("compiles");
    let state = State::from_scene(scene);
    let mut cpu = common::cpu_backend(scene, 1);
    let mut gpu = GpuCoupledBackend::with_adapter(&adapter, plan, &state, Precision::F64)
        .expect("the GPU takes the coupled step");
    let exact = f64_identical(&summary);
    let (mut newton, mut cg, mut worst) = (0, 0, 0.0f64);
    for frame in 0..frames {
        let a = cpu
            .step()
            .unwrap_or_else(|e| panic!("{test}: cpu frame {frame}: {e}"));
        let b = gpu
            .step()
            .unwrap_or_else(|e| panic!("{test}: gpu frame {frame}: {e}"));
        let (golden, other) = (
            cpu.read_state().expect("cpu"),
            gpu.read_state().expect("gpu"),
        );
        golden_state(&golden, &a.minimisation);
        for m in &a.minimisation {
            newton += m.iterations;
            cg += m.cg_iterations.iter().sum::<u32>();
        }
        if exact {
            assert!(
                bits(&golden) == bits(&other),
                "{test}: frame {frame}: the f64 GPU state differs from the golden path \
                 (max |dx| = {:e}, max |dv| = {:e})",
                hyperpbd_verify::compare::max_abs_diff(&golden.positions, &other.positions),
                hyperpbd_verify::compare::max_abs_diff(&golden.velocities, &other.velocities)
            );
            assert_eq!(
                a.minimisation, b.minimisation,
                "{test}: frame {frame}: reports differ"
            );
            assert_eq!(
                a.residuals, b.residuals,
                "{test}: frame {frame}: family residuals differ"
            );
        } else {
            let (measured, bound) = evidence(&other);
            assert!(
                measured <= bound,
                "{test}: frame {frame}: {measured:e} > {bound:e}"
            );
        }
        worst = worst.max(hyperpbd_verify::compare::max_abs_diff(
            &golden.positions,
            &other.positions,
        ));
    }
    print_bound(
        format!(
            "gpu-f64 coupled {test}: max |x_gpu − x_cpu| over {frames} frames ({newton} Newton, {cg} CG iterations)"
        ),
        format_args!("{worst:e}"),
        if exact {
            "0".to_string()
        } else {
            "scene evidence".to_string()
        },
        f64_rule(&summary),
    );
}

#[test]
fn alternating_chain_is_the_golden_path() {
    let scene = alternating_chain();
    let residual = |s: &State| {
        let x = &s.positions;
        let worst = (0..12)
            .map(|k| ((x[2 * k + 2] - x[2 * k]).hypot(x[2 * k + 3] - x[2 * k + 1]) - 0.1).abs())
            .fold(0.0, f64::max);
        (worst, 1e-3)
    };
    differential("chain 1:1e6", &scene, 20, residual);
}

#[test]
fn head_on_balls_are_the_golden_path() {
    let gap = |s: &State| {
        let d = (s.positions[2] - s.positions[0]).hypot(s.positions[3] - s.positions[1]) - 0.2;
        (-d, 0.0)
    };
    differential("head-on", &head_on(), 30, gap);
}

#[test]
fn inclines_are_the_golden_path() {
    for (name, mu) in [("incline stick", 0.5), ("incline slide", 0.2)] {
        let (scene, _) = incline(mu);
        let height = |s: &State| (-(s.positions[0].hypot(s.positions[1])), 0.0);
        differential(name, &scene, 30, height);
    }
}

#[test]
fn stack_of_ten_balls_is_the_golden_path() {
    let (scene, _) = stack();
    let lowest_gap = |s: &State| {
        let y = |k: usize| s.positions[2 * k + 1];
        let mut closest = y(0) - 0.1;
        for k in 1..10 {
            closest = closest.min(y(k) - y(k - 1) - 0.2);
        }
        (-closest, 0.0)
    };
    differential("stack of 10", &scene, 30, lowest_gap);
}

/// Two balls passing off-centre (0.05 m apart across the line of
/// approach) with ball-pair friction μ = 0.5, and the stack of ten with
/// pair friction and a sideways push: the lagged pair friction's
/// sticking and sliding branches.
#[test]
fn pair_friction_is_the_golden_path() {
    let glancing = glancing();
    let gap = |s: &State| {
        let d = (s.positions[2] - s.positions[0]).hypot(s.positions[3] - s.positions[1]) - 0.2;
        (-d, 0.0)
    };
    differential("glancing balls with pair friction", &glancing, 30, gap);
    let (mut stack, _) = stack();
    stack.collisions = Some(Collisions {
        friction: 0.5,
        margin: 0.0,
    });
    for (k, p) in stack.particles.iter_mut().enumerate() {
        p.velocity = Some(vec![0.05 * k as f64, 0.0]);
    }
    let lowest_gap = |s: &State| {
        let y = |k: usize| s.positions[2 * k + 1];
        (-(y(0) - 0.1), 0.0)
    };
    differential(
        "stack of 10 pushed sideways, pair friction",
        &stack,
        20,
        lowest_gap,
    );
}

/// A chain of three balls on distance springs dropped into a V of two
/// segments (a simplex mesh) with ball pairs: the barrier's closest-point
/// distance and the certified filter's support bound on the GPU.
#[test]
fn simplex_mesh_obstacles_are_the_golden_path() {
    let scene = balls_in_a_v();
    let below = |s: &State| {
        let lowest = (0..3)
            .map(|k| s.positions[2 * k + 1])
            .fold(f64::INFINITY, f64::min);
        (-(lowest + 0.3), 0.0)
    };
    differential("three balls in a V of segments", &scene, 40, below);
}

/// A 3D tethered triangle of springs falling onto a plane with friction,
/// with a signed-volume spring, a "previous" warm start and the packed
/// gradient criterion: every other branch the evidence scenes miss.
#[test]
fn measures_tethers_and_previous_warm_start_are_the_golden_path() {
    let scene = spring_tetrahedron();
    let above = |s: &State| {
        let lowest = (0..4)
            .map(|k| s.positions[3 * k + 1])
            .fold(f64::INFINITY, f64::min);
        (-(lowest - 0.02), 0.0)
    };
    differential(
        "tetrahedron of springs on a frictional plane",
        &scene,
        40,
        above,
    );
}

/// Why the GPU's coupled step refuses `scene` in `precision` (panics if it
/// loads, or fails otherwise).
fn refusal(adapter: &wgpu::Adapter, scene: &Scene, precision: Precision) -> String {
    let plan = Plan::compile(scene).expect("compiles");
    match GpuCoupledBackend::with_adapter(adapter, plan, &State::from_scene(scene), precision) {
        Err(BackendError::Gpu(GpuError::Unsupported { what })) => what,
        Err(e) => panic!("expected Unsupported, got {e}"),
        Ok(_) => panic!("expected a refusal"),
    }
}

/// What the GPU does not run yet (material families in f32) is a typed
/// refusal naming it, never a different result.
#[test]
fn unsupported_coupled_scenes_are_typed_refusals() {
    let Some((adapter, _)) = adapter_or_skip("coupled refusals", Precision::F64) else {
        return;
    };
    let material = hanging_block(ConstraintKind::NeoHookean);
    let what = refusal(&adapter, &material, Precision::F32);
    assert!(
        what.contains("material family") && what.contains("f32"),
        "{what}"
    );
}

/// A refused minimisation (two balls starting overlapped) rolls the GPU
/// state back byte for byte and names the same pair as the CPU.
#[test]
fn a_refused_step_rolls_back_and_names_the_pair() {
    let Some((adapter, _)) = adapter_or_skip("coupled rollback", Precision::F64) else {
        return;
    };
    let mut scene = head_on();
    scene.particles[1].position = vec![-0.45, 0.0];
    let plan = Plan::compile(&scene).expect("compiles");
    let state = State::from_scene(&scene);
    let mut gpu =
        GpuCoupledBackend::with_adapter(&adapter, plan, &state, Precision::F64).expect("loads");
    let before = gpu.read_state().expect("state");
    let gpu_error = gpu.step().expect_err("overlapping start");
    let cpu_error = common::cpu_backend(&scene, 1)
        .step()
        .expect_err("overlapping start");
    assert_eq!(gpu_error.to_string(), cpu_error.to_string());
    assert!(
        gpu_error.to_string().contains("particles 0 and 1"),
        "{gpu_error}"
    );
    assert_eq!(bits(&before), bits(&gpu.read_state().expect("state")));
}

/// A chain of 100 beads (99 links): every block-tree reduction (particles,
/// elements, filter times) has a second level, which no other scene here
/// reaches (a tree over at most 64 terms is one workgroup; mutant M114).
#[test]
fn a_chain_of_a_hundred_beads_reduces_over_two_levels() {
    let mut scene = Scene::new(2, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, -common::implicit_scenes::G]);
    scene.particles.push(particle(vec![0.0, 0.0], None, 0.0));
    for k in 1..100 {
        scene
            .particles
            .push(particle(vec![0.01 * k as f64, 0.0], Some(0.1), 0.0));
    }
    scene.constraints.push(ConstraintFamily::new(
        ConstraintKind::Distance,
        1e-4,
        (0..99).map(|k| vec![k, k + 1]).collect(),
    ));
    let mut s = settings(1e3, 1e-3, 1e-1, 20);
    s.cg_iterations = Some(50);
    scene.solver = Solver::IncrementalPotential(s);
    let links = |s: &State| {
        let x = &s.positions;
        let worst = (0..99)
            .map(|k| ((x[2 * k + 2] - x[2 * k]).hypot(x[2 * k + 3] - x[2 * k + 1]) - 0.01).abs())
            .fold(0.0, f64::max);
        (worst, 1e-3)
    };
    differential("chain of 100 beads", &scene, 4, links);
}

/// A pendulum whose fixed anchor sits on (radius: sunk into) the frictional
/// floor it swings onto: fixed particles are outside the barrier and the
/// certified filter on both paths (validation checks free particles only),
/// so an anchor at d ≤ 0 must neither refuse the start (mutant M116) nor
/// stall every line search at t = 0 (M115).
#[test]
fn an_anchor_sunk_into_the_floor_is_the_golden_path() {
    let mut scene = Scene::new(2, 1.0 / 60.0, 1, 1);
    scene.gravity = Some(vec![0.0, -common::implicit_scenes::G]);
    scene.particles.push(particle(vec![0.0, 0.0], None, 0.05));
    for k in 1..6 {
        let r = 0.1 * k as f64;
        scene
            .particles
            .push(particle(vec![0.6 * r, 0.8 * r], Some(0.2), 0.02));
    }
    scene.constraints.push(ConstraintFamily::new(
        ConstraintKind::Distance,
        1e-6,
        (0..5).map(|k| vec![k, k + 1]).collect(),
    ));
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: vec![0.0, 1.0],
        offset: 0.0,
        friction: 0.3,
        compliance: 0.0,
        motion: Vec::new(),
    });
    scene.solver = Solver::IncrementalPotential(settings(1e4, 1e-2, 1e-2, 50));
    let above = |s: &State| {
        let lowest = (1..6)
            .map(|k| s.positions[2 * k + 1] - 0.02)
            .fold(f64::INFINITY, f64::min);
        (-lowest, 0.0)
    };
    differential("anchor sunk into the floor", &scene, 40, above);
}

mod expressions;
mod materials;

use materials::hanging_block;
