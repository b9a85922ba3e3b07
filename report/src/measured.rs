//! Everything a run measured: the [`Report`] every file is written from,
//! its headline answers, and why a run can fail.

use crate::cases::CaseId;
use crate::effects::EffectRow;
use crate::implicit_budgets::ImplicitSection;
use crate::machine::Machine;
use crate::patch_study::PatchSection;
use crate::scaling::{Fit, ScalingPoint};
use crate::sweep::CaseResult;
use hyperpbd::BackendKind;
use serde::Serialize;

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
    pub cases: Vec<CaseResult>,
    /// Cheapest configurations reaching ε, per case and backend.
    pub headlines: Vec<Headline>,
    /// Scaling points.
    pub scaling: Vec<ScalingPoint>,
    /// Fitted exponents.
    pub fits: Vec<Fit>,
    /// Cloth side of the effect table.
    pub effects_n: usize,
    /// Balls of the collision / barrier rows (column3d side, height).
    pub effects_balls: (usize, usize),
    /// Fewest steps per timing rep of the ball rows.
    pub effects_ball_steps: u64,
    /// Reps of the effect table.
    pub effect_reps: usize,
    /// The effect-cost table.
    pub effects: Vec<EffectRow>,
    /// The implicit path against its Newton and CG budgets (None when not
    /// run).
    pub implicit: Option<ImplicitSection>,
    /// The patch test: equilibrium error against time per method (None
    /// when not run).
    pub patch: Option<PatchSection>,
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
