//! The particle-contact iteration alone, CPU golden path
//! (`hyperpbd_cpu::collide`) vs the GPU kernels (`GpuCollide`), on
//! packed granular states in 2, 3 and 4 dimensions, plus a single
//! particle and an isolated pair, with sizes that do not divide the
//! workgroup size (64).
//!
//! Inputs are identical: the state is taken from a CPU run and, for f32,
//! rounded to f32 before both sides see it; both run the same broadphase
//! lists. Bounds:
//!
//! ```text
//! f64   bit-identical (0): the same operations in the same order, every one
//!       correctly rounded on both sides; lavapipe has matched the CPU bit for
//!       bit on every f64 kernel so far (no contraction into FMA observed).
//! f32   ε₃₂ · X · (8N + 40) · iterations, X = largest |coordinate|: one
//!       iteration is ≤ 8N + 40 roundings on the longest chain to one output
//!       (pair kernel: N differences, N squares + sum, sqrt, C, 1/|d|,
//!       normal, ·s, friction 3N + 8; gather: share, product, ≤ a_k sums,
//!       division, add), and the averaged Jacobi map is non-expansive, so
//!       rounding errors add up over iterations instead of growing.
//! ```

use crate::common;

use common::bound::print_bound;
use common::exact::f32_identical;
use common::gpu::adapter_or_skip;
use hyperpbd::{Backend, CpuBackend, Plan, Scene, State};
use hyperpbd_cpu::collide::{self, Contacts};
use hyperpbd_cpu::f32_reference;
use hyperpbd_gpu::{CollideInput, GpuCollide, Precision};

const ITERATIONS: u32 = 4;

struct Case {
    name: &'static str,
    scene: Scene,
    frames: usize,
}

fn cases() -> Vec<Case> {
    let mut one = hyperpbd::scenes::sandpile2d();
    one.particles.truncate(1);
    let mut pair = hyperpbd::scenes::ballpit4d();
    pair.particles.truncate(2);
    pair.particles[1].position = pair.particles[0].position.clone();
    pair.particles[1].position[0] += 0.15; // overlapping: radii 0.075 + 0.1
    vec![
        Case {
            name: "one particle",
            scene: one,
            frames: 0,
        },
        Case {
            name: "overlapping pair 4d",
            scene: pair,
            frames: 0,
        },
        Case {
            name: "sandpile2d",
            scene: hyperpbd::scenes::sandpile2d(),
            frames: 30,
        },
        Case {
            name: "ballpit4d",
            scene: hyperpbd::scenes::ballpit4d(),
            frames: 20,
        },
        Case {
            name: "column3d 6x10x6",
            scene: hyperpbd::scenes::column3d(6, 10),
            frames: 20,
        },
    ]
}

fn round(values: &mut [f64], precision: Precision) {
    if precision == Precision::F32 {
        for v in values {
            *v = f64::from(*v as f32);
        }
    }
}

fn differential(precision: Precision) {
    let test = format!("gpu_collide_{precision}");
    let Some((adapter, summary)) = adapter_or_skip(&test, precision) else {
        return;
    };
    let identical = precision == Precision::F32 && f32_identical(&summary);
    for case in cases() {
        let plan = Plan::compile(&case.scene).expect("valid");
        let mut cpu = CpuBackend::new(plan.clone(), &State::from_scene(&case.scene)).expect("cpu");
        for _ in 0..case.frames {
            cpu.step().expect("step");
        }
        let state = cpu.read_state().expect("read");
        let mut x = state.positions.clone();
        // Substep start one substep back along the velocity, then a
        // prediction one substep ahead: a realistic (x, p) pair.
        let mut p: Vec<f64> = x
            .iter()
            .zip(&state.velocities)
            .map(|(x, v)| x - plan.h * v)
            .collect();
        for (xi, vi) in x.iter_mut().zip(&state.velocities) {
            *xi += plan.h * vi;
        }
        round(&mut x, precision);
        round(&mut p, precision);
        let contacts_plan = plan.contacts.expect("collisions");
        let mut contacts = Contacts::default();
        collide::broadphase(&plan, contacts_plan.margin, &p, &x, &mut contacts);
        let mut expected = x.clone();
        for _ in 0..ITERATIONS {
            collide::collide(
                &plan,
                contacts_plan.friction,
                &p,
                &mut expected,
                &mut contacts,
            )
            .expect("cpu collide");
        }
        let gpu = GpuCollide::with_adapter(&adapter, plan.dim, precision).expect("collide kernels");
        let input = CollideInput {
            x: &x,
            p: &p,
            inverse_mass: &plan.inverse_mass,
            radius: &plan.radius,
            pairs: &contacts.pairs,
            offsets: &contacts.offsets,
            entries: &contacts.entries,
            friction: contacts_plan.friction,
        };
        let found = gpu.iterate(&input, ITERATIONS).expect("gpu collide");
        if identical {
            check_reference(case.name, &plan, &input, &found);
        }
        let err = expected
            .iter()
            .zip(&found)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let moved = expected
            .iter()
            .zip(&x)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        let scale = x.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        let n = plan.dim as f64;
        let bound = match precision {
            Precision::F64 => 0.0,
            Precision::F32 => {
                f64::from(f32::EPSILON) * scale * (8.0 * n + 40.0) * f64::from(ITERATIONS)
            }
        };
        print_bound(
            format_args!(
                "collide {precision} {} ({} particles, {} pairs, {} active, max move {moved:.2e})",
                case.name,
                plan.particle_count(),
                contacts.pairs.len(),
                contacts.active_count()
            ),
            format_args!("{err:e}"),
            format_args!("{bound:e}"),
            format_args!(
                "{}",
                if precision == Precision::F64 {
                    "same operations, correctly rounded"
                } else {
                    "ε·X·(8N+40)·iterations"
                }
            ),
        );
        assert!(
            err <= bound,
            "{precision} {}: error {err:e} > bound {bound:e}",
            case.name
        );
        if case.frames > 0 {
            assert!(
                contacts.active_count() > 0,
                "{}: the case must have active contacts",
                case.name
            );
        }
    }
}

