//! The linear patch test (docs/equilibria.md): how far the interior of a
//! stressed patch is from its exact equilibrium after a fixed simulated
//! time, against wall time, for three ways of stepping it (issue 34,
//! item 4).
//!
//! ```text
//! case      builders::PatchSpec::stressed(dim, law): boundary nodes fixed on
//!           x = F X, interior free, E = 1e5 Pa, ν = 0.3, 0.05 kg per node,
//!           dt = 1/60 s; started from patch.state(false): the interior at
//!           rest on X, so it has to travel to F X (several mm)
//! error     max over interior nodes of |x_i − F X_i| after `patch_seconds`
//!           (1 s: 60 frames), F X being the exact equilibrium of every
//!           hyperelastic law on this mesh; also at half that time, so a
//!           reader sees whether the error is a transient still decaying or
//!           the method's fixed point
//! methods   xpbd             the standard update (damping 5/s)
//!           primal_residual  "solver": {"type": "xpbd", "primal_residual": true}
//!                            (damping 5/s)
//!           implicit         patch.use_implicit_path(): one Newton
//!                            minimisation per substep, stopped at an
//!                            acceleration residual of 1e-9 m/s² or at the
//!                            Newton budget (no damping: that path refuses it)
//! grids     XPBD: substeps × iterations (config.patch_substeps ×
//!           config.patch_iterations); implicit: config.patch_implicit_substeps
//!           × Newton budget (max_iterations, config.patch_newton_budgets)
//! time      cpu-f64 on one thread for every method (the primal update runs
//!           on the calling thread, so one thread compares like with like);
//!           timing::simulate: one untimed warm-up step, `reps` runs from the
//!           same state, only `step()` timed, median
//!           ms / sim s = median Σ step time / (frames · dt) · 1000
//! frontier  per case and method, and over all methods: pareto::undominated
//!           on (ms / sim s, error)
//! ```

use crate::config::Config;
use crate::pareto::undominated;
use crate::progress::Progress;
use crate::timing::{median, simulate};
use hyperpbd::builders::{Patch, PatchSpec};
use hyperpbd::{CpuBackend, Plan, Solver, XpbdSettings};
use serde::Serialize;
use std::time::Instant;

pub use crate::patch_cases::{PatchCase, PatchLaw};

/// How the patch is stepped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum PatchMethod {
    /// Standard XPBD.
    Xpbd,
    /// XPBD carrying the primal residual.
    PrimalResidual,
    /// The implicit (incremental-potential) path.
    Implicit,
}

impl PatchMethod {
    /// Every method, in table order.
    pub const ALL: [PatchMethod; 3] = [
        PatchMethod::Xpbd,
        PatchMethod::PrimalResidual,
        PatchMethod::Implicit,
    ];

    /// As written in tables and legends.
    pub fn name(self) -> &'static str {
        match self {
            PatchMethod::Xpbd => "xpbd",
            PatchMethod::PrimalResidual => "xpbd + primal_residual",
            PatchMethod::Implicit => "implicit",
        }
    }

    /// What the second budget number means.
    pub fn budget_name(self) -> &'static str {
        match self {
            PatchMethod::Xpbd | PatchMethod::PrimalResidual => "iterations",
            PatchMethod::Implicit => "Newton budget",
        }
    }
}

/// One (case, method, substeps, budget) point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PatchPoint {
    /// The method.
    pub method: PatchMethod,
    /// Substeps per frame.
    pub substeps: u32,
    /// XPBD iterations per substep, or the implicit path's Newton budget.
    pub budget: u32,
    /// Median wall ms per simulated second.
    pub ms_per_sim_second: f64,
    /// Fastest rep.
    pub ms_min: f64,
    /// Slowest rep.
    pub ms_max: f64,
    /// Reps run.
    pub reps: usize,
    /// max |x − F X| over the interior at the end (None when the run failed).
    pub error: Option<f64>,
    /// The same at half the simulated time.
    pub error_half: Option<f64>,
    /// On its method's frontier.
    pub frontier: bool,
    /// On the frontier over every method.
    pub overall_frontier: bool,
    /// Why the error is missing, or anything odd.
    pub note: Option<String>,
}

