//! The accuracy sweep: case × backend × substeps × iterations.
//!
//! ```text
//! point     the case's scene at (substeps, iterations), run for the case's
//!           frames (dt = 1/60 s) on one backend
//! time      ms of wall time per simulated second = median step time sum
//!           / (frames · dt) · 1000
//! error     the case's measure (cases.rs): closed form or converged reference
//! residual  largest constraint violation any step reported (StepReport),
//!           in the constraint's units (m for distance and contact)
//! drift     (E_end − E_0) / E_scale for the conservative cases
//! ```

use crate::cases::{Answer, CaseId, Observed, energy, relative_position_error};
use crate::config::Config;
use crate::pareto::mark_frontiers;
use crate::point::Point;
use crate::progress::Progress;
use crate::timing::{load, median, simulate};
use hyperpbd::{BackendKind, Plan, Scene, State};
use serde::Serialize;

/// The converged reference of a case without a closed form.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Reference {
    /// Substeps of the reference run.
    pub substeps: u32,
    /// Iterations of the reference run.
    pub iterations: u32,
    /// |ref − ref at half the substeps| / extent: the reference's own error
    /// estimate.
    pub uncertainty: f64,
    /// Wall ms per simulated second of the reference run (cpu-f64, one rep).
    pub ms_per_sim_second: f64,
    /// The same estimate for the case's rigid variant, where it has one
    /// (the shipped rigid cloth): large means no converged limit.
    pub rigid_uncertainty: Option<f64>,
}

/// Everything measured for one case.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CaseResult {
    /// The case.
    pub case: CaseId,
    /// Description with parameters.
    pub title: String,
    /// The error measure in words.
    pub metric: String,
    /// Closed form, or `converged`.
    pub answer: String,
    /// Simulated seconds.
    pub seconds: f64,
    /// The points, backend by backend.
    pub points: Vec<Point>,
    /// The converged reference, where used.
    pub reference: Option<Reference>,
}

fn compile(scene: &Scene) -> Result<Plan, String> {
    Plan::compile(scene).map_err(|e| e.to_string())
}

/// Final state of `scene` on the CPU after `frames`, and wall ms per
/// simulated second.
fn cpu_run(scene: &Scene, frames: u64) -> Result<(State, f64), String> {
    let initial = State::from_scene(scene);
    let mut b = load(BackendKind::Cpu, compile(scene)?, &initial)?;
    let sim = simulate(b.as_mut(), &initial, frames, 1, f64::INFINITY, false)?;
    Ok((
        sim.final_state,
        sim.samples[0] * 1000.0 / (frames as f64 * scene.dt),
    ))
}

/// Runs the reference of a converged case on the CPU: the reference, its
/// own error estimate (distance to the run at half the substeps, relative
/// to `extent`), the rigid variant's estimate, and ms per simulated second.
fn reference(
    case: CaseId,
    substeps: u32,
    iterations: u32,
    cloth_n: usize,
    extent: f64,
) -> Result<(State, Reference), String> {
    let frames = case.frames();
    let (fine, ms) = cpu_run(&case.scene(substeps, iterations, cloth_n), frames)?;
    let (coarse, _) = cpu_run(&case.scene(substeps / 2, iterations, cloth_n), frames)?;
    let rigid_uncertainty = match (
        case.rigid_variant(substeps, iterations, cloth_n),
        case.rigid_variant(substeps / 2, iterations, cloth_n),
    ) {
        (Some(a), Some(b)) => {
            let (a, _) = cpu_run(&a, frames)?;
            let (b, _) = cpu_run(&b, frames)?;
            Some(relative_position_error(&a, &b, extent))
        }
        _ => None,
    };
    let reference = Reference {
        substeps,
        iterations,
        uncertainty: relative_position_error(&fine, &coarse, extent),
        ms_per_sim_second: ms,
        rigid_uncertainty,
    };
    Ok((fine, reference))
}

