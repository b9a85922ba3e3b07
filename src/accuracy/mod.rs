//! `hyperpbd accuracy`: what accuracy costs in time.
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
//! output    OUT/accuracy.md, OUT/effects.md, OUT/figures/{accuracy_pareto,
//!           accuracy_cloth,scaling}.png, OUT/figures/{accuracy,effects}.json;
//!           optionally the README section between the accuracy markers
//!           (effects-only runs: effects.md, effects.json and the README's
//!           effect lines only)                                      report.rs
//! ```
//! Timing (timing.rs): only `Backend::step` is timed; every point is run
//! `reps` times from the same initial state and the median is reported.
//! GPU points are skipped with a printed notice when there is no adapter.

pub mod cases;
pub mod effects;
pub mod granular_effects;
pub mod machine;
pub mod pareto;
pub mod plot;
pub mod report;
pub mod scaling;
pub mod sweep;
pub mod timing;

pub use cases::CaseId;
pub use machine::Machine;
pub use timing::BackendKind;

use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// What to measure and where to write it.
#[derive(Debug, Clone)]
pub struct Config {
    /// Quick mode (smoke test): fewer points, smaller sizes, one rep.
    pub quick: bool,
    /// Output directory: `accuracy.md` and `figures/` go here.
    pub out: PathBuf,
    /// README whose section between the accuracy markers is replaced.
    pub readme: Option<PathBuf>,
    /// Repetitions per timing (the median is reported).
    pub reps: usize,
    /// A sweep point whose first rep takes longer than this (seconds) is
    /// not repeated.
    pub long_run: f64,
    /// Cases of the sweep.
    pub cases: Vec<CaseId>,
    /// Backends to measure.
    pub backends: Vec<BackendKind>,
    /// Substeps swept.
    pub substeps: Vec<u32>,
    /// Largest substep count swept per case (cases not listed: no cap).
    pub substep_caps: Vec<(CaseId, u32)>,
    /// Iterations swept (cases with coupled constraints only).
    pub iterations: Vec<u32>,
    /// Points with substeps × iterations above this are not run.
    pub work_cap: u32,
    /// Cases swept at one iteration only (their GPU points are slow).
    pub single_iteration: Vec<CaseId>,
    /// Side of the sweep's hanging cloth.
    pub cloth_n: usize,
    /// Reference substeps = factor × the finest swept substeps.
    pub reference_factor: u32,
    /// The error the headline asks for ("to reach 1e-3 …").
    pub target: f64,
    /// Cloth sides of the scaling figure.
    pub scaling_sizes: Vec<usize>,
    /// Largest cloth side the CPU runs in the scaling figure.
    pub cpu_scaling_max: usize,
    /// Cloth side of the effect-cost table.
    pub effects_n: usize,
    /// Balls of the collision / barrier rows: `scenes::column3d(side,
    /// height)`.
    pub effects_balls: (usize, usize),
    /// Fewest steps per timing rep of the ball rows (all ball rows on one
    /// backend run the same steps from the same start).
    pub effects_ball_steps: u64,
    /// Measure only the effect tables and write only OUT/effects.md,
    /// OUT/figures/effects.json and the README's effect lines (accuracy.md
    /// and the other figures are left as they are).
    pub effects_only: bool,
    /// Seconds one timing rep should last (scaling and effects).
    pub time_target: f64,
    /// Run the sweep.
    pub sweep: bool,
    /// Run the scaling section.
    pub scaling: bool,
    /// Run the effect-cost section.
    pub effects: bool,
    /// Print progress to stderr.
    pub progress: bool,
}