/// One case's points.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PatchResult {
    /// The case.
    pub case: PatchCase,
    /// "2D StVK".
    pub name: String,
    /// Nodes, interior nodes, elements.
    pub sizes: (usize, usize, usize),
    /// max |X − F X| over the interior: the error at the start.
    pub start_error: f64,
    /// Every method's points, method by method, substeps-major.
    pub points: Vec<PatchPoint>,
}

/// The section.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PatchSection {
    /// Simulated seconds per run.
    pub seconds: f64,
    /// The error the summary asks for.
    pub target: f64,
    /// XPBD substeps swept.
    pub substeps: Vec<u32>,
    /// XPBD iterations swept.
    pub iterations: Vec<u32>,
    /// Implicit substeps swept.
    pub implicit_substeps: Vec<u32>,
    /// Implicit Newton budgets swept.
    pub newton_budgets: Vec<u32>,
    /// Reps per point.
    pub reps: usize,
    /// The cases.
    pub cases: Vec<PatchResult>,
    /// 1-minute load average when the section started and ended.
    pub load: (Option<f64>, Option<f64>),
    /// Wall seconds of the section.
    pub wall_seconds: f64,
}

/// The patch of `case` stepped by `method` at (`substeps`, `budget`).
pub fn build(case: PatchCase, method: PatchMethod, substeps: u32, budget: u32) -> Patch {
    let spec = PatchSpec::stressed(case.dim, case.law.kind());
    let dt = 1.0 / 60.0;
    match method {
        PatchMethod::Xpbd => Patch::new(&spec, dt, substeps, budget),
        PatchMethod::PrimalResidual => {
            let mut patch = Patch::new(&spec, dt, substeps, budget);
            patch.scene.solver = Solver::Xpbd(XpbdSettings {
                primal_residual: true,
            });
            patch
        }
        PatchMethod::Implicit => {
            let mut patch = Patch::new(&spec, dt, substeps, 1);
            patch.use_implicit_path();
            if let Solver::IncrementalPotential(settings) = &mut patch.scene.solver {
                settings.max_iterations = budget;
            }
            patch
        }
    }
}

/// Measures one point (cpu-f64, one thread) over `frames` frames.
pub fn measure(
    case: PatchCase,
    method: PatchMethod,
    (substeps, budget): (u32, u32),
    frames: u64,
    config: &Config,
) -> PatchPoint {
    let mut point = PatchPoint {
        method,
        substeps,
        budget,
        ms_per_sim_second: f64::NAN,
        ms_min: f64::NAN,
        ms_max: f64::NAN,
        reps: 0,
        error: None,
        error_half: None,
        frontier: false,
        overall_frontier: false,
        note: None,
    };
    let patch = build(case, method, substeps, budget);
    let initial = patch.state(false);
    let loaded = Plan::compile(&patch.scene)
        .map_err(|e| e.to_string())
        .and_then(|plan| CpuBackend::with_threads(plan, &initial, 1).map_err(|e| e.to_string()));
    let mut cpu = match loaded {
        Ok(cpu) => cpu,
        Err(e) => {
            point.note = Some(format!("refused: {e}"));
            return point;
        }
    };
    let run = match simulate(
        &mut cpu,
        &initial,
        frames,
        config.reps,
        config.long_run,
        true,
    ) {
        Ok(run) => run,
        Err(e) => {
            point.note = Some(format!("step failed: {e}"));
            return point;
        }
    };
    let per_sim_second = |s: f64| s * 1000.0 / (frames as f64 * patch.scene.dt);
    let samples: Vec<f64> = run.samples.iter().map(|&s| per_sim_second(s)).collect();
    point.ms_per_sim_second = median(&samples);
    point.ms_min = samples.iter().copied().fold(f64::INFINITY, f64::min);
    point.ms_max = samples.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    point.reps = samples.len();
    let end = patch.interior_error(&run.final_state.positions);
    let half = run
        .trajectory
        .get(run.trajectory.len() / 2)
        .map(|s| patch.interior_error(&s.positions));
    if end.is_finite() {
        point.error = Some(end);
        point.error_half = half.filter(|e| e.is_finite());
    } else {
        point.note = Some("non-finite state".into());
    }
    if !run.reproducible {
        point.note = Some("reps ended in different states".into());
    }
    point
}

