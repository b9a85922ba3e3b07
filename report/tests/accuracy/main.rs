//! The accuracy report (`hyperpbd-report`) on a tiny subset: the files it writes and the
//! sanity of its numbers.
//!
//! One run (a few seconds) of the quick path narrowed to the pendulum, free
//! fall, a 4 × 4 cloth and the rope bridge, cloth side 8–16 for scaling and
//! effects, 12 balls for the collision and barrier rows; cpu-f64 and, where an adapter exists, gpu-f32 (skipped with a
//! notice otherwise, failing under `HYPERPBD_REQUIRE_GPU=1`). The helper
//! math (zero crossings, power-law fit, Pareto frontier) is checked on
//! inputs with known answers.

#[path = "../../../tests/common/mod.rs"]
mod common;

use hyperpbd::Precision;
use hyperpbd::{Collisions, Kernel, Plan, Scene};
use hyperpbd_report::cases::{CaseId, zero_crossings};
use hyperpbd_report::effects::{self, EffectRow};
use hyperpbd_report::granular_effects;
use hyperpbd_report::pareto::frontier;
use hyperpbd_report::point::Point;
use hyperpbd_report::readme::{EFFECTS_BEGIN, EFFECTS_END, README_BEGIN, README_END};
use hyperpbd_report::scaling::fit_power_law;
use hyperpbd_report::{BackendKind, Config, Report, run};
use std::path::PathBuf;
use std::sync::OnceLock;

const G: f64 = 9.81;

fn out_dir() -> PathBuf {
    std::env::temp_dir().join(format!("hyperpbd-accuracy-test-{}", std::process::id()))
}

/// The one tiny run every test reads, or `None` when the calling test `test`
/// ran in the binary's child process on one lavapipe thread
/// ([`common::gpu::binary_on_one_lavapipe_thread`]: the GPU rows are
/// hundreds of small dispatches each).
fn report(test: &str) -> Option<&'static (Report, Config)> {
    static RUN: OnceLock<(Report, Config)> = OnceLock::new();
    if !common::gpu::binary_on_one_lavapipe_thread(test) {
        return None;
    }
    Some(RUN.get_or_init(|| {
        let dir = out_dir();
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("temp dir");
        let readme = dir.join("README.md");
        std::fs::write(
            &readme,
            format!("# Project\n\nintro\n\n## What accuracy costs\n\n{README_BEGIN}\nold text\n{README_END}\n\n## After\n\nkept\n"),
        )
        .expect("readme");
        let mut config = Config::quick(&dir);
        config.readme = Some(readme);
        config.progress = false;
        config.cases = vec![CaseId::Pendulum, CaseId::FreeFall, CaseId::Cloth, CaseId::Chain2d];
        config.backends = vec![BackendKind::Cpu, BackendKind::Gpu(Precision::F32)];
        config.substeps = vec![1, 4, 16];
        config.iterations = vec![1, 2];
        config.cloth_n = 4;
        config.scaling_sizes = vec![8, 16];
        config.cpu_scaling_max = 16;
        config.effects_n = 8;
        config.effects_balls = (2, 3);
        config.effects_ball_steps = 3;
        config.time_target = 0.002;
        config.newton_budgets = vec![1, 2];
        config.cg_budgets = vec![None];
        let report = run(&config).unwrap_or_else(|e| panic!("accuracy run failed: {e}"));
        (report, config)
    }))
}

fn points(report: &Report, case: CaseId, backend: BackendKind) -> Vec<&Point> {
    report
        .cases
        .iter()
        .find(|c| c.case == case)
        .map(|c| c.points.iter().filter(|p| p.backend == backend).collect())
        .unwrap_or_default()
}

fn gpu_ran(report: &Report) -> bool {
    report.cases.iter().any(|c| {
        c.points
            .iter()
            .any(|p| p.backend == BackendKind::Gpu(Precision::F32))
    })
}

