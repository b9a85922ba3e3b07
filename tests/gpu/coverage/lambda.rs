//! Projection kernels with λ ≠ 0: each (family, color) projected several
//! times in a row without a prediction in between, so from the second call
//! on the multiplier of every element is nonzero and enters
//!
//! ```text
//! Δλ = (−C − α~ λ) / (Σ w |∇C|² + α~)           every kind (α > 0 here)
//! contact  λ' = max(λ + Δλ, 0),  tether  λ' = min(λ + Δλ, 0)
//! static friction  |Δt| ≤ μ w λ'
//! ```
//! (`tests/gpu/kernels/` projects each color once after the reset λ = 0,
//! where α~λ vanishes.) Kernel level, both backends from the same state;
//! f64 on lavapipe bit for bit after every call (`common::exact`); the
//! material families (stvk, neo_hookean) on a compressed Kuhn block in 2, 3
//! and 4 D likewise, and in f32 against the f32 reference. This
//! test asserts identity only: on an adapter that does not promise it, it
//! says so and checks nothing (the whole-step tests keep their bounds
//! there).

use super::*;

use common::exact::{assert_identical_if_claimed, bits, f32_identical, f64_identical};
use common::gpu::adapter_or_skip;
use hyperpbd::{
    Backend, ConstraintFamily, ConstraintKind, CpuBackend, F32Reference, Kernel, Obstacle,
    Particle, Plan, SceneBuilder, State,
};
use hyperpbd_gpu::{GpuBackend, Precision};

/// A chain in R^dim whose links are stretched 5 %, tethers from its fixed
/// first particle stretched too (rest 90 % of the distance), squared-area
/// triangles and one oriented N-simplex off their rest values, and a plane
/// with friction that every particle penetrates by 1–3 mm: every family
/// kind violated, every one compliant.
fn violated(dim: usize) -> Scene {
    let mut rng = Lcg(31 + dim as u64);
    let mut b = SceneBuilder::new(dim)
        .dt(1.0 / 60.0)
        .substeps(2)
        .iterations(4)
        .gravity_along(1, 9.81);
    let n = 9;
    let mut ids = Vec::new();
    for i in 0..n {
        let x: Vec<f64> = (0..dim)
            .map(|a| match a {
                0 => 0.105 * i as f64 + 0.003 * rng.next(),
                1 => -0.002 - 0.001 * (1.0 + rng.next()),
                _ => 0.02 * rng.next(),
            })
            .collect();
        let v: Vec<f64> = (0..dim).map(|_| 0.4 * rng.next()).collect();
        let mut p = Particle::new(x, 0.2 + 0.1 * i as f64).with_velocity(v);
        if i == 0 {
            p = Particle::fixed(p.position.clone());
        }
        ids.push(b.particle(p));
    }
    let links: Vec<Vec<usize>> = ids.windows(2).map(|w| w.to_vec()).collect();
    let mut distance = ConstraintFamily::new(ConstraintKind::Distance, 1e-5, links);
    distance.rest = Some(vec![0.1; n - 1]);
    b.family(distance);
    let tethers: Vec<Vec<usize>> = ids[2..].iter().map(|&i| vec![ids[0], i]).collect();
    let mut tether = ConstraintFamily::new(ConstraintKind::Tether, 1e-6, tethers);
    tether.rest = Some((2..n).map(|i| 0.09 * i as f64).collect());
    b.family(tether);
    let triangles: Vec<Vec<usize>> = ids[1..].windows(3).map(|w| w.to_vec()).collect();
    let count = triangles.len();
    let mut area = ConstraintFamily::new(ConstraintKind::SimplexMeasure, 1e-9, triangles);
    area.rest = Some(vec![1e-6; count]);
    b.family(area);
    let simplex: Vec<usize> = ids[1..=dim + 1].to_vec();
    let mut oriented = ConstraintFamily::new(ConstraintKind::OrientedMeasure, 1e-8, vec![simplex]);
    oriented.rest = Some(vec![1e-4]);
    b.family(oriented);
    let mut scene = b.build().expect("valid");
    scene.obstacles.push(Obstacle::Hyperplane {
        normal: unit(dim, &[0.0, 1.0]),
        offset: 0.0,
        friction: 0.6,
        compliance: 1e-7,
        motion: Vec::new(),
    });
    valid(scene)
}