impl Config {
    /// The full report: every case, 3 reps, cloth up to 1024².
    pub fn full(out: impl Into<PathBuf>) -> Config {
        Config {
            quick: false,
            out: out.into(),
            readme: None,
            reps: 3,
            long_run: 10.0,
            cases: cases::ALL.to_vec(),
            backends: timing::BACKENDS.to_vec(),
            substeps: vec![1, 2, 4, 8, 16, 32, 64, 128, 256, 512],
            substep_caps: vec![
                (CaseId::Pendulum, 128),
                (CaseId::FreeFall, 128),
                (CaseId::Incline, 128),
                (CaseId::Damping, 128),
                (CaseId::Tesseract, 64),
                (CaseId::Chain2d, 256),
            ],
            iterations: vec![1, 2, 4, 8],
            work_cap: 256,
            single_iteration: vec![CaseId::Tesseract],
            cloth_n: 16,
            reference_factor: 16,
            target: 1e-3,
            scaling_sizes: vec![32, 64, 128, 256, 512, 1024],
            cpu_scaling_max: 1024,
            effects_n: 64,
            effects_balls: (6, 12),
            effects_ball_steps: 60,
            effects_only: false,
            time_target: 0.25,
            sweep: true,
            scaling: true,
            effects: true,
            progress: true,
        }
    }

    /// The smoke test: the same sections, small (under two minutes on a
    /// 2-core machine with lavapipe).
    pub fn quick(out: impl Into<PathBuf>) -> Config {
        Config {
            quick: true,
            reps: 1,
            // The tesseract's GPU points alone would take minutes.
            cases: cases::ALL
                .into_iter()
                .filter(|&c| c != CaseId::Tesseract)
                .collect(),
            substeps: vec![1, 4, 16, 64],
            substep_caps: Vec::new(),
            iterations: vec![1, 4],
            work_cap: 64,
            cloth_n: 10,
            scaling_sizes: vec![32, 64, 128],
            cpu_scaling_max: 128,
            effects_n: 32,
            effects_balls: (4, 6),
            effects_ball_steps: 20,
            time_target: 0.05,
            ..Config::full(out)
        }
    }
}

impl Config {
    /// The substep counts swept for `case` (capped per case).
    pub fn substeps_for(&self, case: CaseId) -> Vec<u32> {
        let cap = self
            .substep_caps
            .iter()
            .find(|(c, _)| *c == case)
            .map_or(u32::MAX, |(_, m)| *m);
        self.substeps
            .iter()
            .copied()
            .filter(|&s| s <= cap)
            .collect()
    }

    /// The (substeps, iterations) points swept for `case`: every pair with
    /// substeps × iterations ≤ `work_cap` (iterations only where they
    /// matter).
    pub fn grid_for(&self, case: CaseId) -> Vec<(u32, u32)> {
        let iterations: Vec<u32> =
            if case.uses_iterations() && !self.single_iteration.contains(&case) {
                self.iterations.clone()
            } else {
                vec![1]
            };
        let mut grid = Vec::new();
        for s in self.substeps_for(case) {
            for &i in &iterations {
                if u64::from(s) * u64::from(i) <= u64::from(self.work_cap.max(1)) || i == 1 {
                    grid.push((s, i));
                }
            }
        }
        grid
    }
}

/// Progress lines and the notices that go into the report.
#[derive(Debug)]
pub struct Progress {
    enabled: bool,
    unavailable: Vec<(BackendKind, String)>,
    /// Notices (skips, references) in order.
    pub notes: Vec<String>,
}

impl Progress {
    /// Whether `backend` can run here.
    pub fn available(&self, backend: BackendKind) -> bool {
        !self.unavailable.iter().any(|(b, _)| *b == backend)
    }

    /// A notice: printed and kept for the report.
    pub fn note(&mut self, text: &str) {
        if self.enabled {
            eprintln!("notice: {text}");
        }
        self.notes.push(text.to_string());
    }

    /// A progress line (printed only).
    pub fn line(&self, text: &str) {
        if self.enabled {
            eprintln!("{text}");
        }
    }