#[test]
fn writes_every_file() {
    let Some((report, config)) =
        report(&common::gpu::test_name(module_path!(), "writes_every_file"))
    else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    let dir = &config.out;
    for f in [
        "accuracy.md",
        "figures/accuracy_pareto.png",
        "figures/accuracy_cloth.png",
        "figures/scaling.png",
        "figures/accuracy.json",
        "figures/patch.json",
        "figures/accuracy_patch.png",
    ] {
        let path = dir.join(f);
        let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(
            bytes.len() > 1000,
            "{} is only {} bytes",
            path.display(),
            bytes.len()
        );
        if f.ends_with(".png") {
            assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{f} is not a PNG");
        }
        assert!(
            report.files.iter().any(|g| g == f),
            "{f} missing from report.files"
        );
    }
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("figures/accuracy.json")).expect("json"))
            .expect("accuracy.json parses");
    assert_eq!(json["mode"], "quick");
    assert!(json["cases"].as_array().is_some_and(|c| c.len() == 4));
}

#[test]
fn markdown_names_machine_adapter_and_headlines() {
    let Some((report, config)) = report(&common::gpu::test_name(
        module_path!(),
        "markdown_names_machine_adapter_and_headlines",
    )) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    let md = std::fs::read_to_string(config.out.join("accuracy.md")).expect("markdown");
    assert!(md.contains(&report.machine.cpu_model), "CPU model missing");
    assert!(md.contains(&format!("| nproc | {} |", report.machine.nproc)));
    assert!(md.contains("GPU adapter (f32)"));
    assert!(
        md.contains("median of"),
        "the report must say timings are medians"
    );
    assert!(md.contains("## Headline answers"));
    assert!(md.contains("figures/accuracy_pareto.png"));
    assert!(md.contains("## Scaling") && md.contains("## What each effect costs"));
    assert!(
        md.contains("## Implicit path: error against the Newton and CG budgets")
            && md.contains("### implicit hanging"),
        "accuracy.md must carry the implicit rows"
    );
    assert!(report.files.iter().any(|f| f == "figures/implicit.json"));
    let (implicit_end, patch, scaling) = (
        md.find("<!-- implicit-budgets:end -->"),
        md.find("## The patch test: equilibrium error against wall time"),
        md.find("## Scaling"),
    );
    assert!(
        implicit_end < patch && patch < scaling && md.contains("### patch 2D Neo-Hookean"),
        "accuracy.md must carry the patch test between the implicit rows and Scaling"
    );
    assert!(
        md.contains("[effects.md](effects.md)"),
        "accuracy.md must link the effect tables"
    );
    let effects = std::fs::read_to_string(config.out.join("effects.md")).expect("effects.md");
    assert!(effects.contains("## Cloth: one effect at a time"));
    assert!(effects.contains("## Balls: particle–particle collisions and the barrier solver"));
    assert!(effects.contains("+ collisions (μ = 0)") && effects.contains("| minimise |"));
    assert!(
        !effects.contains("not yet available"),
        "collisions and the barrier path exist: no effect is left as not yet available"
    );
    assert!(report.files.iter().any(|f| f == "effects.md"));
    assert!(report.files.iter().any(|f| f == "figures/effects.json"));
    if !gpu_ran(report) {
        assert!(
            report.notices.iter().any(|n| n.contains("SKIPPED gpu-f32")),
            "no GPU points and no skip notice: {:?}",
            report.notices
        );
        assert!(
            !common::gpu::gpu_required(),
            "HYPERPBD_REQUIRE_GPU=1 but no GPU points ran"
        );
    }
}

