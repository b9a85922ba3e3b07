//! The implicit rows of the accuracy report (report/src/implicit_budgets.rs):
//! one `--only-implicit` run of the quick grid (Newton 1, 4, 16 × CG 2,
//! none; well under a second in release) into a directory holding an
//! earlier report and README, then checks of its numbers against the
//! cases' known answers and of the files it spliced.

/// The skip count of scripts/test.sh (`record_skip`) and the child on one
/// lavapipe thread (`binary_on_one_lavapipe_thread`).
#[allow(dead_code)]
#[path = "../../tests/common/gpu.rs"]
mod gpu;

use hyperpbd_report::implicit_budgets::{CASES, ImplicitCase, ImplicitPoint, ImplicitResult};
use hyperpbd_report::implicit_markdown::{HEADING, IMPLICIT_BEGIN, IMPLICIT_END};
use hyperpbd_report::readme::{README_BEGIN, README_END};
use hyperpbd_report::{Config, Report, run, write};
use std::path::PathBuf;
use std::sync::OnceLock;

const EARLIER: &str = "# What accuracy costs\n\nearlier sweep\n\n## Scaling\n\nearlier scaling\n\n## Notices\n\n- kept\n";

fn out_dir() -> PathBuf {
    std::env::temp_dir().join(format!("hyperpbd-implicit-rows-{}", std::process::id()))
}

/// The one run every test reads, or `None` when the calling test `test`
/// ran in the binary's child process on one lavapipe thread
/// ([`gpu::binary_on_one_lavapipe_thread`]: the GPU rows are
/// hundreds of small dispatches each).
fn report(test: &str) -> Option<&'static (Report, Config)> {
    static RUN: OnceLock<(Report, Config)> = OnceLock::new();
    if !gpu::binary_on_one_lavapipe_thread(test) {
        return None;
    }
    Some(RUN.get_or_init(|| {
        let dir = out_dir();
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("temp dir");
        std::fs::write(dir.join("accuracy.md"), EARLIER).expect("accuracy.md");
        let readme = dir.join("README.md");
        std::fs::write(
            &readme,
            format!("# Project\n\n{README_BEGIN}\nearlier lines\n{README_END}\n\n## After\n"),
        )
        .expect("readme");
        let mut config = Config::quick(&dir);
        config.readme = Some(readme);
        config.progress = false;
        config.implicit_only = true;
        let report = run(&config).unwrap_or_else(|e| panic!("implicit rows failed: {e}"));
        (report, config)
    }))
}

fn case(report: &Report, case: ImplicitCase) -> &ImplicitResult {
    report
        .implicit
        .as_ref()
        .expect("the implicit section ran")
        .cases
        .iter()
        .find(|c| c.case == case)
        .unwrap_or_else(|| panic!("no {} rows", case.name()))
}

/// cpu-f64's point at these budgets.
fn point(r: &ImplicitResult, newton: u32, cg: Option<u32>) -> &ImplicitPoint {
    r.points
        .iter()
        .find(|p| p.backend == "cpu-f64" && p.newton_budget == newton && p.cg_budget == cg)
        .unwrap_or_else(|| panic!("{}: no point Newton {newton} × CG {cg:?}", r.case.name()))
}

fn error(r: &ImplicitResult, newton: u32, cg: Option<u32>) -> f64 {
    point(r, newton, cg)
        .error
        .unwrap_or_else(|| panic!("{}: Newton {newton} × CG {cg:?}: no error", r.case.name()))
}

#[test]
fn every_budget_has_a_timed_row_within_its_budgets() {
    let Some((report, config)) = report(&gpu::test_name(
        module_path!(),
        "every_budget_has_a_timed_row_within_its_budgets",
    )) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    let running = running_gpu_backends(report);
    for c in CASES {
        let r = case(report, c);
        let on = |backend: &str| r.points.iter().filter(|p| p.backend == backend).count();
        assert_eq!(
            on("cpu-f64"),
            config.newton_budgets.len() * config.cg_budgets.len(),
            "{}",
            c.name()
        );
        for b in ["gpu-f32", "gpu-f64"] {
            let expected = if running.contains(&b) {
                config.gpu_newton_budgets.len() * config.gpu_cg_budgets.len()
            } else {
                0
            };
            assert_eq!(on(b), expected, "{} on {b}", c.name());
        }
        for p in &r.points {
            let at = format!(
                "{} {} Newton {} × CG {:?}",
                p.backend,
                c.name(),
                p.newton_budget,
                p.cg_budget
            );
            assert!(p.note.is_none(), "{at}: {:?}", p.note);
            assert!(
                p.ms_per_sim_second.is_finite() && p.ms_per_sim_second > 0.0,
                "{at}"
            );
            assert!(p.error.is_some_and(f64::is_finite), "{at}: {:?}", p.error);
            assert!(p.second.is_some_and(f64::is_finite), "{at}: {:?}", p.second);
            let b = &p.budgets;
            assert_eq!(b.minimisations as u64, c.frames(), "{at}: one per frame");
            assert_eq!(
                b.converged + b.budget_exhausted + b.rounding_floor,
                b.minimisations,
                "{at}: every minimisation ended one of the three ways"
            );
            assert!(b.newton_max <= p.newton_budget, "{at}: {b:?}");
            assert!(b.newton_mean <= f64::from(b.newton_max), "{at}: {b:?}");
            if let Some(cg) = p.cg_budget {
                assert!(b.cg_max <= cg, "{at}: {b:?}");
            }
        }
        assert!(
            r.points.iter().any(|p| p.frontier),
            "{}: no frontier",
            c.name()
        );
    }
}

