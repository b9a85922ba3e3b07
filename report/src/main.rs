//! `hyperpbd-report`: the accuracy/effects report (see the library docs).
//!
//! ```text
//! cargo run --release -p hyperpbd-report -- --quick        smoke test → target/accuracy/
//! scripts/accuracy.sh [--only-effects | --only-implicit | --only-patch]
//!                                                          docs/ and README.md
//! ```
//! Exit codes as the `hyperpbd` command: 2 bad options, 3 a failed run,
//! 4 an output that could not be written.

use clap::Parser;
use hyperpbd_report::{AccuracyError, BackendKind, CaseId, Config, cases, headlines};
use std::path::PathBuf;
use std::process::ExitCode;

/// What accuracy costs in time: error against wall time per backend,
/// substeps and iterations; scaling; effect costs. Writes a markdown
/// report with PNG figures.
#[derive(Debug, Parser)]
#[command(name = "hyperpbd-report", version, about)]
pub struct AccuracyArgs {
    /// CPU threads of the f64 golden path (default: HYPERPBD_THREADS, else
    /// every core); results are bit-identical for any count.
    #[arg(long, value_name = "N")]
    threads: Option<std::num::NonZeroUsize>,
    /// Smoke-test mode: fewer points, smaller scenes, one rep (under two
    /// minutes on a 2-core machine).
    #[arg(long)]
    quick: bool,
    /// Output directory: writes DIR/accuracy.md and DIR/figures/*.png, *.json.
    #[arg(long, default_value = "target/accuracy")]
    out: PathBuf,
    /// Also replace the generated "What accuracy costs" section of this
    /// README (between its accuracy markers; appended if absent).
    #[arg(long)]
    readme: Option<PathBuf>,
    /// Repetitions per timing (median reported); default 3, 1 with --quick.
    #[arg(long)]
    reps: Option<usize>,
    /// Comma-separated cases of the sweep (pendulum, free_fall, incline,
    /// damping, cloth, tesseract, chain2d, stretch); default all.
    #[arg(long, value_delimiter = ',')]
    cases: Option<Vec<String>>,
    /// Comma-separated backends (cpu-f64, gpu-f32, gpu-f64); default all.
    #[arg(long, value_delimiter = ',')]
    backends: Option<Vec<String>>,
    /// Comma-separated substep counts to sweep (overrides the mode's list).
    #[arg(long, value_delimiter = ',')]
    substeps: Option<Vec<u32>>,
    /// Comma-separated iteration counts to sweep (overrides the mode's list).
    #[arg(long, value_delimiter = ',')]
    iterations: Option<Vec<u32>>,
    /// Skip the scaling section.
    #[arg(long)]
    no_scaling: bool,
    /// Skip the effect-cost section.
    #[arg(long)]
    no_effects: bool,
    /// Measure only the effect-cost tables: writes DIR/effects.md,
    /// DIR/figures/effects.json and (with --readme) the README's effect
    /// lines; DIR/accuracy.md and the other figures are left as they are.
    #[arg(long, conflicts_with_all = ["no_effects", "no_scaling", "cases", "substeps", "iterations"])]
    only_effects: bool,
    /// Skip the implicit rows (error against the Newton and CG budgets).
    #[arg(long)]
    no_implicit: bool,
    /// Measure only the implicit rows: writes DIR/figures/implicit.json and
    /// splices their section into DIR/accuracy.md (and, with --readme,
    /// their lines into the README); everything else is left as it is.
    #[arg(long, conflicts_with_all = ["only_effects", "no_implicit", "no_effects", "no_scaling", "cases", "substeps", "iterations", "backends"])]
    only_implicit: bool,
    /// Skip the patch test (error against time of standard XPBD, XPBD
    /// with the primal residual and the implicit path).
    #[arg(long)]
    no_patch: bool,
    /// Measure only the patch test: writes DIR/figures/patch.json and
    /// DIR/figures/accuracy_patch.png and splices its section into
    /// DIR/accuracy.md; everything else (the README included) is left as
    /// it is.
    #[arg(long, conflicts_with_all = ["only_effects", "only_implicit", "no_patch", "no_implicit", "no_effects", "no_scaling", "cases", "substeps", "iterations", "backends"])]
    only_patch: bool,
}

fn accuracy(args: &AccuracyArgs) -> Result<(), AccuracyError> {
    if args.threads.is_some() {
        hyperpbd::set_default_threads(args.threads);
    }
    let mut config = if args.quick {
        Config::quick(&args.out)
    } else {
        Config::full(&args.out)
    };
    config.readme = args.readme.clone();
    if let Some(reps) = args.reps {
        if reps == 0 {
            return Err(AccuracyError::Config("--reps: must be at least 1".into()));
        }
        config.reps = reps;
    }
    if let Some(names) = &args.cases {
        config.cases = names
            .iter()
            .map(|n| {
                CaseId::parse(n).ok_or_else(|| {
                    let all: Vec<&str> = cases::ALL.iter().map(|c| c.name()).collect();
                    AccuracyError::Config(format!(
                        "--cases: unknown case {n:?}; cases: {}",
                        all.join(", ")
                    ))
                })
            })
            .collect::<Result<_, _>>()?;
    }
    if let Some(names) = &args.backends {
        config.backends = names
            .iter()
            .map(|n| {
                BackendKind::ALL
                    .into_iter()
                    .find(|b| b.name() == n)
                    .ok_or_else(|| {
                        AccuracyError::Config(format!(
                            "--backends: unknown backend {n:?}; backends: cpu-f64, gpu-f32, gpu-f64"
                        ))
                    })
            })
            .collect::<Result<_, _>>()?;
    }
    if let Some(s) = &args.substeps {
        config.substeps = s.clone();
        config.substep_caps.clear();
    }
    if let Some(i) = &args.iterations {
        config.iterations = i.clone();
    }
    config.scaling = !args.no_scaling;
    config.effects = !args.no_effects;
    config.effects_only = args.only_effects;
    config.implicit = !args.no_implicit;
    config.implicit_only = args.only_implicit;
    config.patch = !args.no_patch;
    config.patch_only = args.only_patch;
    if let Some(readme) = &config.readme
        && !readme.is_file()
    {
        return Err(AccuracyError::Config(format!(
            "--readme: {} is not a file",
            readme.display()
        )));
    }
    let report = hyperpbd_report::run(&config)?;
    println!("{}", headlines::summary(&report));
    for f in &report.files {
        println!("wrote {}", config.out.join(f).display());
    }
    Ok(())
}

fn main() -> ExitCode {
    match accuracy(&AccuracyArgs::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(match e {
                AccuracyError::Config(_) => 2,
                AccuracyError::Output(_) => 4,
                _ => 3,
            })
        }
    }
}
