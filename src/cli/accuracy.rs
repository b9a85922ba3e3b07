//! `hyperpbd accuracy`: the accuracy/cost report (see `hyperpbd::accuracy`).

use super::CliError;
use hyperpbd::accuracy::{self, BackendKind, CaseId, Config};
use std::path::PathBuf;

/// Options of `hyperpbd accuracy`.
#[derive(Debug, clap::Args)]
pub struct AccuracyArgs {
    #[command(flatten)]
    threads: super::threads::ThreadsArg,
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
    /// damping, cloth, tesseract, chain2d); default all.
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
}

pub fn accuracy(args: &AccuracyArgs) -> Result<(), CliError> {
    args.threads.apply();
    let mut config = if args.quick {
        Config::quick(&args.out)
    } else {
        Config::full(&args.out)
    };
    config.readme = args.readme.clone();
    if let Some(reps) = args.reps {
        if reps == 0 {
            return Err(CliError::Input("--reps: must be at least 1".into()));
        }
        config.reps = reps;
    }
    if let Some(names) = &args.cases {
        config.cases = names
            .iter()
            .map(|n| {
                CaseId::parse(n).ok_or_else(|| {
                    let all: Vec<&str> = accuracy::cases::ALL.iter().map(|c| c.name()).collect();
                    CliError::Input(format!(
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
                BackendKind::parse(n).ok_or_else(|| {
                    CliError::Input(format!(
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
    if let Some(readme) = &config.readme
        && !readme.is_file()
    {
        return Err(CliError::Input(format!(
            "--readme: {} is not a file",
            readme.display()
        )));
    }
    let report = accuracy::run(&config).map_err(|e| match e {
        accuracy::AccuracyError::Config(m) => CliError::Input(m),
        accuracy::AccuracyError::Output(m) => CliError::Output(m),
        other => CliError::Simulation(other.to_string()),
    })?;
    println!("{}", accuracy::report::summary(&report));
    for f in &report.files {
        println!("wrote {}", config.out.join(f).display());
    }
    Ok(())
}
