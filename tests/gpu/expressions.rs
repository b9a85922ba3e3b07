//! Expression families on the GPU: the WGSL generated from each family's
//! tapes performs the golden projection's operations in the golden order,
//! so on lavapipe gpu-f64 is the golden path and gpu-f32 the f32 reference
//! bit for bit — states, residuals and active contacts, every frame from
//! the start — for distance, tether, plane, Gram and oriented-measure
//! expressions, one that uses ln, exp, min, max and abs, and both bending
//! models (the quadratic one reads per-element constants from `rest`,
//! on the standard update and on the primal-residual one).

use crate::common;

use common::exact::{assert_f32_reference_step, assert_identical_if_claimed, bits};
use common::expressions::as_expressions;
use common::gpu::adapter_or_skip;
use hyperpbd::kinds::{BendingModel, Relation};
use hyperpbd::{
    Backend, ConstraintFamily, ConstraintKind, CpuBackend, F32Reference, Obstacle, Plan, Scene,
    State, scenes,
};
use hyperpbd_gpu::Precision;

fn cases() -> Vec<(&'static str, Scene, usize)> {
    let cloth = as_expressions(
        &scenes::cloth(8),
        ConstraintKind::Distance,
        "norm(x1 - x0)",
        Relation::Equal,
    );
    let mut chain = scenes::chain2d();
    for family in &mut chain.constraints {
        family.kind = ConstraintKind::Tether;
    }
    let chain = as_expressions(
        &chain,
        ConstraintKind::Tether,
        "norm(x1 - x0)",
        Relation::AtMost,
    );
    let tesseract = as_expressions(
        &scenes::tesseract(),
        ConstraintKind::OrientedMeasure,
        "det(x1 - x0, x2 - x0, x3 - x0, x4 - x0) / 24",
        Relation::Equal,
    );
    // A cloth on a plane written as dot(n, x0) ≥ rest, with a soft
    // bending-like term that calls ln, exp, min, max and abs.
    let mut sheet = scenes::cloth(6);
    let Some(Obstacle::Hyperplane { offset, .. }) = sheet.obstacles.first().cloned() else {
        panic!("a plane")
    };
    sheet.obstacles.clear();
    let dynamic: Vec<Vec<usize>> = (0..sheet.particles.len())
        .filter(|&i| !sheet.particles[i].fixed)
        .map(|i| vec![i])
        .collect();
    let rest = dynamic
        .iter()
        .map(|e| offset + sheet.particles[e[0]].radius)
        .collect();
    let mut plane =
        ConstraintFamily::expression("dot(n, x0)", 0.0, dynamic).with_relation(Relation::AtLeast);
    plane.params = Some(serde_json::Map::from_iter([(
        "n".to_string(),
        serde_json::json!([0.0, 1.0, 0.0]),
    )]));
    plane.rest = Some(rest);
    let triples: Vec<Vec<usize>> = (0..6)
        .flat_map(|r| (0..4).map(move |c| vec![r * 6 + c, r * 6 + c + 1, r * 6 + c + 2]))
        .collect();
    let mut soft = ConstraintFamily::expression(
        "let a = norm(x1 - x0); let b = norm(x2 - x1); \
         ln(1 + exp(min(a, b) / max(a, b))) + abs(a - b) * k",
        1e-4,
        triples,
    );
    soft.params = Some(serde_json::Map::from_iter([(
        "k".to_string(),
        serde_json::json!(0.5),
    )]));
    sheet.constraints.push(soft);
    sheet.constraints.push(plane);
    // A cloth with bending (a built-in kind written as an expression)
    // draped over a plane; the quadratic model also on the primal-residual
    // update, and with a tilted cloth so that no two hinges' weights agree.
    let draped = |model: BendingModel, primal: bool| {
        let mut b = hyperpbd::SceneBuilder::new(3)
            .dt(1.0 / 60.0)
            .substeps(10)
            .gravity_along(1, 9.81);
        let grid = b.grid(&hyperpbd::builders::GridSpec::cloth(8, 8, 0.1, 0.3));
        b.grid_bending(&grid, 1e-4, model).expect("hinges");
        b.hyperplane(vec![0.0, 1.0, 0.0], 0.0, 0.3);
        let mut scene = b.build().expect("valid");
        if primal {
            scene.solver = hyperpbd::Solver::Xpbd(hyperpbd::XpbdSettings {
                primal_residual: true,
            });
            for p in &mut scene.particles {
                let [x, y, z] = p.position[..] else {
                    panic!("R^3")
                };
                p.position = vec![x + 0.05 * z * z, y + 0.2 * x + 0.1 * x * z, z];
            }
        }
        scene
    };
    vec![
        (
            "cloth 8² bending on a plane",
            draped(BendingModel::Cosine, false),
            25,
        ),
        (
            "cloth 8² quadratic bending on a plane",
            draped(BendingModel::Quadratic, false),
            25,
        ),
        (
            "curved cloth 8² quadratic bending, primal residual",
            draped(BendingModel::Quadratic, true),
            12,
        ),
        ("cloth 8² distance", cloth, 25),
        ("chain2d tether", chain, 25),
        ("tesseract det", tesseract, 12),
        ("sheet plane + ln/exp", sheet, 25),
    ]
}

