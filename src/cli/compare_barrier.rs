//! `hyperpbd compare` for incremental-potential scenes: the CPU golden path
//! and `GpuBarrierBackend` side by side, judged by
//! [`hyperpbd::compare_barrier::BarrierErrorModel`].

use super::CliError;
use hyperpbd::compare::{Divergence, coordinate_scale, max_abs_diff};
use hyperpbd::compare_barrier::BarrierErrorModel;
use hyperpbd::gpu::{GpuBarrierBackend, Precision};
use hyperpbd::{Backend, CpuBackend, Plan, State};
use std::path::Path;

/// Runs `frames` frames on both backends and prints the divergence against
/// the barrier-path bound (an error when some frame is over it).
pub fn compare_barrier(
    scene: &Path,
    frames: u64,
    every: u64,
    plan: Plan,
    state: &State,
    precision: Precision,
) -> Result<(), CliError> {
    let mut model = BarrierErrorModel::new(&plan, precision.into());
    let mut cpu =
        CpuBackend::new(plan.clone(), state).map_err(|e| CliError::Input(e.to_string()))?;
    let mut gpu = GpuBarrierBackend::new(plan, state, precision)
        .map_err(|e| CliError::Input(format!("GPU: {e}")))?;
    println!(
        "{}: cpu-f64 vs {} on {}; barrier-path bound = double sum over substeps of ({:e} x (r_cpu + r_gpu) + 16 eps {:e} x scale)",
        scene.display(),
        gpu.name(),
        gpu.adapter().name,
        model.position_per_residual,
        model.epsilon
    );
    println!(
        "{:>6} {:>13} {:>13} {:>13} {:>13}  status",
        "frame", "max |dx|", "bound", "max |dv|", "bound"
    );
    let mut scale = coordinate_scale(state);
    let mut over = 0u64;
    let mut worst: Option<Divergence> = None;
    for frame in 1..=frames {
        let step = |b: &mut dyn Backend| {
            b.step()
                .and_then(|report| b.read_state().map(|s| (report, s)))
                .map_err(|e| CliError::Simulation(format!("{} frame {frame}: {e}", b.name())))
        };
        let (golden_report, golden) = step(&mut cpu)?;
        let (other_report, other) = step(&mut gpu)?;
        scale = scale.max(coordinate_scale(&golden));
        model.advance(
            &golden_report.minimisation,
            &other_report.minimisation,
            scale,
        );
        let d = Divergence {
            steps: frame,
            position: max_abs_diff(&golden.positions, &other.positions),
            position_bound: model.position_bound(),
            velocity: max_abs_diff(&golden.velocities, &other.velocities),
            velocity_bound: model.velocity_bound(),
        };
        let ok = d.within();
        if !ok {
            over += 1;
        }
        if frame % every == 0 || frame == frames || !ok {
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
            "{over} of {frames} frames over the bound"
        )));
    }
    println!("all {frames} frames within the bound");
    Ok(())
}