/// Measures one case on every configured backend.
pub fn run_case(
    case: CaseId,
    config: &Config,
    progress: &mut Progress,
) -> Result<CaseResult, String> {
    let frames = case.frames();
    let grid = config.grid_for(case);
    let max_substeps = grid.iter().map(|p| p.0).max().unwrap_or(1);
    let max_iterations = grid.iter().map(|p| p.1).max().unwrap_or(1);
    let probe = case.scene(1, 1, config.cloth_n);
    let extent = probe.extent();
    let dt = probe.dt;

    let mut result = CaseResult {
        case,
        title: case.title(config.cloth_n),
        metric: case.metric().to_string(),
        answer: match case.answer() {
            Answer::ClosedForm(f) => f.to_string(),
            Answer::Converged => "converged cpu-f64 reference".to_string(),
        },
        seconds: frames as f64 * dt,
        points: Vec::new(),
        reference: None,
    };
    let reference_state = if case.answer() == Answer::Converged {
        let s = config.reference_factor * max_substeps;
        let i = config
            .iterations
            .iter()
            .copied()
            .max()
            .unwrap_or(1)
            .max(max_iterations);
        progress.note(&format!(
            "{}: reference cpu-f64 at {s} substeps × {i} iterations",
            case.name()
        ));
        let (fine, r) = reference(case, s, i, config.cloth_n, extent)?;
        result.reference = Some(r);
        Some(fine)
    } else {
        None
    };

    let context = Context {
        case,
        frames,
        dt,
        extent,
        reference: reference_state.as_ref(),
    };
    for &backend in &config.backends {
        if !progress.available(backend) {
            continue;
        }
        for &(s, i) in &grid {
            match measure(&context, backend, s, i, config) {
                Ok(point) => {
                    progress.point(&point);
                    result.points.push(point);
                }
                Err(e) => progress.note(&format!(
                    "{} {} s{s} i{i}: SKIPPED: {e}",
                    case.name(),
                    backend.name()
                )),
            }
        }
    }
    mark_frontiers(&mut result.points);
    Ok(result)
}

/// What every point of a case shares.
struct Context<'a> {
    case: CaseId,
    frames: u64,
    dt: f64,
    extent: f64,
    reference: Option<&'a State>,
}

/// One point: `Err` when the backend cannot load the scene (skipped); a
/// failed step is a point with a note.
fn measure(
    cx: &Context<'_>,
    backend: BackendKind,
    substeps: u32,
    iterations: u32,
    config: &Config,
) -> Result<Point, String> {
    let case = cx.case;
    let scene = case.scene(substeps, iterations, config.cloth_n);
    let initial = State::from_scene(&scene);
    let mut b = load(backend, compile(&scene)?, &initial)?;
    let mut point = Point {
        case,
        backend,
        substeps,
        iterations,
        ms_per_sim_second: f64::NAN,
        ms_min: f64::NAN,
        ms_max: f64::NAN,
        reps: 0,
        error: None,
        residual: f64::NAN,
        energy_drift: None,
        frontier: false,
        frozen: false,
        note: None,
    };
    let sim = match simulate(
        b.as_mut(),
        &initial,
        cx.frames,
        config.reps,
        config.long_run,
        case.needs_trajectory(),
    ) {
        Ok(sim) => sim,
        Err(e) => {
            point.note = Some(format!("step failed: {e}"));
            return Ok(point);
        }
    };
    let per = 1000.0 / (cx.frames as f64 * cx.dt);
    let ms: Vec<f64> = sim.samples.iter().map(|t| t * per).collect();
    point.ms_per_sim_second = median(&ms);
    point.ms_min = ms.iter().copied().fold(f64::INFINITY, f64::min);
    point.ms_max = ms.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    point.reps = ms.len();
    point.residual = sim.max_residual;
    let observed = Observed {
        trajectory: sim.trajectory,
        final_state: sim.final_state,
    };
    let measured = match (
        case.closed_form_error(&observed, cx.dt, cx.frames),
        cx.reference,
    ) {
        (Some(e), _) => e,
        (None, Some(r)) => Ok(relative_position_error(&observed.final_state, r, cx.extent)),
        (None, None) => Err("no reference".to_string()),
    };
    match measured {
        Ok(e) if e.is_finite() => point.error = Some(e),
        Ok(_) => point.note = Some("non-finite state (unstable)".into()),
        Err(why) => point.note = Some(why),
    }
    if !sim.reproducible {
        point.note = Some("reps ended in different states".into());
    }
    let dynamic: Vec<usize> = (0..scene.particles.len())
        .filter(|&k| !scene.particles[k].fixed)
        .collect();
    point.frozen = scene.gravity.is_some()
        && !dynamic.is_empty()
        && dynamic
            .iter()
            .all(|&k| observed.final_state.velocity(k).iter().all(|&v| v == 0.0));
    if point.frozen {
        point.note = Some("frozen: every velocity exactly 0 (h·|v| below half an ulp of x)".into());
    }
    point.energy_drift = case.conservative().then(|| {
        (energy(&scene, &observed.final_state) - energy(&scene, &initial))
            / case.energy_scale(&scene, &initial)
    });
    Ok(point)
}
