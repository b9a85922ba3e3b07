//! The implicit (incremental-potential, coupled Newton–PCG) path: error
//! against wall time against the Newton and CG budgets (issue 16, item 5).
//!
//! ```text
//! budgets   Newton: max_iterations (the minimisation's iterations per step)
//!           CG:     cg_iterations  (PCG iterations per Newton direction;
//!                   None = DEFAULT_CG_ITERATIONS = 200, more than the
//!                   24 coordinates of the chain: no budget in effect)
//! time      only the step's length h = dt = 1/60 s is fixed here, so every
//!           error below is the minimiser's, or (incline, first measure)
//!           backward Euler's plus the minimiser's
//! cases     implicit_cases.rs: incline (vs ½ a t² and backward Euler),
//!           the swinging 1:1e6 chain (link residual), the hanging chain
//!           (vs its static stretch α g Σ m)
//! point     (case, Newton budget, CG budget) on cpu-f64: `step()` alone
//!           timed, reps from the same initial state, median (timing.rs)
//!           ms / sim s = median Σ step time / (frames · dt) · 1000
//!           Newton mean = Σ MinimisationReport::iterations / minimisations
//!           CG mean     = Σ cg_iterations / Σ Newton directions
//!           ends        = counts of Converged, BudgetExhausted, RoundingFloor
//!                         (a refused step stops the run: the point keeps
//!                         why, and no error)
//! frontier  per case: pareto::undominated on (ms / sim s, error)
//! ```
//! The sweep runs on cpu-f64. gpu-f64 runs the same step bit for bit on
//! lavapipe (`GpuCoupledBackend`, tests/gpu_coupled.rs), so its errors are
//! the CPU's; gpu-f32 runs it with a per-step residual-driven bound against
//! the CPU (tests/gpu_coupled_f32.rs), not swept here either.
//! [`gpu_refusals`] asks each configured GPU backend to load the incline
//! and the report prints what it said.

use crate::config::Config;
use crate::implicit_cases::link_residual;
pub use crate::implicit_cases::{CASES, ImplicitCase};
use crate::pareto::undominated;
use crate::progress::Progress;
use crate::timing::{load, median};
use hyperpbd::gpu::Precision;
use hyperpbd::{BackendKind, MinimisationStatus, Plan, State};
use serde::Serialize;
use std::time::Instant;

/// How the minimisations of a run used their budgets and ended.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Budgets {
    /// Minimisations run (one per frame here).
    pub minimisations: usize,
    /// Mean Newton iterations per minimisation.
    pub newton_mean: f64,
    /// Most Newton iterations of one minimisation.
    pub newton_max: u32,
    /// Mean CG iterations per Newton direction.
    pub cg_mean: f64,
    /// Most CG iterations of one direction.
    pub cg_max: u32,
    /// Minimisations that met the criterion.
    pub converged: usize,
    /// Minimisations that ended at the Newton budget.
    pub budget_exhausted: usize,
    /// Minimisations that ended at the rounding floor.
    pub rounding_floor: usize,
}

impl Budgets {
    fn add(&mut self, report: &hyperpbd::MinimisationReport, sums: &mut (u64, u64, u64)) {
        self.minimisations += 1;
        sums.0 += u64::from(report.iterations);
        sums.1 += report
            .cg_iterations
            .iter()
            .map(|&c| u64::from(c))
            .sum::<u64>();
        sums.2 += report.cg_iterations.len() as u64;
        self.newton_max = self.newton_max.max(report.iterations);
        self.cg_max = self
            .cg_max
            .max(report.cg_iterations.iter().copied().max().unwrap_or(0));
        match report.status {
            MinimisationStatus::Converged => self.converged += 1,
            MinimisationStatus::BudgetExhausted => self.budget_exhausted += 1,
            MinimisationStatus::RoundingFloor => self.rounding_floor += 1,
            MinimisationStatus::Refused(_) => {}
        }
    }
}

/// One (case, Newton budget, CG budget) point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImplicitPoint {
    /// The case.
    pub case: ImplicitCase,
    /// `max_iterations`.
    pub newton_budget: u32,
    /// `cg_iterations` (None: the default, 200).
    pub cg_budget: Option<u32>,
    /// Median wall ms per simulated second.
    pub ms_per_sim_second: f64,
    /// Fastest rep.
    pub ms_min: f64,
    /// Slowest rep.
    pub ms_max: f64,
    /// Reps run.
    pub reps: usize,
    /// The case's error measure (None when the run failed).
    pub error: Option<f64>,
    /// The case's second measure.
    pub second: Option<f64>,
    /// What the minimisations used and how they ended (first rep).
    pub budgets: Budgets,
    /// On the case's frontier.
    pub frontier: bool,
    /// Why the error is missing, or anything odd.
    pub note: Option<String>,
}