#[test]
fn readme_section_is_replaced_in_place_and_idempotently() {
    let Some((report, config)) = report(&common::gpu::test_name(
        module_path!(),
        "readme_section_is_replaced_in_place_and_idempotently",
    )) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    let readme = config.readme.as_ref().expect("readme configured");
    let text = std::fs::read_to_string(readme).expect("readme");
    assert!(!text.contains("old text"), "the old section survived");
    assert!(
        text.starts_with("# Project\n\nintro\n"),
        "text before the section changed"
    );
    assert!(
        text.contains("## After\n\nkept\n"),
        "text after the section changed"
    );
    assert!(text.contains("figures/accuracy_cloth.png"));
    assert!(
        text.contains("To reach 1e-3"),
        "the README must give the headline answer"
    );
    assert!(
        text.contains("- The implicit path (coupled Newton–PCG"),
        "the README must give the implicit rows' summary"
    );
    // Writing again leaves exactly one section.
    let mut again = report.clone();
    hyperpbd_report::write::write(&mut again, config).expect("rewrite");
    let text = std::fs::read_to_string(readme).expect("readme");
    assert_eq!(text.matches(README_BEGIN).count(), 1);
    assert_eq!(text.matches(README_END).count(), 1);
    assert_eq!(text.matches("## What accuracy costs").count(), 1);
}

/// The pendulum's period error falls with substeps: at least 4× per 4×
/// substeps (XPBD is at least first order; measured ≈ second order).
#[test]
fn pendulum_error_decreases_with_substeps() {
    let Some((report, _)) = report(&common::gpu::test_name(
        module_path!(),
        "pendulum_error_decreases_with_substeps",
    )) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    let cpu = points(report, CaseId::Pendulum, BackendKind::Cpu);
    assert_eq!(cpu.len(), 3);
    for pair in cpu.windows(2) {
        let (a, b) = (pair[0].error.expect("error"), pair[1].error.expect("error"));
        eprintln!(
            "pendulum s{} {a:e} -> s{} {b:e}: ratio {:.1} / bound ≥ 4",
            pair[0].substeps,
            pair[1].substeps,
            a / b
        );
        assert!(
            b * 4.0 <= a,
            "period error {a:e} -> {b:e} from s{} to s{}",
            pair[0].substeps,
            pair[1].substeps
        );
        // Rigid link: the residual is rounding only.
        assert!(
            pair[1].residual < 1e-12,
            "pendulum residual {:e}",
            pair[1].residual
        );
    }
    // The coarsest point is a real error, not noise: above 1e-5 (measured ≈ 8e-4).
    assert!(cpu[0].error.expect("error") > 1e-5);
    let drift = cpu[0].energy_drift.expect("pendulum is conservative");
    assert!(
        drift < 0.0 && drift > -1.0,
        "XPBD dissipates, never gains: drift {drift}"
    );
}

/// Free fall: semi-implicit Euler's position error is exactly g·h·t/2
/// (x_n = x0 + n h v0 + h² g n(n+1)/2 against x0 + v0 t + g t²/2), so the
/// measured relative error must equal (g h t / 2) / |x*(t) − x0| to
/// rounding.
#[test]
fn free_fall_error_is_the_closed_form_discretisation_error() {
    let Some((report, _)) = report(&common::gpu::test_name(
        module_path!(),
        "free_fall_error_is_the_closed_form_discretisation_error",
    )) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    let t: f64 = 1.0;
    let exact = [1.0 * t, 5.0 * t - 0.5 * G * t * t, 0.5 * t];
    let travel = exact.iter().map(|x| x * x).sum::<f64>().sqrt();
    for p in points(report, CaseId::FreeFall, BackendKind::Cpu) {
        let h = 1.0 / 60.0 / f64::from(p.substeps);
        let expected = 0.5 * G * h * t / travel;
        let rel = (p.error.expect("error") - expected).abs() / expected;
        eprintln!(
            "free fall s{}: {:e} vs g h t / 2 / |x*| = {expected:e}: relative difference {rel:e} / bound 1e-9",
            p.substeps,
            p.error.unwrap_or(f64::NAN)
        );
        assert!(rel < 1e-9, "free fall s{}: {rel:e}", p.substeps);
    }
}

