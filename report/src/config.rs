//! What a run measures and where it writes: the full report, the quick
//! smoke test, and the sweep grid of each case.
//!
//! ```text
//! grid(case)  substeps s ≤ cap(case) × iterations i (only where several
//!             constraints couple), keeping s · i ≤ work_cap (i = 1 always)
//! ```

use crate::cases::{self, CaseId};
use crate::patch_cases::{PatchCase, PatchLaw};
use hyperpbd::BackendKind;
use std::path::PathBuf;

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
    /// Newton budgets (`max_iterations`) of the implicit rows.
    pub newton_budgets: Vec<u32>,
    /// CG budgets (`cg_iterations`, None: the default) of the implicit rows.
    pub cg_budgets: Vec<Option<u32>>,
    /// Newton budgets of the implicit rows on the GPU backends (a subset:
    /// on lavapipe a GPU point costs 10²–10³ CPU points, docs/performance.md).
    pub gpu_newton_budgets: Vec<u32>,
    /// CG budgets of the implicit rows on the GPU backends.
    pub gpu_cg_budgets: Vec<Option<u32>>,
    /// Run the implicit rows (implicit_budgets.rs).
    pub implicit: bool,
    /// Measure only the implicit rows: writes OUT/figures/implicit.json,
    /// splices their section into OUT/accuracy.md and (with a README) their
    /// lines into the README; everything else is left as it is.
    pub implicit_only: bool,
    /// Stressed patches of the patch study (patch_study.rs).
    pub patch_cases: Vec<PatchCase>,
    /// Simulated seconds of each patch run (from the interior at rest on X).
    pub patch_seconds: f64,
    /// XPBD substeps of the patch study.
    pub patch_substeps: Vec<u32>,
    /// XPBD iterations of the patch study.
    pub patch_iterations: Vec<u32>,
    /// Implicit-path substeps of the patch study.
    pub patch_implicit_substeps: Vec<u32>,
    /// Implicit-path Newton budgets (`max_iterations`) of the patch study.
    pub patch_newton_budgets: Vec<u32>,
    /// The error the patch summary asks for (m).
    pub patch_target: f64,
    /// Run the patch study.
    pub patch: bool,
    /// Measure only the patch study: writes OUT/figures/patch.json and
    /// OUT/figures/accuracy_patch.png and splices its section into
    /// OUT/accuracy.md; everything else is left as it is.
    pub patch_only: bool,
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
            backends: BackendKind::ALL.to_vec(),
            substeps: vec![1, 2, 4, 8, 16, 32, 64, 128, 256, 512],
            substep_caps: vec![
                (CaseId::Pendulum, 128),
                (CaseId::FreeFall, 128),
                (CaseId::Incline, 128),
                (CaseId::Damping, 128),
                (CaseId::Tesseract, 64),
                (CaseId::Chain2d, 256),
                (CaseId::Stretch, 32),
            ],
            iterations: vec![1, 2, 4, 8],
            work_cap: 256,
            single_iteration: vec![CaseId::Tesseract, CaseId::Stretch],
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
            newton_budgets: vec![1, 2, 4, 8, 16, 32, 64],
            cg_budgets: vec![Some(2), Some(8), Some(32), None],
            gpu_newton_budgets: vec![1, 4, 16, 64],
            gpu_cg_budgets: vec![Some(8), None],
            implicit: true,
            implicit_only: false,
            patch_cases: vec![
                PatchCase {
                    dim: 2,
                    law: PatchLaw::Stvk,
                },
                PatchCase {
                    dim: 2,
                    law: PatchLaw::NeoHookean,
                },
                PatchCase {
                    dim: 3,
                    law: PatchLaw::Stvk,
                },
            ],
            patch_seconds: 1.0,
            patch_substeps: vec![1, 2, 5, 10, 20],
            patch_iterations: vec![1, 3, 10, 30],
            patch_implicit_substeps: vec![1, 2],
            patch_newton_budgets: vec![1, 2, 4, 8, 16, 50],
            patch_target: 1e-6,
            patch: true,
            patch_only: false,
            sweep: true,
            scaling: true,
            effects: true,
            progress: true,
        }
    }

    /// The smoke test: the same sections, small (under two minutes on a
    /// 2-core machine with lavapipe).
    pub fn quick(out: impl Into<PathBuf>) -> Config {
        let full = Config::full(out);
        Config {
            quick: true,
            reps: 1,
            // The tesseract's and the stretched bar's GPU points alone would
            // take minutes.
            cases: cases::ALL
                .into_iter()
                .filter(|&c| !matches!(c, CaseId::Tesseract | CaseId::Stretch))
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
            newton_budgets: vec![1, 4, 16],
            cg_budgets: vec![Some(2), None],
            gpu_newton_budgets: vec![1, 4],
            gpu_cg_budgets: vec![Some(2), None],
            // The full run's 2D cases.
            patch_cases: (full.patch_cases.iter().copied())
                .filter(|case| case.dim == 2)
                .collect(),
            patch_substeps: vec![1, 10],
            patch_iterations: vec![1, 10],
            patch_implicit_substeps: vec![1],
            patch_newton_budgets: vec![1, 16],
            ..full
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