/// Everything measured for one case.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImplicitResult {
    /// The case.
    pub case: ImplicitCase,
    /// Description with parameters.
    pub title: String,
    /// The error measure.
    pub metric: String,
    /// The second measure.
    pub second_metric: String,
    /// Simulated seconds.
    pub seconds: f64,
    /// Newton budget × CG budget, Newton-major.
    pub points: Vec<ImplicitPoint>,
}

/// The section: every case, and what each GPU backend said.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImplicitSection {
    /// Newton budgets swept.
    pub newton_budgets: Vec<u32>,
    /// CG budgets swept (None: the default).
    pub cg_budgets: Vec<Option<u32>>,
    /// Reps per point.
    pub reps: usize,
    /// The cases.
    pub cases: Vec<ImplicitResult>,
    /// (backend, what loading the incline scene on it said).
    pub gpu: Vec<(BackendKind, String)>,
    /// 1-minute load average when the section started and ended.
    pub load: (Option<f64>, Option<f64>),
    /// Wall seconds of the section.
    pub wall_seconds: f64,
}

/// What the first rep records: the budgets used, and a call per frame.
type Observer<'a> = (&'a mut Budgets, &'a mut dyn FnMut(&State));

/// One run of `frames` steps from `initial`, each `step()` timed alone;
/// `observe` sees the state after every step when `first`.
fn run_once(
    backend: &mut dyn hyperpbd::Backend,
    initial: &State,
    frames: u64,
    mut observe: Option<Observer<'_>>,
) -> Result<(f64, State), String> {
    backend.write_state(initial).map_err(|e| e.to_string())?;
    let mut elapsed = 0.0;
    let mut sums = (0, 0, 0);
    for frame in 1..=frames {
        let start = Instant::now();
        let report = backend.step();
        elapsed += start.elapsed().as_secs_f64();
        let report = report.map_err(|e| format!("frame {frame}: {e}"))?;
        if let Some((budgets, each)) = observe.as_mut() {
            for m in &report.minimisation {
                budgets.add(m, &mut sums);
            }
            each(&backend.read_state().map_err(|e| e.to_string())?);
        }
    }
    if let Some((budgets, _)) = observe {
        let n = budgets.minimisations.max(1) as f64;
        budgets.newton_mean = sums.0 as f64 / n;
        budgets.cg_mean = sums.1 as f64 / (sums.2.max(1) as f64);
    }
    let last = backend.read_state().map_err(|e| e.to_string())?;
    Ok((elapsed, last))
}

/// Measures one point on cpu-f64: one untimed warm-up step, then `reps`
/// timed runs from the initial state (the first also observed); a run
/// longer than `long_run` seconds is not repeated.
pub fn measure(
    case: ImplicitCase,
    (newton, cg): (u32, Option<u32>),
    reps: usize,
    long_run: f64,
) -> Result<(ImplicitPoint, State), String> {
    let scene = case.scene(newton, cg);
    let initial = State::from_scene(&scene);
    let plan = Plan::compile(&scene).map_err(|e| e.to_string())?;
    let mut b = load(BackendKind::Cpu, plan, &initial)?;
    let mut point = ImplicitPoint {
        case,
        newton_budget: newton,
        cg_budget: cg,
        ms_per_sim_second: f64::NAN,
        ms_min: f64::NAN,
        ms_max: f64::NAN,
        reps: 0,
        error: None,
        second: None,
        budgets: Budgets::default(),
        frontier: false,
        note: None,
    };
    if let Err(e) = b.step() {
        point.note = Some(format!("warm-up step failed: {e}"));
        return Ok((point, initial));
    }
    let mut worst: f64 = 0.0;
    let mut samples = Vec::new();
    let mut first: Option<State> = None;
    let mut reproducible = true;
    for rep in 0..reps.max(1) {
        let mut each = |s: &State| {
            if case != ImplicitCase::Incline {
                worst = worst.max(link_residual(s));
            }
        };
        let each: &mut dyn FnMut(&State) = &mut each;
        let observe = (rep == 0).then_some((&mut point.budgets, each));
        let (elapsed, last) = match run_once(b.as_mut(), &initial, case.frames(), observe) {
            Ok(run) => run,
            Err(e) => {
                point.note = Some(format!("step failed: {e}"));
                return Ok((point, initial));
            }
        };
        samples.push(elapsed * 1000.0 / (case.frames() as f64 * scene.dt));
        match &first {
            None => first = Some(last),
            Some(s) => reproducible &= s.hash() == last.hash(),
        }
        if elapsed > long_run {
            break;
        }
    }
    point.ms_per_sim_second = median(&samples);
    point.ms_min = samples.iter().copied().fold(f64::INFINITY, f64::min);
    point.ms_max = samples.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    point.reps = samples.len();
    let end = first.unwrap_or_else(|| unreachable!("at least one rep runs"));
    let (error, second) = case.measures(&scene, &end, worst);
    if end.positions.iter().all(|x| x.is_finite()) && second.is_finite() {
        point.error = error;
        point.second = Some(second);
    } else {
        point.note = Some("non-finite state".into());
    }
    if !reproducible {
        point.note = Some("reps ended in different states".into());
    }
    Ok((point, end))
}