/// The f64 adapter of `test` if it promises bit identity (this file
/// asserts nothing else); `None` after saying why not.
fn identity_adapter(test: &str) -> Option<(wgpu::Adapter, hyperpbd_gpu::AdapterSummary)> {
    let (adapter, summary) = adapter_or_skip(test, Precision::F64)?;
    if !f64_identical(&summary) {
        println!(
            "NOT CHECKED: {test} asserts f64 bit identity, which {} does not promise",
            summary.name
        );
        return None;
    }
    Some((adapter, summary))
}

/// Projects every (family, color) of `scene` 4 times in a row after one
/// prediction, CPU and GPU (f64) from the same state, asserting bit
/// identity after every call and that every family saw λ ≠ 0; returns the
/// number of projection calls.
fn project_repeatedly(
    adapter: &wgpu::Adapter,
    summary: &hyperpbd_gpu::AdapterSummary,
    label: &str,
    scene: &Scene,
) -> usize {
    let plan = Plan::compile(scene).expect("compiles");
    let state = State::from_scene(scene);
    let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
    let mut gpu =
        GpuBackend::with_adapter(adapter, plan.clone(), &state, Precision::F64).expect("gpu");
    let mut calls = 0;
    let mut nonzero = vec![false; plan.families.len()];
    for (f, family) in plan.families.iter().enumerate() {
        for color in 0..family.color_count() {
            // Same start on both: the GPU's state; Predict resets λ.
            let start = gpu.read_state().expect("gpu state");
            cpu.write_state(&start).expect("cpu write_state");
            cpu.run_kernel(Kernel::Predict).expect("cpu predict");
            gpu.run_kernel(Kernel::Predict).expect("gpu predict");
            for repeat in 0..4 {
                let kernel = Kernel::Project { family: f, color };
                cpu.run_kernel(kernel).expect("cpu project");
                gpu.run_kernel(kernel).expect("gpu project");
                calls += 1;
                let name = format!("{label} {} color {color} call {repeat}", family.label);
                assert_identical_if_claimed(
                    summary,
                    &name,
                    &cpu.read_state().expect("cpu"),
                    &gpu.read_state().expect("gpu"),
                );
                if repeat == 0 {
                    let lambda = cpu.multipliers(f).expect("family");
                    nonzero[f] |= family.color(color).any(|slot| lambda[slot] != 0.0);
                }
            }
        }
    }
    // The repeated calls did see λ ≠ 0 in every family (else α~λ and
    // the clamps would still be untested).
    for (f, family) in plan.families.iter().enumerate() {
        assert!(
            nonzero[f],
            "{label} {}: every multiplier stayed 0",
            family.label
        );
    }
    calls
}

#[test]
fn repeated_projections_with_nonzero_multipliers_match_bit_for_bit() {
    let Some((adapter, summary)) =
        identity_adapter("repeated_projections_with_nonzero_multipliers_match_bit_for_bit")
    else {
        return;
    };
    for dim in [2, 3, 4] {
        let calls = project_repeatedly(&adapter, &summary, &format!("R^{dim}"), &violated(dim));
        println!("LAMBDA | R^{dim} | {calls} projection calls with λ ≠ 0 | f64 bit-identical");
    }
}

/// The Kuhn block of `common::guarded::material_block` (E = 2e5 Pa,
/// ν = 0.3) whose authored rest shape is the initial one scaled by 1.08
/// about the block's first node: every element starts compressed 8 %
/// (J ≈ 0.93^N > 0, so Neo-Hookean evaluates), C = √(2W) far from 0; the
/// plane (never touched) removed, so the material is the only family.
fn compressed_material_block(dim: usize, law: ConstraintKind) -> Scene {
    let mut scene = common::guarded::material_block(dim, 0.0, law, None, None);
    scene.obstacles.clear();
    let anchor = scene.particles[0].position.clone();
    let rest: Vec<Vec<f64>> = scene
        .particles
        .iter()
        .map(|p| {
            p.position
                .iter()
                .zip(&anchor)
                .map(|(x, o)| o + 1.08 * (x - o))
                .collect()
        })
        .collect();
    let family = scene.constraints.remove(0).with_rest_positions(rest);
    scene.constraints.push(family);
    valid(scene)
}