#[test]
fn converged_rows_meet_the_known_answers() {
    let Some((report, _)) = report(&gpu::test_name(
        module_path!(),
        "converged_rows_meet_the_known_answers",
    )) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    let incline = case(report, ImplicitCase::Incline);
    let p = point(incline, 16, None);
    let e = p.error.unwrap_or(f64::NAN);
    assert!(e < 1e-6, "incline against backward Euler: {e:e}");
    // Backward Euler slides ½ a t (t + h): h / t = 1/60 beyond ½ a t².
    let s = p.second.unwrap_or(f64::NAN);
    assert!(
        (s - 1.0 / 60.0).abs() < 1e-3,
        "incline against ½ a t²: {s:e}"
    );
    let hanging = case(report, ImplicitCase::Hanging);
    let e = error(hanging, 16, None);
    assert!(e < 1e-6, "hanging chain against α g Σ m: {e:e}");
    let chain = case(report, ImplicitCase::Chain);
    for p in &chain.points {
        let e = p.error.unwrap_or(f64::NAN);
        if p.cg_budget.is_none() {
            assert!(e < 1e-3, "chain: issue 16's target: {e:e}");
        }
    }
}

#[test]
fn budgets_discriminate() {
    let Some((report, _)) = report(&gpu::test_name(module_path!(), "budgets_discriminate")) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    // Two CG iterations per direction cannot solve the 24-coordinate
    // hanging chain with its 1:1e6 masses: one Newton step of them is far
    // off, and more Newton steps close the gap.
    let hanging = case(report, ImplicitCase::Hanging);
    let (one, sixteen, solved) = (
        error(hanging, 1, Some(2)),
        error(hanging, 16, Some(2)),
        error(hanging, 1, None),
    );
    assert!(one > 1e-2, "hanging, Newton 1 × CG 2: {one:e}");
    assert!(
        sixteen < one / 100.0,
        "hanging, Newton 16 × CG 2: {sixteen:e} vs {one:e}"
    );
    assert!(
        solved < one / 1e4,
        "hanging, Newton 1 × CG none: {solved:e}"
    );
    // One Newton step leaves the incline's friction unresolved.
    let incline = case(report, ImplicitCase::Incline);
    assert!(error(incline, 1, None) > 1e-3);
    // The chain holds its links better with more Newton iterations.
    let chain = case(report, ImplicitCase::Chain);
    assert!(error(chain, 16, None) < error(chain, 1, None));
}

#[test]
fn the_section_is_spliced_into_the_earlier_files() {
    let Some((report, config)) = report(&gpu::test_name(
        module_path!(),
        "the_section_is_spliced_into_the_earlier_files",
    )) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    let md = std::fs::read_to_string(config.out.join("accuracy.md")).expect("accuracy.md");
    let (a, b) = (
        md.find(IMPLICIT_BEGIN).expect("begin marker"),
        md.find(IMPLICIT_END).expect("end marker"),
    );
    let scaling = md.find("## Scaling").expect("earlier sections kept");
    assert!(
        md.contains("earlier sweep") && md.contains("earlier scaling") && md.contains("- kept")
    );
    assert!(a < b && b < scaling, "the section goes before Scaling");
    let section = &md[a..b];
    assert!(section.contains(HEADING));
    let rows = section
        .lines()
        .filter(|l| l.starts_with("| ") && !l.starts_with("| backend"))
        .count();
    let points: usize = report
        .implicit
        .as_ref()
        .map_or(0, |s| s.cases.iter().map(|c| c.points.len()).sum());
    assert_eq!(rows, points, "one table row per point");
    for c in CASES {
        assert!(section.contains(&format!("### implicit {}", c.name())));
    }
    let json: serde_json::Value = serde_json::from_slice(
        &std::fs::read(config.out.join("figures/implicit.json")).expect("implicit.json"),
    )
    .expect("implicit.json parses");
    assert_eq!(
        json["implicit"]["cases"].as_array().map(Vec::len),
        Some(CASES.len())
    );

    let readme_path = config.readme.as_ref().expect("readme");
    let readme = std::fs::read_to_string(readme_path).expect("README");
    let (a, b) = (
        readme.find(IMPLICIT_BEGIN).expect("README begin marker"),
        readme.find(README_END).expect("accuracy end marker"),
    );
    assert!(a < b, "the lines go inside the accuracy section");
    assert!(readme.contains("earlier lines") && readme.contains("## After"));
    assert_eq!(readme.matches("- The implicit path").count(), 1);
    for c in CASES {
        assert!(
            readme.contains(&format!("  - {} (error: ", c.name())),
            "{}",
            c.name()
        );
    }

    // Writing again replaces the blocks in place.
    let mut again = report.clone();
    write::write(&mut again, config).expect("second write");
    assert_eq!(
        std::fs::read_to_string(config.out.join("accuracy.md")).expect("accuracy.md"),
        md
    );
    assert_eq!(
        std::fs::read_to_string(readme_path).expect("README"),
        readme
    );
}

