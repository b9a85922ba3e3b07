//! hyperpbd-report: what accuracy costs in time — the accuracy/effects
//! report, an application kept out of the `hyperpbd` facade (its figures
//! need plotters, png and an embedded font). The `hyperpbd-report` binary
//! runs it (`scripts/accuracy.sh`).
//!
//! ```text
//! sweep     case × backend (cpu-f64, gpu-f32, gpu-f64) × substeps × iterations
//!           → (wall ms per simulated second, error against a known answer,
//!              constraint residual, energy drift)            sweep.rs, cases.rs
//! answers   closed forms (pendulum period, free fall, incline slide, damping
//!           decay) or a converged cpu-f64 run at 16 × the finest swept
//!           substeps                                                 cases.rs
//! frontier  per backend: the points no other point of that backend beats in
//!           both time and error; "to reach ε" = the fastest measured point
//!           with error ≤ ε                                          pareto.rs
//! scaling   ms per step against particle count, hanging cloth n = 32..1024,
//!           exponent of t ≈ a·P^b by least squares on (ln P, ln t) scaling.rs
//! effects   ms per step as effects are added one at a time, with controls
//!           showing that an authored-but-inert effect compiles away effects.rs
//!           (collisions and the barrier solver on balls: granular_effects.rs)
//! implicit  the coupled Newton–PCG step on the incline and the 1:1e6
//!           chain (swinging, hanging), cpu-f64 and every GPU backend that
//!           runs it: error and time against the Newton budget × the CG
//!           budget, iterations used, how the minimisations ended, GPU end
//!           states against cpu-f64's      implicit_budgets.rs (scenes and
//!           answers: implicit_cases.rs, markdown: implicit_markdown.rs)
//! patch     the stressed patch test (2D StVK and Neo-Hookean, 3D StVK):
//!           max |x − F X| after 1 s from X against ms per simulated second
//!           for standard XPBD, XPBD with the primal residual (substeps ×
//!           iterations) and the implicit path (substeps × Newton budget),
//!           cpu-f64 on one thread          patch_study.rs (markdown:
//!           patch_markdown.rs, figure: patch_plot.rs)
//! output    OUT/accuracy.md, OUT/effects.md, OUT/figures/{accuracy_pareto,
//!           accuracy_cloth,scaling}.png, OUT/figures/{accuracy,effects,
//!           implicit,patch}.json, OUT/figures/accuracy_patch.png;
//!           optionally the README section between the accuracy markers
//!           (effects-only runs: effects.md, effects.json and the README's
//!           effect lines only; implicit-only runs: figures/implicit.json
//!           and the implicit section spliced into accuracy.md and the
//!           README; patch-only runs: figures/patch.json,
//!           figures/accuracy_patch.png and the patch section spliced into
//!           accuracy.md)                          write.rs (outputs.rs: the files)
//!           accuracy.md markdown.rs, effects.md effects_markdown.rs,
//!           the README splice readme.rs, shared wording format.rs and
//!           headlines.rs
//! ```
//! Timing (timing.rs): only `Backend::step` is timed; every point is run
//! `reps` times from the same initial state and the median is reported.
//! GPU points are skipped with a printed notice when there is no adapter.

pub mod cases;
pub mod config;
pub mod effects;
pub mod effects_markdown;
pub mod format;
pub mod granular_effects;
pub mod headlines;
pub mod implicit_budgets;
pub mod implicit_cases;
pub mod implicit_markdown;
pub mod machine;
pub mod markdown;
pub mod measured;
pub mod outputs;
pub mod pareto;
pub mod patch_cases;
pub mod patch_markdown;
pub mod patch_plot;
pub mod patch_study;
pub mod plot;
pub mod point;
pub mod progress;
pub mod readme;
pub mod scaling;
pub mod sweep;
pub mod timing;
pub mod write;

pub use cases::CaseId;
pub use config::Config;
pub use hyperpbd::BackendKind;
pub use machine::Machine;
pub use measured::{AccuracyError, Headline, Report};
pub use progress::Progress;

use hyperpbd::Precision;
use std::time::Instant;

