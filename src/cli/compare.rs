//! `hyperpbd compare`: a GPU backend against the CPU golden path frame by
//! frame, each frame from the GPU's own previous state, against the
//! per-frame divergence bound of the plan's solver.
//!
//! ```text
//! every frame            s = GPU state; GPU steps; CPU loads s and steps;
//!                        |dx|, |dv| against the bounds of that one frame;
//!                        OVER lines are always printed; any OVER frame exits 3
//! XPBD                   FrameErrorModel: the roundings of one frame's substeps
//! incremental potential  BarrierErrorModel: driven by both runs' residuals
//! f32 XPBD               also the f32 reference (F32Reference, the WGSL's
//!                        f32 arithmetic on the CPU) from the same start: the
//!                        GPU's distance from it (0 where the adapter neither
//!                        contracts nor regroups, e.g. lavapipe); --exact
//!                        makes any nonzero distance a failure (exit 3)
//! ```

use super::error::CliError;
use super::load::load_scene;
use hyperpbd::gpu::SceneOrigin;
use hyperpbd::with_sources;
use hyperpbd::{
    Backend, BackendError, BackendKind, F32Reference, Plan, Precision, SolverPlan, State,
};
use hyperpbd_verify::compare::{Divergence, DivergenceModel, Frame};
use hyperpbd_verify::compare_barrier::BarrierErrorModel;
use hyperpbd_verify::compare_frame::FrameErrorModel;
use std::path::PathBuf;

/// Options of `hyperpbd compare`.
#[derive(Debug, clap::Args)]
pub struct CompareArgs {
    #[command(flatten)]
    threads: super::threads::ThreadsArg,
    /// Scene file (JSON).
    scene: PathBuf,
    /// Frames to compare.
    #[arg(long, default_value_t = 60)]
    frames: u64,
    /// Precision of the GPU run: f32 or f64.
    #[arg(long, default_value = "f32", value_parser = parse_precision)]
    precision: Precision,
    /// Print every K-th frame (all frames are checked).
    #[arg(long, default_value_t = 1)]
    every: u64,
    /// Multiplies every bound (for tests: a factor below 1 makes the
    /// over-bound path reachable on a healthy GPU).
    #[arg(
        long,
        default_value_t = 1.0,
        hide = true,
        allow_negative_numbers = true
    )]
    bound_factor: f64,
    /// f32: fail unless every frame is the f32 reference's bit for bit (an
    /// adapter that neither contracts nor regroups, e.g. lavapipe).
    #[arg(long)]
    exact: bool,
}

fn parse_precision(name: &str) -> Result<Precision, String> {
    name.parse()
}

/// The per-frame divergence model of `plan`'s solver at `precision`; the
/// GPU stores positions relative to the origin of `state`.
fn model(
    plan: &Plan,
    precision: Precision,
    state: &State,
) -> Result<Box<dyn DivergenceModel>, BackendError> {
    Ok(match plan.solver {
        SolverPlan::Xpbd => {
            let origin = SceneOrigin::for_state(plan.dim, &state.positions, precision);
            Box::new(FrameErrorModel::new(plan, precision, origin.as_slice())?)
        }
        SolverPlan::IncrementalPotential(_) => Box::new(BarrierErrorModel::new(plan, precision)),
    })
}

/// The f32 reference of an f32 XPBD plan it runs (with the GPU's origin).
fn reference(
    plan: &Plan,
    precision: Precision,
    state: &State,
) -> Result<Option<F32Reference>, CliError> {
    if precision != Precision::F32 || !matches!(plan.solver, SolverPlan::Xpbd) {
        return Ok(None);
    }
    let origin = SceneOrigin::for_state(plan.dim, &state.positions, precision);
    Ok(F32Reference::new(plan.clone(), state, origin.as_slice()).ok())
}

/// The f32 reference's frame from `start`: its largest coordinate distance
/// (positions and velocities) from the GPU's `other`; 0 means bit for bit.
fn reference_distance(
    r: &mut F32Reference,
    start: &State,
    other: &State,
    frame: u64,
) -> Result<f64, CliError> {
    let failed = |e: &dyn std::fmt::Display| {
        CliError::Simulation(format!("f32 reference frame {frame}: {e}"))
    };
    r.write_state(start).map_err(|e| failed(&e))?;
    r.step().map_err(|e| failed(&e))?;
    let expected = r.read_state();
    let same = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
    if same(&expected.positions, &other.positions) && same(&expected.velocities, &other.velocities)
    {
        return Ok(0.0);
    }
    let distance =
        hyperpbd_verify::compare::max_abs_diff(&expected.positions, &other.positions).max(
            hyperpbd_verify::compare::max_abs_diff(&expected.velocities, &other.velocities),
        );
    // Differing bits at distance 0 (±0, NaN payloads) still differ.
    Ok(if distance > 0.0 {
        distance
    } else {
        f64::MIN_POSITIVE
    })
}