/// Marks each method's frontier and the frontier over every method.
pub fn mark_frontiers(points: &mut [PatchPoint]) {
    let candidates = |m: Option<PatchMethod>, points: &[PatchPoint]| -> Vec<usize> {
        undominated(
            points
                .iter()
                .enumerate()
                .filter(|(_, p)| m.is_none_or(|m| p.method == m))
                .map(|(i, p)| (i, p.ms_per_sim_second, p.error.unwrap_or(f64::NAN))),
        )
    };
    let overall = candidates(None, points);
    let mut own = Vec::new();
    for m in PatchMethod::ALL {
        own.extend(candidates(Some(m), points));
    }
    for (i, p) in points.iter_mut().enumerate() {
        p.frontier = own.contains(&i);
        p.overall_frontier = overall.contains(&i);
    }
}

/// The (substeps, budget) pairs of `method`, substeps-major.
pub fn grid(method: PatchMethod, config: &Config) -> Vec<(u32, u32)> {
    let (substeps, budgets) = match method {
        PatchMethod::Xpbd | PatchMethod::PrimalResidual => {
            (&config.patch_substeps, &config.patch_iterations)
        }
        PatchMethod::Implicit => (
            &config.patch_implicit_substeps,
            &config.patch_newton_budgets,
        ),
    };
    substeps
        .iter()
        .flat_map(|&s| budgets.iter().map(move |&b| (s, b)))
        .collect()
}

/// Every case × method × grid point, each printed as it ends.
pub fn run(config: &Config, progress: &mut Progress) -> PatchSection {
    let start = Instant::now();
    let load_start = crate::machine::load_average();
    let frames = (config.patch_seconds * 60.0).round().max(1.0) as u64;
    let mut cases = Vec::new();
    for &case in &config.patch_cases {
        let mut points = Vec::new();
        for method in PatchMethod::ALL {
            for at in grid(method, config) {
                let p = measure(case, method, at, frames, config);
                progress.line(&format!(
                    "patch {:<16} {:<22} s{:<3} {:<3} {:>10.2} ms/sim-s  error {}",
                    case.name(),
                    method.name(),
                    at.0,
                    at.1,
                    p.ms_per_sim_second,
                    p.error.map_or_else(
                        || p.note.clone().unwrap_or_default(),
                        |e| format!("{e:.3e}")
                    ),
                ));
                points.push(p);
            }
        }
        mark_frontiers(&mut points);
        let patch = build(case, PatchMethod::Xpbd, 1, 1);
        let interior = patch.boundary.iter().filter(|&&b| !b).count();
        let elements = patch
            .scene
            .constraints
            .iter()
            .map(|f| f.elements.len())
            .sum();
        cases.push(PatchResult {
            case,
            name: case.name(),
            sizes: (patch.boundary.len(), interior, elements),
            start_error: patch.interior_error(&patch.state(false).positions),
            points,
        });
    }
    PatchSection {
        seconds: frames as f64 / 60.0,
        target: config.patch_target,
        substeps: config.patch_substeps.clone(),
        iterations: config.patch_iterations.clone(),
        implicit_substeps: config.patch_implicit_substeps.clone(),
        newton_budgets: config.patch_newton_budgets.clone(),
        reps: config.reps,
        cases,
        load: (load_start, crate::machine::load_average()),
        wall_seconds: start.elapsed().as_secs_f64(),
    }
}