#[test]
fn repeated_material_projections_with_nonzero_multipliers_match_bit_for_bit() {
    // The material energy constraint's α~λ term (α = 1, α~ = 1/h²) reached
    // directly: tests/gpu/materials.rs compares whole steps only, where a
    // mistake in α~λ could hide behind the first iteration's λ = 0.
    let Some((adapter, summary)) = identity_adapter(
        "repeated_material_projections_with_nonzero_multipliers_match_bit_for_bit",
    ) else {
        return;
    };
    for dim in [2, 3, 4] {
        for (law, name) in [
            (ConstraintKind::Stvk, "stvk"),
            (ConstraintKind::NeoHookean, "neo_hookean"),
        ] {
            let label = format!("R^{dim} {name} block");
            let calls = project_repeatedly(
                &adapter,
                &summary,
                &label,
                &compressed_material_block(dim, law),
            );
            println!("LAMBDA | {label} | {calls} projection calls with λ ≠ 0 | f64 bit-identical");
        }
    }
}

/// [`project_repeatedly`] in f32 against the f32 reference (the WGSL's f32
/// operations on the CPU, λ carried as on the device): bit identity after
/// every call; returns the number of projection calls.
fn project_repeatedly_f32(adapter: &wgpu::Adapter, label: &str, scene: &Scene) -> usize {
    let plan = Plan::compile(scene).expect("compiles");
    let state = State::from_scene(scene);
    let mut gpu =
        GpuBackend::with_adapter(adapter, plan.clone(), &state, Precision::F32).expect("gpu");
    let mut reference = F32Reference::new(plan.clone(), &state, gpu.origin().as_slice())
        .expect("the f32 reference runs material families");
    let mut calls = 0;
    for (f, family) in plan.families.iter().enumerate() {
        for color in 0..family.color_count() {
            let start = gpu.read_state().expect("gpu state");
            reference
                .write_state(&start)
                .expect("reference write_state");
            reference
                .run_kernel(Kernel::Predict)
                .expect("reference predict");
            gpu.run_kernel(Kernel::Predict).expect("gpu predict");
            for repeat in 0..4 {
                let kernel = Kernel::Project { family: f, color };
                reference.run_kernel(kernel).expect("reference project");
                gpu.run_kernel(kernel).expect("gpu project");
                calls += 1;
                assert!(
                    bits(&reference.read_state()) == bits(&gpu.read_state().expect("gpu")),
                    "{label} {} color {color} call {repeat}: f32 on llvmpipe differs from the \
                     f32 reference",
                    family.label
                );
            }
        }
    }
    calls
}

#[test]
fn repeated_f32_material_projections_match_the_f32_reference_bit_for_bit() {
    // The material kernel alone in f32 (gpu_materials holds whole steps):
    // both laws, 2–4 D, compressed 8 % so C is far from 0 and λ ≠ 0 from
    // the second call on.
    let test = "repeated_f32_material_projections_match_the_f32_reference_bit_for_bit";
    let Some((adapter, summary)) = adapter_or_skip(test, Precision::F32) else {
        return;
    };
    if !f32_identical(&summary) {
        println!(
            "NOT CHECKED: {test} asserts f32 bit identity, which {} does not promise",
            summary.name
        );
        return;
    }
    for dim in [2, 3, 4] {
        for (law, name) in [
            (ConstraintKind::Stvk, "stvk"),
            (ConstraintKind::NeoHookean, "neo_hookean"),
        ] {
            let label = format!("R^{dim} {name} block");
            let calls =
                project_repeatedly_f32(&adapter, &label, &compressed_material_block(dim, law));
            println!(
                "LAMBDA | {label} | {calls} f32 projection calls (4 per colour) | bit-identical to the f32 reference"
            );
        }
    }
}
