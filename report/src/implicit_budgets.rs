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
//! point     (backend, case, Newton budget, CG budget): `step()` alone
//!           timed, reps from the same initial state, median (timing.rs)
//!           ms / sim s = median Σ step time / (frames · dt) · 1000
//!           Newton mean = Σ MinimisationReport::iterations / minimisations
//!           CG mean     = Σ cg_iterations / Σ Newton directions
//!           ends        = counts of Converged, BudgetExhausted, RoundingFloor
//!                         (a refused step stops the run: the point keeps
//!                         why, and no error)
//!           same state  GPU points: the end state's hash against cpu-f64's
//!                         at the same budgets (bit-identical or not)
//! backends  cpu-f64 over newton_budgets × cg_budgets; each configured GPU
//!           backend with an adapter over gpu_newton_budgets ×
//!           gpu_cg_budgets (a subset: on lavapipe a GPU point costs
//!           10²–10³ CPU points), or its load refusal when it refuses the
//!           step (the incline is asked first)
//! frontier  per case, over every backend's points: pareto::undominated on
//!           (ms / sim s, error)
//! ```

use crate::config::Config;
use crate::implicit_cases::link_residual;
pub use crate::implicit_cases::{CASES, ImplicitCase};
use crate::pareto::undominated;
use crate::progress::Progress;
use crate::timing::{load, median};
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

/// One (backend, case, Newton budget, CG budget) point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ImplicitPoint {
    /// The backend's name (`cpu-f64`, `gpu-f32`, `gpu-f64`).
    pub backend: &'static str,
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
    /// GPU points: whether the end state is cpu-f64's at the same budgets,
    /// bit for bit (None for cpu-f64 itself, or without that CPU point).
    pub same_state_as_cpu: Option<bool>,
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
    /// cpu-f64's points, then each GPU backend's, each Newton budget ×
    /// CG budget, Newton-major.
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
    /// Newton budgets swept on the GPU backends.
    pub gpu_newton_budgets: Vec<u32>,
    /// CG budgets swept on the GPU backends.
    pub gpu_cg_budgets: Vec<Option<u32>>,
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

/// Measures one point on `backend`: one untimed warm-up step, then `reps`
/// timed runs from the initial state (the first also observed); a run
/// longer than `long_run` seconds is not repeated.
pub fn measure(
    backend: BackendKind,
    case: ImplicitCase,
    (newton, cg): (u32, Option<u32>),
    reps: usize,
    long_run: f64,
) -> Result<(ImplicitPoint, State), String> {
    let scene = case.scene(newton, cg);
    let initial = State::from_scene(&scene);
    let plan = Plan::compile(&scene).map_err(|e| e.to_string())?;
    let mut b = load(backend, plan, &initial)?;
    let mut point = ImplicitPoint {
        backend: backend.name(),
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
        same_state_as_cpu: None,
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

/// What loading the incline scene on each configured GPU backend says,
/// and the backends that run the step; backends without an adapter are
/// not asked.
pub fn gpu_backends(
    config: &Config,
    progress: &Progress,
) -> (Vec<(BackendKind, String)>, Vec<BackendKind>) {
    let scene = ImplicitCase::Incline.scene(1, None);
    let state = State::from_scene(&scene);
    let mut said = Vec::new();
    let mut running = Vec::new();
    for &b in config
        .backends
        .iter()
        .filter(|b| matches!(b, BackendKind::Gpu(_)))
        .filter(|&&b| progress.available(b))
    {
        let Ok(plan) = Plan::compile(&scene) else {
            continue;
        };
        match load(b, plan, &state) {
            Err(e) => said.push((b, format!("refused: {e}"))),
            Ok(_) => {
                said.push((b, "runs the coupled step: swept below".into()));
                running.push(b);
            }
        }
    }
    (said, running)
}

/// One backend's points of `case` over `budgets`, each printed as it ends.
fn sweep(
    backend: BackendKind,
    case: ImplicitCase,
    budgets: &[(u32, Option<u32>)],
    config: &Config,
    progress: &mut Progress,
) -> Vec<(ImplicitPoint, State)> {
    let mut points = Vec::new();
    for &(newton, cg) in budgets {
        match measure(backend, case, (newton, cg), config.reps, config.long_run) {
            Ok((p, end)) => {
                progress.line(&format!(
                    "implicit {:<7} {:<8} newton {:>3} cg {:>4} {:>10.2} ms/sim-s  error {}  newton {:.1} cg {:.1}",
                    backend.name(),
                    case.name(),
                    newton,
                    cg.map_or("none".into(), |c| c.to_string()),
                    p.ms_per_sim_second,
                    p.error.map_or_else(|| p.note.clone().unwrap_or_default(), |e| format!("{e:.3e}")),
                    p.budgets.newton_mean,
                    p.budgets.cg_mean,
                ));
                points.push((p, end));
            }
            Err(e) => progress.note(&format!(
                "implicit {} {} newton {newton} cg {cg:?}: SKIPPED: {e}",
                backend.name(),
                case.name()
            )),
        }
    }
    points
}

/// Newton-major (Newton budget, CG budget) pairs.
fn grid(newton: &[u32], cg: &[Option<u32>]) -> Vec<(u32, Option<u32>)> {
    newton
        .iter()
        .flat_map(|&n| cg.iter().map(move |&c| (n, c)))
        .collect()
}

/// The section: every case × Newton budget × CG budget on cpu-f64, and
/// the GPU grid on every GPU backend that runs the step.
pub fn run(config: &Config, progress: &mut Progress) -> ImplicitSection {
    let start = Instant::now();
    let load_start = crate::machine::load_average();
    let (gpu, running) = gpu_backends(config, progress);
    let cpu_grid = grid(&config.newton_budgets, &config.cg_budgets);
    let gpu_grid = grid(&config.gpu_newton_budgets, &config.gpu_cg_budgets);
    let mut cases = Vec::new();
    for case in CASES {
        let cpu = sweep(BackendKind::Cpu, case, &cpu_grid, config, progress);
        let mut points: Vec<ImplicitPoint> = cpu.iter().map(|(p, _)| p.clone()).collect();
        for &b in &running {
            for (mut p, end) in sweep(b, case, &gpu_grid, config, progress) {
                p.same_state_as_cpu = cpu
                    .iter()
                    .find(|(c, _)| (c.newton_budget, c.cg_budget) == (p.newton_budget, p.cg_budget))
                    .filter(|(c, _)| c.note.is_none() && p.note.is_none())
                    .map(|(_, cpu_end)| cpu_end.hash() == end.hash());
                points.push(p);
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
        gpu_newton_budgets: config.gpu_newton_budgets.clone(),
        gpu_cg_budgets: config.gpu_cg_budgets.clone(),
        reps: config.reps,
        cases,
        gpu,
        load: (load_start, crate::machine::load_average()),
        wall_seconds: start.elapsed().as_secs_f64(),
    }
}
