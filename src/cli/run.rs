//! `hyperpbd run` and `hyperpbd demo`.

use super::error::CliError;
use super::load::{load_backend, load_scene, parse_backend};
use super::output::{forces_json, state_json, write_file};
use hyperpbd::atomic_file::AtomicFile;
use hyperpbd::sweep::Metric;
use hyperpbd::with_sources;
use hyperpbd::{Backend, BackendKind, Plan, State, StepReport};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::time::Instant;

/// Options of `hyperpbd run`.
#[derive(Debug, clap::Args)]
pub struct RunArgs {
    #[command(flatten)]
    threads: super::threads::ThreadsArg,
    /// Scene file (JSON).
    scene: PathBuf,
    /// Backend: cpu, gpu (f32), gpu-f64, or auto (a hardware GPU when
    /// there is one, else the CPU, saying why).
    #[arg(long, default_value = "auto", value_parser = parse_backend)]
    backend: BackendKind,
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
    /// Write each frame's contact forces here, one JSON object per line:
    /// per obstacle its total contact force on the particles, per particle its
    /// total contact force (docs/collisions.md#contact-forces).
    #[arg(long)]
    forces: Option<PathBuf>,
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
            .map_err(|e| CliError::Simulation(format!("frame {frame}: {}", with_sources(&e))))?;
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
    if args.forces.is_some() {
        backend
            .request_contact_forces(true)
            .map_err(|e| CliError::Input(format!("--forces: {}", with_sources(&e))))?;
    }

    // The trajectory is written under a temporary name and committed only
    // when the whole run and `--out` succeeded: any failure drops it, and
    // dropping an uncommitted file removes it (no partial output).
    let cannot_write = |path: &std::path::Path, e: std::io::Error| {
        CliError::Output(format!("cannot write {}: {e}", path.display()))
    };
    let mut trajectory = match &args.trajectory {
        Some(path) => Some(AtomicFile::create(path).map_err(|e| cannot_write(path, e))?),
        None => None,
    };
    let mut forces = match &args.forces {
        Some(path) => Some(AtomicFile::create(path).map_err(|e| cannot_write(path, e))?),
        None => None,
    };
    if let Some(file) = &mut trajectory {
        let initial = read(backend.as_mut())?;
        writeln!(file, "{}", state_json(0.0, 0, &initial))
            .map_err(|e| cannot_write(file.path(), e))?;
    }
    let start = Instant::now();
    let mut host_waits = 0u64;
    let last = simulate(backend.as_mut(), args.frames, |frame, b, report| {
        print_retries(frame, report);
        host_waits += report.host_waits;
        if let Some(file) = &mut trajectory
            && frame % args.every == 0
        {
            let state = read(b)?;
            writeln!(file, "{}", state_json(frame as f64 * dt, frame, &state))
                .map_err(|e| cannot_write(file.path(), e))?;
        }
        if let (Some(file), Some(f)) = (&mut forces, &report.contact_forces) {
            writeln!(file, "{}", forces_json(frame as f64 * dt, frame, f))
                .map_err(|e| cannot_write(file.path(), e))?;
        }
        Ok(())
    })?;
    let wall = start.elapsed().as_secs_f64();
    let time = args.frames as f64 * dt;
    let state = read(backend.as_mut())?;
    if let Some(path) = &args.out {
        write_file(
            path,
            (state_json(time, args.frames, &state) + "\n").as_bytes(),
        )?;
    }
    for file in [trajectory, forces].into_iter().flatten() {
        let path = file.path().to_path_buf();
        file.commit().map_err(|e| cannot_write(&path, e))?;
    }
    println!(
        "{}: {} frames, {time} s simulated in {wall:.3} s wall ({})",
        args.scene.display(),
        args.frames,
        backend.name()
    );
    if backend.name().starts_with("gpu") {
        let precision = if backend.name() == "gpu-f64" {
            hyperpbd::Precision::F64
        } else {
            hyperpbd::Precision::F32
        };
        match hyperpbd::gpu::ShaderPath::current(precision) {
            Ok(path) => println!("{}", path.describe()),
            Err(e) => println!("shader path: unknown ({e})"),
        }
        // The steps' own waits (StepReport::host_waits), not the reads of
        // --out or --trajectory.
        println!(
            "host waits per frame: {}",
            host_waits as f64 / args.frames.max(1) as f64
        );
    }
    if let Some(report) = last {
        print_report(&report);
    }
    println!("state hash {:016x}", state.hash());
    Ok(())
}

/// One line for a frame that `adaptive` retried: every rejected attempt
/// and the substeps of the accepted one.
fn print_retries(frame: u64, report: &StepReport) {
    if report.retries() == 0 {
        return;
    }
    let rejected: Vec<String> = report
        .attempts
        .iter()
        .filter_map(|a| {
            let r = a.rejection.as_ref()?;
            Some(format!("{} substeps: {r}", a.substeps))
        })
        .collect();
    let accepted = report.attempts.last().map_or(0, |a| a.substeps);
    println!(
        "frame {frame}: retried, accepted with {accepted} substeps after {} rejected attempts ({})",
        rejected.len(),
        rejected.join("; ")
    );
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

/// The mean of velocity coordinate `axis` over the dynamic particles.
fn mean_velocity(scene: &hyperpbd::Scene, state: &State, axis: usize) -> f64 {
    let dim = state.dim;
    let dynamic: Vec<usize> = (0..scene.particles.len())
        .filter(|&i| !scene.particles[i].fixed)
        .collect();
    let sum: f64 = dynamic
        .iter()
        .map(|&i| state.velocities[i * dim + axis])
        .sum();
    sum / dynamic.len().max(1) as f64
}

pub fn demo(frames: u64, choice: BackendKind) -> Result<(), CliError> {
    let scene = hyperpbd::scenes::demo();
    let plan = Plan::compile(&scene).map_err(|e| CliError::Input(e.to_string()))?;
    println!(
        "hyperpbd demo: a 32x32 cloth (1 m square, rigid edges and shear links, cosine bending) held at two \
         corners by hands that lower it onto a conveyor belt (the ground plane, moving at {} m/s along x, \
         friction 0.6)",
        hyperpbd::scenes::BELT_SPEED
    );
    print!("{}", super::describe::describe(&plan));
    let dt = plan.dt;
    let mut backend = load_backend(choice, plan, &State::from_scene(&scene))?;
    println!("backend: {}", backend.name());
    println!(
        "{:>6} {:>7} {:>12} {:>14} {:>10} {:>12} {:>12}",
        "frame", "time", "lowest y", "max |C| edge", "contacts", "mean vx m/s", "kinetic J"
    );
    let start = Instant::now();
    simulate(backend.as_mut(), frames, |frame, b, report| {
        if frame % 20 == 0 || frame == frames {
            let state = read(b)?;
            println!(
                "{frame:>6} {:>7.3} {:>12.5} {:>14.3e} {:>10} {:>12.4} {:>12.5e}",
                frame as f64 * dt,
                lowest(&state, 1),
                report.residuals.first().map_or(0.0, |r| r.max_violation),
                report.active_contacts,
                mean_velocity(&scene, &state, 0),
                Metric::KineticEnergy.value(&scene, &state, None),
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
        "picture of the last frame: {} (more: hyperpbd render demo --perspective)",
        picture.display()
    );
    Ok(())
}