#[test]
fn gpu_f64_is_the_golden_path_bit_for_bit() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_expressions f64", Precision::F64) else {
        return;
    };
    let mut frames_checked = 0;
    for (name, scene, frames) in cases() {
        let plan = Plan::compile(&scene).expect("compiles");
        let state = State::from_scene(&scene);
        let mut cpu = CpuBackend::new(plan.clone(), &state).expect("cpu");
        let mut gpu =
            hyperpbd::load_on_adapter(&adapter, plan, &state, Precision::F64).expect("gpu");
        for frame in 0..frames {
            let a = cpu
                .step()
                .unwrap_or_else(|e| panic!("{name} cpu {frame}: {e}"));
            let b = gpu
                .step()
                .unwrap_or_else(|e| panic!("{name} gpu {frame}: {e}"));
            let (sa, sb) = (
                cpu.read_state().expect("cpu"),
                gpu.read_state().expect("gpu"),
            );
            if assert_identical_if_claimed(&summary, &format!("{name} frame {frame}"), &sa, &sb) {
                let ra: Vec<u64> = a
                    .residuals
                    .iter()
                    .map(|r| r.max_violation.to_bits())
                    .collect();
                let rb: Vec<u64> = b
                    .residuals
                    .iter()
                    .map(|r| r.max_violation.to_bits())
                    .collect();
                assert_eq!(ra, rb, "{name} frame {frame}: residuals");
                frames_checked += 1;
            }
        }
        assert!(
            bits(&cpu.read_state().expect("s")) != bits(&state),
            "{name}: the scene moved"
        );
    }
    println!("gpu_expressions f64: {frames_checked} frames bit-identical");
}

#[test]
fn gpu_f32_is_the_f32_reference_bit_for_bit() {
    let Some((adapter, summary)) = adapter_or_skip("gpu_expressions f32", Precision::F32) else {
        return;
    };
    if !common::exact::f32_identical(&summary) {
        eprintln!("gpu_expressions f32: not an exact adapter ({summary}); nothing to assert");
        return;
    }
    let mut frames_checked = 0;
    for (name, scene, frames) in cases() {
        let plan = Plan::compile(&scene).expect("compiles");
        let state = State::from_scene(&scene);
        let origin = vec![0.0; scene.dim];
        let mut reference = F32Reference::new(plan.clone(), &state, &origin).expect("reference");
        let mut gpu =
            hyperpbd::load_on_adapter(&adapter, plan, &state, Precision::F32).expect("gpu");
        for frame in 0..frames as u64 {
            let report = gpu
                .step()
                .unwrap_or_else(|e| panic!("{name} gpu {frame}: {e}"));
            let s = gpu.read_state().expect("gpu");
            assert_f32_reference_step(name, frame, &mut reference, &report, &s);
            frames_checked += 1;
        }
    }
    assert!(frames_checked >= 100, "{frames_checked}");
    println!("gpu_expressions f32: {frames_checked} frames bit-identical");
}
