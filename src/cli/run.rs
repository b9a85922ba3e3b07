//! `hyperpbd run` and `hyperpbd demo`.

use super::output::{state_json, temporary_path, write_atomically};
use super::{BackendChoice, CliError, load_backend, load_scene};
use hyperpbd::{Backend, Plan, Scene, State, StepReport};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::{BufWriter, IsTerminal, Write};
use std::path::PathBuf;
use std::time::Instant;

/// Options of `hyperpbd run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    #[command(flatten)]
    threads: super::threads::ThreadsArg,
    /// Scene file (JSON).
    scene: PathBuf,
    /// Backend to use.
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    backend: BackendChoice,
    /// Number of frames (steps of the scene's dt) to simulate.
    #[arg(long, default_value_t = 60)]
    frames: u64,
    /// Write the final state here as JSON.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Write one JSON state per line here, every `--every` frames (and the
    /// initial state).
    #[arg(long)]
    trajectory: Option<PathBuf>,
    /// Trajectory stride in frames.
    #[arg(long, default_value_t = 1, requires = "trajectory")]
    every: u64,
}

/// Steps `backend` for `frames` frames, calling `on_frame` after each.
fn simulate(
    backend: &mut dyn Backend,
    frames: u64,
    mut on_frame: impl FnMut(u64, &mut dyn Backend, &StepReport) -> Result<(), CliError>,
) -> Result<Option<StepReport>, CliError> {
    let bar = if std::io::stderr().is_terminal() && frames >= 30 {
        let bar = ProgressBar::new(frames);
        bar.set_style(
            ProgressStyle::with_template("{bar:40} {pos}/{len} frames {elapsed} (eta {eta})")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar
    } else {
        ProgressBar::hidden()
    };
    let mut last = None;
    for frame in 1..=frames {
        let report = backend
            .step()
            .map_err(|e| CliError::Simulation(format!("frame {frame}: {e}")))?;
        on_frame(frame, backend, &report)?;
        last = Some(report);
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(last)
}

fn read(backend: &mut dyn Backend) -> Result<State, CliError> {
    backend
        .read_state()
        .map_err(|e| CliError::Simulation(e.to_string()))
}

pub fn run(args: &RunArgs) -> Result<(), CliError> {
    args.threads.apply();
    if args.every == 0 {
        return Err(CliError::Input("--every: must be at least 1".into()));
    }
    let scene = load_scene(&args.scene)?;
    let plan = Plan::compile(&scene).map_err(|e| CliError::Input(e.to_string()))?;
    let dt = plan.dt;
    let mut backend = load_backend(args.backend, plan, &State::from_scene(&scene))?;

    // The trajectory goes to a temporary file, renamed only on success.
    let mut trajectory = match &args.trajectory {
        Some(path) => {
            let tmp = temporary_path(path);
            let file = std::fs::File::create(&tmp)
                .map_err(|e| CliError::Output(format!("cannot write {}: {e}", path.display())))?;
            Some((path.clone(), tmp, BufWriter::new(file)))
        }
        None => None,
    };
    let write_line = |w: &mut BufWriter<std::fs::File>, line: String| {
        writeln!(w, "{line}").map_err(|e| CliError::Output(e.to_string()))
    };
    if let Some((_, _, w)) = &mut trajectory {
        let initial = read(backend.as_mut())?;
        write_line(w, state_json(0.0, 0, &initial))?;
    }
    let start = Instant::now();
    let result = simulate(backend.as_mut(), args.frames, |frame, b, _| {
        if let Some((_, _, w)) = &mut trajectory
            && frame % args.every == 0
        {
            let state = read(b)?;
            write_line(w, state_json(frame as f64 * dt, frame, &state))?;
        }
        Ok(())
    });
    let wall = start.elapsed().as_secs_f64();
    let finish_trajectory = |trajectory: Option<(PathBuf, PathBuf, BufWriter<std::fs::File>)>,
                             keep: bool|
     -> Result<(), CliError> {
        if let Some((path, tmp, w)) = trajectory {
            let flushed = w
                .into_inner()
                .map_err(|e| e.to_string())
                .and_then(|f| f.sync_all().map_err(|e| e.to_string()));
            if keep && flushed.is_ok() {
                return std::fs::rename(&tmp, &path).map_err(|e| {
                    CliError::Output(format!("cannot write {}: {e}", path.display()))
                });
            }
            let _ = std::fs::remove_file(&tmp);
            if let Err(e) = flushed {
                return Err(CliError::Output(format!(
                    "cannot write {}: {e}",
                    path.display()
                )));
            }
        }
        Ok(())
    };
    let last = match result {
        Ok(last) => last,
        Err(e) => {
            finish_trajectory(trajectory, false)?;
            return Err(e);
        }
    };
    let time = args.frames as f64 * dt;
    // Any failure from here on discards the trajectory too: no partial output.
    let written = read(backend.as_mut()).and_then(|state| {
        if let Some(path) = &args.out {
            write_atomically(
                path,
                (state_json(time, args.frames, &state) + "\n").as_bytes(),
            )?;
        }
        Ok(state)
    });
    let state = match written {
        Ok(state) => state,
        Err(e) => {
            finish_trajectory(trajectory, false)?;
            return Err(e);
        }
    };
    finish_trajectory(trajectory, true)?;
    println!(
        "{}: {} frames, {time} s simulated in {wall:.3} s wall ({})",
        args.scene.display(),
        args.frames,
        backend.name()
    );
    if let Some(report) = last {
        print_report(&report);
    }
    println!("state hash {:016x}", state.hash());
    Ok(())
}

fn print_report(report: &StepReport) {
    for r in &report.residuals {
        println!("  {} max violation {:e}", r.label, r.max_violation);
    }
    if report.active_contacts > 0 {
        println!("  active contacts {}", report.active_contacts);
    }
    if report.threads > 0 {
        println!("  cpu threads {}", report.threads);
    }
}

/// Lowest coordinate along `axis` over all particles.
fn lowest(state: &State, axis: usize) -> f64 {
    (0..state.len())
        .map(|i| state.position(i)[axis])
        .fold(f64::INFINITY, f64::min)
}

/// Kinetic energy ½ Σ m |v|² of the dynamic particles.
fn kinetic_energy(scene: &Scene, state: &State) -> f64 {
    scene
        .particles
        .iter()
        .enumerate()
        .filter(|(_, p)| !p.fixed)
        .map(|(i, p)| {
            let v2: f64 = state.velocity(i).iter().map(|v| v * v).sum();
            0.5 * p.mass.unwrap_or(0.0) * v2
        })
        .sum()
}

pub fn demo(frames: u64, choice: BackendChoice) -> Result<(), CliError> {
    let scene = hyperpbd::scenes::cloth(32);
    let plan = Plan::compile(&scene).map_err(|e| CliError::Input(e.to_string()))?;
    println!(
        "hyperpbd demo: a 32x32 cloth (1 m square, rigid edges and shear springs) dropped onto a ground plane with friction 0.4"
    );
    print!("{}", plan.describe());
    let dt = plan.dt;
    let mut backend = load_backend(choice, plan, &State::from_scene(&scene))?;
    println!("backend: {}", backend.name());
    println!(
        "{:>6} {:>7} {:>12} {:>14} {:>10} {:>12}",
        "frame", "time", "lowest y", "max |C| edge", "contacts", "kinetic J"
    );
    let start = Instant::now();
    simulate(backend.as_mut(), frames, |frame, b, report| {
        if frame % 20 == 0 || frame == frames {
            let state = read(b)?;
            println!(
                "{frame:>6} {:>7.3} {:>12.5} {:>14.3e} {:>10} {:>12.5e}",
                frame as f64 * dt,
                lowest(&state, 1),
                report.residuals.first().map_or(0.0, |r| r.max_violation),
                report.active_contacts,
                kinetic_energy(&scene, &state),
            );
        }
        Ok(())
    })?;
    let wall = start.elapsed().as_secs_f64();
    let state = read(backend.as_mut())?;
    println!(
        "simulated {:.3} s in {wall:.3} s wall; {} constraint projections per step; state hash {:016x}",
        frames as f64 * dt,
        backend.plan().projections_per_step(),
        state.hash()
    );
    let picture = std::path::Path::new("out").join("demo.png");
    super::render::demo_picture(&scene, &state, frames as f64 * dt, &picture)?;
    println!(
        "picture of the last frame: {} (more: hyperpbd render cloth --perspective)",
        picture.display()
    );
    Ok(())
}