/// The GPU backends that ran the implicit rows (their load answer said so).
fn running_gpu_backends(report: &Report) -> Vec<&'static str> {
    let section = report.implicit.as_ref().expect("section");
    section
        .gpu
        .iter()
        .filter(|(_, said)| said.starts_with("runs the coupled step"))
        .map(|(b, _)| b.name())
        .collect()
}

#[test]
fn the_gpu_rows_say_what_each_gpu_backend_does_with_the_coupled_step() {
    let Some((report, _)) = report(&gpu::test_name(
        module_path!(),
        "the_gpu_rows_say_what_each_gpu_backend_does_with_the_coupled_step",
    )) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    let section = report.implicit.as_ref().expect("section");
    let require = std::env::var_os("HYPERPBD_REQUIRE_GPU").is_some();
    if require {
        assert!(
            section.gpu.iter().any(|(b, _)| b.name() == "gpu-f64"),
            "HYPERPBD_REQUIRE_GPU is set but gpu-f64 was not asked: {:?}",
            report.machine.gpu_f64
        );
    }
    for (backend, said) in &section.gpu {
        match backend.name() {
            "gpu-f64" => assert!(said.starts_with("runs the coupled step"), "{said}"),
            // f32 runs it or refuses it with a typed, named reason.
            _ => assert!(
                said.starts_with("runs the coupled step") || said.starts_with("refused: "),
                "{}: {said}",
                backend.name()
            ),
        }
    }
}

#[test]
fn gpu_f64_rows_are_the_cpu_rows_on_lavapipe() {
    let Some((report, config)) = report(&gpu::test_name(
        module_path!(),
        "gpu_f64_rows_are_the_cpu_rows_on_lavapipe",
    )) else {
        return; // run in the child with LP_NUM_THREADS=0
    };
    if !running_gpu_backends(report).contains(&"gpu-f64") {
        assert!(
            std::env::var_os("HYPERPBD_REQUIRE_GPU").is_none(),
            "HYPERPBD_REQUIRE_GPU is set but gpu-f64 has no implicit rows"
        );
        gpu::record_skip(
            "gpu_f64_rows_are_the_cpu_rows_on_lavapipe",
            &"no gpu-f64 adapter here (set HYPERPBD_REQUIRE_GPU=1 to fail instead)",
        );
        return;
    }
    // The identity guarantee is lavapipe's (tests/common/exact.rs); other
    // adapters are held to a finite error.
    let identical = report
        .machine
        .gpu_f64
        .as_ref()
        .is_ok_and(|a| a.contains("llvmpipe"));
    for c in CASES {
        let r = case(report, c);
        for &newton in &config.gpu_newton_budgets {
            for &cg in &config.gpu_cg_budgets {
                let gpu = r
                    .points
                    .iter()
                    .find(|p| {
                        p.backend == "gpu-f64" && p.newton_budget == newton && p.cg_budget == cg
                    })
                    .unwrap_or_else(|| panic!("{}: no gpu-f64 point {newton} × {cg:?}", c.name()));
                let cpu = point(r, newton, cg);
                if identical {
                    assert_eq!(
                        gpu.same_state_as_cpu,
                        Some(true),
                        "{} {newton} × {cg:?}",
                        c.name()
                    );
                    assert_eq!(gpu.error, cpu.error, "{} {newton} × {cg:?}", c.name());
                    assert_eq!(gpu.budgets, cpu.budgets, "{} {newton} × {cg:?}", c.name());
                } else {
                    assert!(gpu.error.is_some_and(f64::is_finite), "{}", c.name());
                }
            }
        }
    }
}