/// f32 on lavapipe: `found` is the f32 reference's iteration on the same
/// lists, bit for bit.
fn check_reference(name: &str, plan: &Plan, input: &CollideInput, found: &[f64]) {
    let lists: Vec<Vec<u32>> = (0..plan.particle_count())
        .map(|k| {
            let range = input.offsets[k] as usize..input.offsets[k + 1] as usize;
            let entries = &input.entries[range];
            let partner = |&e: &u32| input.pairs[e as usize / 2][1 - e as usize % 2];
            entries.iter().map(partner).collect()
        })
        .collect();
    let reference = f32_reference::iterate(
        &f32_reference::Iteration {
            dim: plan.dim,
            x: input.x,
            p: input.p,
            inverse_mass: input.inverse_mass,
            radius: input.radius,
            lists: &lists,
            friction: input.friction,
        },
        ITERATIONS,
    )
    .expect("f32 reference collide");
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let differs = reference
        .iter()
        .zip(found)
        .filter(|(a, b)| a.to_bits() != b.to_bits())
        .count();
    print_bound(
        format_args!(
            "collide f32 {name} vs f32 reference ({} coordinates)",
            found.len()
        ),
        format_args!("{differs} differ"),
        "0",
        "llvmpipe: bit-identical",
    );
    assert!(
        bits(&reference) == bits(found),
        "{name}: f32 collide on llvmpipe is not bit-identical to the f32 reference \
         ({differs} coordinates differ)"
    );
}

#[test]
fn gpu_collide_matches_cpu_f64() {
    differential(Precision::F64);
}

#[test]
fn gpu_collide_matches_cpu_f32() {
    differential(Precision::F32);
}

/// The GPU sweep and contact iteration are bit-identical across runs on one
/// adapter (integer sort and scan; no float atomics; fixed gather order).
#[test]
fn gpu_sweep_and_collide_are_deterministic() {
    for precision in [Precision::F32, Precision::F64] {
        let Some((adapter, _)) = adapter_or_skip("gpu_collide_determinism", precision) else {
            return;
        };
        let scene = hyperpbd::scenes::ballpit4d();
        let plan = Plan::compile(&scene).expect("valid");
        let mut cpu = CpuBackend::new(plan.clone(), &State::from_scene(&scene)).expect("cpu");
        for _ in 0..20 {
            cpu.step().expect("step");
        }
        let x = cpu.read_state().expect("read").positions;
        let contacts_plan = plan.contacts.expect("collisions");
        let mut contacts = Contacts::default();
        collide::broadphase(&plan, contacts_plan.margin, &x, &x, &mut contacts);
        let gpu = GpuCollide::with_adapter(&adapter, plan.dim, precision).expect("kernels");
        let input = CollideInput {
            x: &x,
            p: &x,
            inverse_mass: &plan.inverse_mass,
            radius: &plan.radius,
            pairs: &contacts.pairs,
            offsets: &contacts.offsets,
            entries: &contacts.entries,
            friction: contacts_plan.friction,
        };
        let bits = |v: Vec<f64>| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let first = bits(gpu.iterate(&input, 8).expect("run 1"));
        let second = bits(gpu.iterate(&input, 8).expect("run 2"));
        assert!(first == second, "{precision}: collide differs between runs");
        let boxes = hyperpbd_core::broadphase::Aabbs::particles(4, &x, &plan.radius, 0.02);
        let mut sweep =
            hyperpbd_gpu::GpuSweep::with_adapter(&adapter, 4, precision, 8).expect("sweep");
        let a = sweep.sweep(&boxes, 3).expect("sweep 1");
        let b = sweep.sweep(&boxes, 3).expect("sweep 2");
        assert_eq!(a, b, "{precision}: sweep differs between runs");
    }
}