/// Converged cases: more substeps at fixed iterations move towards the
/// reference (the rope bridge monotonically; the stiff 4 × 4 cloth, whose
/// link vibration is unresolved at these substeps, overall), and the
/// reference's own error estimate is below every point's error.
#[test]
fn converged_cases_approach_their_reference() {
    let Some((report, _)) = report(&common::gpu::test_name(
        module_path!(),
        "converged_cases_approach_their_reference",
    )) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    for case in [CaseId::Chain2d, CaseId::Cloth] {
        let result = report
            .cases
            .iter()
            .find(|c| c.case == case)
            .expect("case ran");
        let reference = result
            .reference
            .as_ref()
            .expect("converged case has a reference");
        assert_eq!(reference.substeps, 16 * 16);
        let cpu = points(report, case, BackendKind::Cpu);
        for i in [1, 2] {
            let errors: Vec<f64> = cpu
                .iter()
                .filter(|p| p.iterations == i)
                .map(|p| p.error.expect("error"))
                .collect();
            eprintln!(
                "{} i{i}: errors {errors:?}, reference uncertainty {:e}",
                case.name(),
                reference.uncertainty
            );
            assert_eq!(errors.len(), 3);
            let decreasing = match case {
                CaseId::Chain2d => errors.windows(2).all(|w| w[1] < w[0]),
                _ => errors[2] < errors[0] / 4.0,
            };
            assert!(decreasing, "{} i{i}: {errors:?}", case.name());
            assert!(
                errors.iter().all(|&e| reference.uncertainty < e),
                "{}: reference not finer than the points",
                case.name()
            );
        }
    }
}

#[test]
fn every_point_is_timed_and_frontiers_exist() {
    let Some((report, _)) = report(&common::gpu::test_name(
        module_path!(),
        "every_point_is_timed_and_frontiers_exist",
    )) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    for c in &report.cases {
        for p in &c.points {
            assert!(
                p.ms_per_sim_second.is_finite() && p.ms_per_sim_second > 0.0,
                "{p:?}"
            );
            assert!(
                p.ms_min <= p.ms_per_sim_second && p.ms_per_sim_second <= p.ms_max,
                "{p:?}"
            );
            assert!(p.residual.is_finite(), "{p:?}");
            assert!(p.error.is_some_and(|e| e.is_finite() && e >= 0.0), "{p:?}");
        }
        assert!(
            c.points
                .iter()
                .any(|p| p.frontier && p.backend == BackendKind::Cpu),
            "{}: no frontier",
            c.case.name()
        );
    }
    assert!(
        report
            .headlines
            .iter()
            .any(|h| h.case == CaseId::Pendulum && h.reached.is_some())
    );
}

/// The same plan on the GPU: f32 rounding on top of the same algorithm, so
/// the coarse pendulum (whose error is discretisation, ≈ 8e-4) agrees with
/// the CPU to well within its own size.
#[test]
fn gpu_points_agree_with_cpu_where_discretisation_dominates() {
    let Some((report, _)) = report(&common::gpu::test_name(
        module_path!(),
        "gpu_points_agree_with_cpu_where_discretisation_dominates",
    )) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    if !gpu_ran(report) {
        common::gpu::record_skip(
            "gpu_points_agree_with_cpu_where_discretisation_dominates",
            &format!("{:?}", report.notices),
        );
        return;
    }
    let cpu = points(report, CaseId::Pendulum, BackendKind::Cpu);
    let gpu = points(report, CaseId::Pendulum, BackendKind::Gpu(Precision::F32));
    let (a, b) = (cpu[0].error.expect("cpu"), gpu[0].error.expect("gpu"));
    eprintln!(
        "pendulum s1: cpu {a:e}, gpu-f32 {b:e}: difference {:e} / bound {:e}",
        (a - b).abs(),
        0.1 * a
    );
    assert!((a - b).abs() < 0.1 * a);
}

mod effects_and_scaling;