/// Runs everything `config` asks for and writes the report.
pub fn run(config: &Config) -> Result<Report, AccuracyError> {
    if config.reps == 0 || config.substeps.is_empty() || config.iterations.is_empty() {
        return Err(AccuracyError::Config(
            "reps, substeps and iterations must be non-empty / at least 1".into(),
        ));
    }
    if config.substeps.contains(&0) || config.iterations.contains(&0) {
        return Err(AccuracyError::Config(
            "substeps and iterations must be ≥ 1".into(),
        ));
    }
    if config.newton_budgets.is_empty()
        || config.cg_budgets.is_empty()
        || config.newton_budgets.contains(&0)
        || config.cg_budgets.contains(&Some(0))
    {
        return Err(AccuracyError::Config(
            "Newton and CG budgets must be non-empty and ≥ 1".into(),
        ));
    }
    let patch_grids = [
        &config.patch_substeps,
        &config.patch_iterations,
        &config.patch_implicit_substeps,
        &config.patch_newton_budgets,
    ];
    if (config.patch || config.patch_only)
        && patch_grids.iter().any(|g| g.is_empty() || g.contains(&0))
    {
        return Err(AccuracyError::Config(
            "the patch study's substeps, iterations and Newton budgets must be non-empty and ≥ 1"
                .into(),
        ));
    }
    let others = !config.effects_only && !config.implicit_only && !config.patch_only;
    let start = Instant::now();
    let mut machine = Machine::probe();
    let mut progress = Progress {
        enabled: config.progress,
        unavailable: Vec::new(),
        notes: Vec::new(),
    };
    progress.line(&format!(
        "hyperpbd-report ({}): {}",
        if config.quick { "quick" } else { "full" },
        machine.footer()
    ));
    for &backend in &config.backends {
        let missing = match backend {
            BackendKind::Cpu | BackendKind::Auto => None,
            BackendKind::Gpu(Precision::F32) => machine.gpu_f32.as_ref().err(),
            BackendKind::Gpu(Precision::F64) => machine.gpu_f64.as_ref().err(),
        };
        if let Some(why) = missing {
            progress.note(&format!("SKIPPED {}: no adapter ({why})", backend.name()));
            progress.unavailable.push((backend, why.clone()));
        }
    }

    let mut results = Vec::new();
    if config.sweep && others {
        for &case in &config.cases {
            results.push(sweep::run_case(case, config, &mut progress).map_err(AccuracyError::Run)?);
        }
    }
    let mut headlines = Vec::new();
    for r in &results {
        for &backend in &config.backends {
            if !r.points.iter().any(|p| p.backend == backend) {
                continue;
            }
            let pick = |p: &point::Point| {
                (
                    p.substeps,
                    p.iterations,
                    p.ms_per_sim_second,
                    p.error.unwrap_or(f64::NAN),
                )
            };
            headlines.push(Headline {
                case: r.case,
                backend,
                target: config.target,
                reached: pareto::cheapest(&r.points, backend, config.target).map(pick),
                best: pareto::most_accurate(&r.points, backend).map(pick),
            });
        }
    }
    let (scaling_points, fits) = if config.scaling && others {
        scaling::run(config, &mut progress)
    } else {
        (Vec::new(), Vec::new())
    };
    let effect_rows = if (config.effects && others) || config.effects_only {
        effects::run(config, &mut progress).map_err(AccuracyError::Run)?
    } else {
        Vec::new()
    };
    let implicit = ((config.implicit && others) || config.implicit_only)
        .then(|| implicit_budgets::run(config, &mut progress));
    let patch = ((config.patch && others) || config.patch_only)
        .then(|| patch_study::run(config, &mut progress));
    machine.load_end = machine::load_average();
    let mut report = Report {
        mode: if config.quick { "quick" } else { "full" }.into(),
        reps: config.reps,
        machine,
        target: config.target,
        cases: results,
        headlines,
        scaling: scaling_points,
        fits,
        effects_n: config.effects_n,
        effects_balls: config.effects_balls,
        effects_ball_steps: config.effects_ball_steps,
        effect_reps: effects::reps(config),
        effects: effect_rows,
        implicit,
        patch,
        notices: progress.notes,
        files: Vec::new(),
        wall_seconds: 0.0,
    };
    report.wall_seconds = start.elapsed().as_secs_f64();
    write::write(&mut report, config)?;
    if config.progress {
        eprintln!("done in {:.1} s", report.wall_seconds);
    }
    Ok(report)
}