/// Marks each case's frontier on (ms / sim s, error).
pub fn mark_frontier(points: &mut [ImplicitPoint]) {
    let kept = undominated(
        points
            .iter()
            .enumerate()
            .map(|(i, p)| (i, p.ms_per_sim_second, p.error.unwrap_or(f64::NAN))),
    );
    for (i, p) in points.iter_mut().enumerate() {
        p.frontier = kept.contains(&i);
    }
}

/// What loading the incline scene on each configured GPU backend says
/// (both precisions run the coupled step; a refusal is printed); backends without
/// an adapter are not asked.
pub fn gpu_refusals(config: &Config, progress: &Progress) -> Vec<(BackendKind, String)> {
    let scene = ImplicitCase::Incline.scene(1, None);
    let state = State::from_scene(&scene);
    config
        .backends
        .iter()
        .filter(|b| matches!(b, BackendKind::Gpu(_)))
        .filter(|&&b| progress.available(b))
        .filter_map(|&b| {
            let plan = Plan::compile(&scene).ok()?;
            Some(match load(b, plan, &state) {
                Err(e) => (b, format!("refused: {e}")),
                Ok(_) if b == BackendKind::Gpu(Precision::F32) => (
                    b,
                    "runs the coupled step in f32 (a per-step residual-driven bound against \
                     cpu-f64: tests/gpu_coupled_f32.rs), not swept here"
                        .into(),
                ),
                Ok(_) => (
                    b,
                    "runs the coupled step (bit-identical to cpu-f64 on lavapipe: \
                     tests/gpu_coupled.rs), not swept here"
                        .into(),
                ),
            })
        })
        .collect()
}

/// The section: every case × Newton budget × CG budget on cpu-f64.
pub fn run(config: &Config, progress: &mut Progress) -> ImplicitSection {
    let start = Instant::now();
    let load_start = crate::machine::load_average();
    let gpu = gpu_refusals(config, progress);
    let mut cases = Vec::new();
    for case in CASES {
        let mut points = Vec::new();
        for &newton in &config.newton_budgets {
            for &cg in &config.cg_budgets {
                match measure(case, (newton, cg), config.reps, config.long_run) {
                    Ok((p, _)) => {
                        progress.line(&format!(
                            "implicit {:<8} newton {:>3} cg {:>4} {:>10.2} ms/sim-s  error {}  newton {:.1} cg {:.1}",
                            case.name(),
                            newton,
                            cg.map_or("none".into(), |c| c.to_string()),
                            p.ms_per_sim_second,
                            p.error.map_or_else(|| p.note.clone().unwrap_or_default(), |e| format!("{e:.3e}")),
                            p.budgets.newton_mean,
                            p.budgets.cg_mean,
                        ));
                        points.push(p);
                    }
                    Err(e) => progress.note(&format!(
                        "implicit {} newton {newton} cg {cg:?}: SKIPPED: {e}",
                        case.name()
                    )),
                }
            }
        }
        mark_frontier(&mut points);
        cases.push(ImplicitResult {
            case,
            title: case.title().into(),
            metric: case.metric().into(),
            second_metric: case.second_metric().into(),
            seconds: case.frames() as f64 * case.scene(1, None).dt,
            points,
        });
    }
    ImplicitSection {
        newton_budgets: config.newton_budgets.clone(),
        cg_budgets: config.cg_budgets.clone(),
        reps: config.reps,
        cases,
        gpu,
        load: (load_start, crate::machine::load_average()),
        wall_seconds: start.elapsed().as_secs_f64(),
    }
}