    /// A finished sweep point.
    pub fn point(&self, p: &sweep::Point) {
        self.line(&format!(
            "{:<10} {:>8} s{:<3} i{:<2} {:>10.2} ms/sim-s  error {}",
            p.case.name(),
            p.backend.name(),
            p.substeps,
            p.iterations,
            p.ms_per_sim_second,
            match (p.error, &p.note) {
                (Some(e), _) => format!("{e:.3e}"),
                (None, Some(n)) => n.clone(),
                (None, None) => "-".into(),
            }
        ));
    }
}

/// "Backend B needs T ms per simulated second to reach ε on case C".
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Headline {
    /// The case.
    pub case: CaseId,
    /// The backend.
    pub backend: BackendKind,
    /// ε.
    pub target: f64,
    /// The cheapest point reaching ε: (substeps, iterations, ms per
    /// simulated second, error).
    pub reached: Option<(u32, u32, f64, f64)>,
    /// The most accurate point when ε was not reached: (substeps,
    /// iterations, ms per simulated second, error).
    pub best: Option<(u32, u32, f64, f64)>,
}

/// Everything a run measured.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// `quick` or `full`.
    pub mode: String,
    /// Reps per timing.
    pub reps: usize,
    /// Where it ran.
    pub machine: Machine,
    /// The headline ε.
    pub target: f64,
    /// Sweep results per case.
    pub cases: Vec<sweep::CaseResult>,
    /// Cheapest configurations reaching ε, per case and backend.
    pub headlines: Vec<Headline>,
    /// Scaling points.
    pub scaling: Vec<scaling::ScalingPoint>,
    /// Fitted exponents.
    pub fits: Vec<scaling::Fit>,
    /// Cloth side of the effect table.
    pub effects_n: usize,
    /// Balls of the collision / barrier rows (column3d side, height).
    pub effects_balls: (usize, usize),
    /// Fewest steps per timing rep of the ball rows.
    pub effects_ball_steps: u64,
    /// Reps of the effect table.
    pub effect_reps: usize,
    /// The effect-cost table.
    pub effects: Vec<effects::EffectRow>,
    /// Skips and other notices.
    pub notices: Vec<String>,
    /// Files written, relative to the output directory.
    pub files: Vec<String>,
    /// Wall seconds of the whole run.
    pub wall_seconds: f64,
}

/// Why a run failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum AccuracyError {
    /// A bad option.
    #[error("{0}")]
    Config(String),
    /// A reference scene or backend failed.
    #[error("{0}")]
    Run(String),
    /// Writing files failed.
    #[error("{0}")]
    Output(String),
}

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
    let start = Instant::now();
    let mut machine = Machine::probe();
    let mut progress = Progress {
        enabled: config.progress,
        unavailable: Vec::new(),
        notes: Vec::new(),
    };
    progress.line(&format!(
        "hyperpbd accuracy ({}): {}",
        if config.quick { "quick" } else { "full" },
        machine.footer()
    ));
    for &backend in &config.backends {
        let missing = match backend {
            BackendKind::CpuF64 => None,
            BackendKind::GpuF32 => machine.gpu_f32.as_ref().err(),
            BackendKind::GpuF64 => machine.gpu_f64.as_ref().err(),
        };
        if let Some(why) = missing {
            progress.note(&format!("SKIPPED {}: no adapter ({why})", backend.name()));
            progress.unavailable.push((backend, why.clone()));
        }
    }

    let mut results = Vec::new();
    if config.sweep && !config.effects_only {
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
            let pick = |p: &sweep::Point| {
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
    let (scaling_points, fits) = if config.scaling && !config.effects_only {
        scaling::run(config, &mut progress)
    } else {
        (Vec::new(), Vec::new())
    };
    let effect_rows = if config.effects || config.effects_only {
        effects::run(config, &mut progress).map_err(AccuracyError::Run)?
    } else {
        Vec::new()
    };
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
        notices: progress.notes,
        files: Vec::new(),
        wall_seconds: 0.0,
    };
    report.wall_seconds = start.elapsed().as_secs_f64();
    report::write(&mut report, config)?;
    if config.progress {
        eprintln!("done in {:.1} s", report.wall_seconds);
    }
    Ok(report)
}
