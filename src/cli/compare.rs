//! `hyperpbd compare`: CPU golden path and GPU side by side.

use super::{CliError, load_scene};
use hyperpbd::compare::{Divergence, ErrorModel, coordinate_scale};
use hyperpbd::gpu::{GpuBackend, Precision};
use hyperpbd::{Backend, CpuBackend, Plan, State};
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
    /// Precision of the GPU run.
    #[arg(long, value_enum, default_value_t = PrecisionArg::F32)]
    precision: PrecisionArg,
    /// Print every K-th frame (all frames are checked).
    #[arg(long, default_value_t = 1)]
    every: u64,
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum PrecisionArg {
    F32,
    F64,
}

pub fn compare(args: &CompareArgs) -> Result<(), CliError> {
    args.threads.apply();
    if args.every == 0 {
        return Err(CliError::Input("--every: must be at least 1".into()));
    }
    let scene = load_scene(&args.scene)?;
    let plan = Plan::compile(&scene).map_err(|e| CliError::Input(e.to_string()))?;
    let state = State::from_scene(&scene);
    let precision = match args.precision {
        PrecisionArg::F32 => Precision::F32,
        PrecisionArg::F64 => Precision::F64,
    };
    if plan.incremental_potential.is_some() {
        return super::compare_barrier::compare_barrier(
            &args.scene,
            args.frames,
            args.every,
            plan,
            &state,
            precision,
        );
    }
    let model = ErrorModel::new(&plan, precision.into());
    if plan.contacts.is_some() {
        println!(
            "note: particle contact switches on and off at C = 0, so a granular scene's \
             trajectories part once a contact differs by rounding; the bound holds for short \
             horizons only (tests/gpu_granular.rs compares invariants instead)"
        );
    }
    let mut cpu =
        CpuBackend::new(plan.clone(), &state).map_err(|e| CliError::Input(e.to_string()))?;
    let mut gpu = GpuBackend::new(plan, &state, precision)
        .map_err(|e| CliError::Input(format!("GPU: {e}")))?;
    println!(
        "{}: cpu-f64 vs {} on {}; bound = eps {:e} x scale x {} roundings/substep x substeps",
        args.scene.display(),
        gpu.name(),
        gpu.adapter().name,
        model.epsilon,
        model.ops_per_substep
    );
    println!(
        "{:>6} {:>13} {:>13} {:>13} {:>13}  status",
        "frame", "max |dx|", "bound", "max |dv|", "bound"
    );
    let mut scale = coordinate_scale(&state);
    let mut worst: Option<Divergence> = None;
    let mut over = 0u64;
    for frame in 1..=args.frames {
        let step = |b: &mut dyn Backend| {
            b.step()
                .and_then(|_| b.read_state())
                .map_err(|e| CliError::Simulation(format!("{} frame {frame}: {e}", b.name())))
        };
        let golden = step(&mut cpu)?;
        let other = step(&mut gpu)?;
        scale = scale.max(coordinate_scale(&golden));
        let d = Divergence::measure(&model, &golden, &other, scale, frame);
        let ok = d.within();
        if !ok {
            over += 1;
        }
        if frame % args.every == 0 || frame == args.frames || !ok {
            println!(
                "{frame:>6} {:>13.3e} {:>13.3e} {:>13.3e} {:>13.3e}  {}",
                d.position,
                d.position_bound,
                d.velocity,
                d.velocity_bound,
                if ok { "ok" } else { "OVER" }
            );
        }
        let ratio =
            |d: &Divergence| (d.position / d.position_bound).max(d.velocity / d.velocity_bound);
        if worst
            .as_ref()
            .is_none_or(|w| ratio(&d) > ratio(w) || d.position.is_nan())
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
    if over > 0 {
        return Err(CliError::Simulation(format!(
            "{over} of {} frames over the bound",
            args.frames
        )));
    }
    println!("all {} frames within the bound", args.frames);
    Ok(())
}