pub fn compare(args: &CompareArgs) -> Result<(), CliError> {
    args.threads.apply();
    if args.every == 0 {
        return Err(CliError::Input("--every: must be at least 1".into()));
    }
    if !(args.bound_factor.is_finite() && args.bound_factor >= 0.0) {
        return Err(CliError::Input(
            "--bound-factor: must be finite and >= 0".into(),
        ));
    }
    let scene = load_scene(&args.scene)?;
    let plan = Plan::compile(&scene).map_err(|e| CliError::Input(e.to_string()))?;
    let state = State::from_scene(&scene);
    let mut model =
        model(&plan, args.precision, &state).map_err(|e| CliError::Input(e.to_string()))?;
    if plan.contacts.is_some() {
        println!(
            "note: particle contact switches on and off at C = 0, so a granular scene's \
             trajectories part once a contact differs by rounding; the bound holds for short \
             horizons only (tests/gpu/granular.rs compares invariants instead)"
        );
    }
    let mut reference = reference(&plan, args.precision, &state)?;
    if args.exact && reference.is_none() {
        return Err(CliError::Input(
            "--exact: needs --precision f32 and an XPBD plan the f32 reference runs \
             (no material families, no particle contact)"
                .into(),
        ));
    }
    let gpu_error = |e: &dyn std::fmt::Display| CliError::Input(format!("GPU: {e}"));
    super::software_threads::choose(&plan);
    let (adapter, summary) =
        hyperpbd::gpu::request_adapter(args.precision).map_err(|e| gpu_error(&e))?;
    let mut cpu = hyperpbd::load(plan.clone(), &state, BackendKind::Cpu)
        .map_err(|e| CliError::Input(e.to_string()))?;
    let mut gpu = hyperpbd::load_on_adapter(&adapter, plan, &state, args.precision)
        .map_err(|e| gpu_error(&e))?;
    println!(
        "{}: cpu-f64 vs {} on {}; {}",
        args.scene.display(),
        gpu.name(),
        summary.name,
        model.describe()
    );
    println!(
        "{:>6} {:>13} {:>13} {:>13} {:>13} {:>13}  status",
        "frame", "max |dx|", "bound", "max |dv|", "bound", "vs f32 ref."
    );
    let mut worst: Option<Divergence> = None;
    let mut over = 0u64;
    let mut identical = 0u64;
    for frame in 1..=args.frames {
        let step = |b: &mut dyn Backend| {
            b.step()
                .and_then(|report| b.read_state().map(|s| (report, s)))
                .map_err(|e| {
                    CliError::Simulation(format!(
                        "{} frame {frame}: {}",
                        b.name(),
                        with_sources(&e)
                    ))
                })
        };
        let start = gpu.read_state().map_err(|e| {
            CliError::Simulation(format!(
                "{} frame {frame}: {}",
                gpu.name(),
                with_sources(&e)
            ))
        })?;
        cpu.write_state(&start)
            .map_err(|e| CliError::Simulation(with_sources(&e)))?;
        let (golden_report, golden) = step(cpu.as_mut())?;
        let (other_report, other) = step(gpu.as_mut())?;
        let (position, velocity) = model
            .frame_bounds(Frame {
                start: &start,
                golden: (&golden_report, &golden),
                other: (&other_report, &other),
            })
            .map_err(|e| CliError::Simulation(format!("frame {frame}: {}", with_sources(&e))))?;
        let bounds = (args.bound_factor * position, args.bound_factor * velocity);
        let d = Divergence::new(frame, &golden, &other, bounds);
        let from_reference = match reference.as_mut() {
            Some(r) => Some(reference_distance(r, &start, &other, frame)?),
            None => None,
        };
        identical += u64::from(from_reference == Some(0.0));
        let ok = d.within() && (!args.exact || from_reference == Some(0.0));
        if !ok {
            over += 1;
        }
        if frame % args.every == 0 || frame == args.frames || !ok {
            let vs_reference = match from_reference {
                Some(0.0) => "exact".to_string(),
                Some(distance) => format!("{distance:.3e}"),
                None => "-".to_string(),
            };
            println!(
                "{frame:>6} {:>13.3e} {:>13.3e} {:>13.3e} {:>13.3e} {vs_reference:>13}  {}",
                d.position,
                d.position_bound,
                d.velocity,
                d.velocity_bound,
                if ok { "ok" } else { "OVER" }
            );
        }
        if worst
            .as_ref()
            .is_none_or(|w| d.ratio() > w.ratio() || d.position.is_nan())
        {
            worst = Some(d);
        }
    }
    if let Some(w) = worst {
        println!(
            "worst frame {}: position {:e} / bound {:e}, velocity {:e} / bound {:e}",
            w.steps, w.position, w.position_bound, w.velocity, w.velocity_bound
        );
    }
    if reference.is_some() {
        println!(
            "f32 reference: the GPU matched it bit for bit in {identical} of {} frames",
            args.frames
        );
    }
    if over > 0 {
        let what = if args.exact {
            "over the bound or off the f32 reference"
        } else {
            "over the bound"
        };
        return Err(CliError::Simulation(format!(
            "{over} of {} frames {what}",
            args.frames
        )));
    }
    println!("all {} frames within the bound", args.frames);
    Ok(())
}
