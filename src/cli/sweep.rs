//! `hyperpbd sweep`: one scene, numbers of it swept over inclusive ranges
//! (`--set PATH=LO:HI:COUNT`, the cartesian product, last `--set` fastest),
//! one JSON line per world, optionally one contiguous shard of the worlds
//! (`--shard K/N`) so a large sweep runs as a job array (docs/sweeps.md).
//!
//! ```text
//! line = {"world": w, "set": {PATH: value, …}, "positions": [[…]…],
//!         "velocities": [[…]…], "report": {"max_violation", "residuals",
//!         "active_contacts", "threads"}}
//! ```
//! The file is written atomically: a failed world leaves no file. On the
//! CPU the worlds run in parallel (`--threads`), one thread each. On
//! `--backend gpu` / `gpu-f64` they run as GPU batches (every world of a
//! batch in the same dispatches, the union of the worlds' stages — a world
//! with zero damping, friction, gravity or force runs them as exact
//! identities —, world k bit for bit its own run in f64), or, where the
//! worlds cannot share one GPU schedule (another topology or law),
//! one GPU backend each, with a notice naming the world and what differs.
//! Particle contact batches (each world its own grid and lists); so do the
//! incremental-potential solvers (each world its own backend, the worlds'
//! steps in lockstep on one device, sharing the host's waits).

use super::error::CliError;
use super::load::{load_backend, parse_backend};
use super::output::{rows, write_file};
use hyperpbd::atomic_file::AtomicFile;
use hyperpbd::batch::{Batch, BatchError, GpuBatch, gpu_batch_worlds};
use hyperpbd::sweep::{Metric, Shard, Sweep, SweepAxis};
use hyperpbd::with_sources;
use hyperpbd::{Backend, BackendKind, CpuBackend, Plan, Precision, Scene, State, StepReport};
use hyperpbd_render::chart::{Series, line_chart};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde_json::{Map, Value, json};
use std::io::{IsTerminal, Write};
use std::path::PathBuf;

/// Options of `hyperpbd sweep`.
#[derive(Debug, clap::Args)]
pub struct SweepArgs {
    #[command(flatten)]
    threads: super::threads::ThreadsArg,
    /// Scene file (JSON).
    scene: PathBuf,
    /// A swept number: PATH=LO:HI:COUNT, PATH as validation errors name
    /// fields (obstacles[0].friction, damping.rate, gravity[1],
    /// constraints[2].compliance, particles[5].velocity[0]); COUNT values
    /// from LO to HI inclusive. Repeat for a cartesian product (the last
    /// one varies fastest).
    #[arg(long = "set", value_name = "PATH=LO:HI:COUNT", required = true)]
    axes: Vec<SweepAxis>,
    /// Frames (steps of the scene's dt) per world.
    #[arg(long, default_value_t = 60)]
    frames: u64,
    /// Backend: cpu, gpu (f32), gpu-f64, or auto.
    #[arg(long, default_value = "auto", value_parser = parse_backend)]
    backend: BackendKind,
    /// Output file: one JSON line per world of this shard.
    #[arg(long)]
    out: PathBuf,
    /// Run only the K-th of N contiguous slices of the worlds (1-based).
    #[arg(long, value_name = "K/N", default_value = "1/1")]
    shard: Shard,
    /// Also draw METRIC (max_violation, kinetic_energy, height, max_speed,
    /// active_contacts) against the swept values into OUT's name with
    /// `.METRIC.png` (one or two --set axes; with two, one line per value
    /// of the first).
    #[arg(long, value_name = "METRIC")]
    plot: Option<Metric>,
}

pub fn sweep(args: &SweepArgs) -> Result<(), CliError> {
    args.threads.apply();
    let path = &args.scene;
    let text = std::fs::read_to_string(path)
        .map_err(|e| CliError::Input(format!("cannot read scene file {}: {e}", path.display())))?;
    let sweep = Sweep::new(&text, args.axes.clone())
        .map_err(|e| CliError::Input(format!("{}: {e}", path.display())))?;
    let worlds = args.shard.range(sweep.world_count());
    if args.plot.is_some() && sweep.axes().len() > 2 {
        return Err(CliError::Input(format!(
            "--plot: draws one or two --set axes, got {}",
            sweep.axes().len()
        )));
    }
    // Every world of the shard is validated before any runs: a bad value
    // fails in a second, not after hours of simulation.
    for world in worlds.clone() {
        sweep
            .scene(world)
            .map_err(|e| CliError::Input(format!("{}: {e}", path.display())))?;
    }
    let cannot_write =
        |e: std::io::Error| CliError::Output(format!("cannot write {}: {e}", args.out.display()));
    let mut file = AtomicFile::create(&args.out).map_err(cannot_write)?;
    let bar = progress(worlds.len() as u64 * args.frames);
    let run = |world: usize, threads: Option<usize>| -> Result<Finished, CliError> {
        let scene = sweep
            .scene(world)
            .map_err(|e| CliError::Input(format!("{}: {e}", path.display())))?;
        let plan =
            Plan::compile(&scene).map_err(|e| CliError::Input(format!("worlds[{world}]: {e}")))?;
        let state = State::from_scene(&scene);
        let mut backend: Box<dyn Backend> = match threads {
            Some(threads) => Box::new(
                CpuBackend::with_threads(plan, &state, threads)
                    .map_err(|e| CliError::Input(format!("worlds[{world}]: {e}")))?,
            ),
            None => load_backend(args.backend, plan, &state)?,
        };
        let mut last = None;
        for frame in 1..=args.frames {
            let report = backend.step().map_err(|e| {
                CliError::Simulation(format!(
                    "worlds[{world}] frame {frame}: {}",
                    with_sources(&e)
                ))
            })?;
            last = Some(report);
            bar.inc(1);
        }
        let state = backend
            .read_state()
            .map_err(|e| CliError::Simulation(format!("worlds[{world}]: {e}")))?;
        Ok(Finished {
            line: world_line(&sweep, world, &state, last.as_ref()).to_string(),
            backend: backend.name(),
            metric: args.plot.map(|m| m.value(&scene, &state, last.as_ref())),
        })
    };
    let mut backend_name = String::new();
    let mut metrics = Vec::with_capacity(worlds.len());
    if args.backend == BackendKind::Cpu {
        // Worlds in parallel, one thread each (same bytes as one world on
        // any count of threads), in groups written in world order.
        let threads = hyperpbd::default_threads().map_err(|e| CliError::Input(e.to_string()))?;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| CliError::Simulation(format!("cannot start {threads} threads: {e}")))?;
        let group = 4 * threads;
        let mut next = worlds.start;
        while next < worlds.end {
            let ids: Vec<usize> = (next..worlds.end.min(next + group)).collect();
            next += ids.len();
            let results: Vec<_> =
                pool.install(|| ids.par_iter().map(|&w| run(w, Some(1))).collect());
            for result in results {
                let done = result?;
                writeln!(file, "{}", done.line).map_err(cannot_write)?;
                backend_name = done.backend;
                metrics.extend(done.metric);
            }
        }
    } else {
        let batched = match args.backend {
            BackendKind::Gpu(precision) => {
                run_batched(&sweep, worlds.clone(), args, precision, &bar)?
            }
            _ => None,
        };
        let finished = match batched {
            Some(finished) => finished,
            None => worlds
                .clone()
                .map(|w| run(w, None))
                .collect::<Result<_, _>>()?,
        };
        for done in finished {
            writeln!(file, "{}", done.line).map_err(cannot_write)?;
            backend_name = done.backend;
            metrics.extend(done.metric);
        }
    }
    bar.finish_and_clear();
    let chart = match args.plot {
        Some(metric) => Some((
            metric,
            chart(&sweep, worlds.clone(), &metrics, metric, &args.out)?,
        )),
        None => None,
    };
    file.commit().map_err(cannot_write)?;
    println!(
        "{}: worlds {}..{} of {} ({} frames each, {backend_name}) written to {}",
        path.display(),
        worlds.start,
        worlds.end,
        sweep.world_count(),
        args.frames,
        args.out.display()
    );
    if let Some((metric, (path, bytes))) = chart {
        write_file(&path, &bytes)?;
        println!(
            "{metric} against the swept values drawn in {}",
            path.display()
        );
    }
    Ok(())
}

/// `worlds` as GPU batches of at most [`gpu_batch_worlds`] worlds, each frame
/// one step of every world of a batch; `Ok(None)` after a notice when the
/// worlds cannot share a GPU batch (then they run one backend each, with
/// the same results).
fn run_batched(
    sweep: &Sweep,
    worlds: std::ops::Range<usize>,
    args: &SweepArgs,
    precision: Precision,
    bar: &ProgressBar,
) -> Result<Option<Vec<Finished>>, CliError> {
    let ids: Vec<usize> = worlds.collect();
    let mut out = Vec::with_capacity(ids.len());
    let first = ids.first().map(|&w| sweep.scene(w)).transpose();
    let first = first.map_err(|e| CliError::Input(e.to_string()))?;
    let per_batch = first.as_ref().map_or(1, gpu_batch_worlds);
    for group in ids.chunks(per_batch) {
        let scenes = group
            .iter()
            .map(|&w| sweep.scene(w))
            .collect::<Result<Vec<Scene>, _>>()
            .map_err(|e| CliError::Input(e.to_string()))?;
        let batch = Batch::new(&scenes).and_then(|b| {
            super::software_threads::choose_for_batch(b.plan(0), b.len(), precision);
            GpuBatch::new(&b, precision)
        });
        let mut gpu = match batch {
            Ok(gpu) => gpu,
            Err(e) => {
                // Named by the world's index in the sweep, not in the batch.
                let why = match e {
                    BatchError::Backend { world, source } => {
                        format!("worlds[{}]: {source}", group[world])
                    }
                    BatchError::Topology { world, field, what } => BatchError::Topology {
                        world: group[world],
                        field,
                        what,
                    }
                    .to_string(),
                    BatchError::Scene { world, source } => BatchError::Scene {
                        world: group[world],
                        source,
                    }
                    .to_string(),
                    other @ (BatchError::Empty
                    | BatchError::Device { .. }
                    | BatchError::Threads { .. }) => other.to_string(),
                };
                eprintln!("sweep: the worlds run one GPU backend each: {why}");
                return Ok(None);
            }
        };
        let mut last: Vec<Option<StepReport>> = vec![None; group.len()];
        for frame in 1..=args.frames {
            let reports = gpu.step().map_err(|e| {
                CliError::Simulation(match &e {
                    BatchError::Backend { world, source } => format!(
                        "worlds[{}] frame {frame}: {}",
                        group[*world],
                        with_sources(source)
                    ),
                    other => format!("frame {frame}: {}", with_sources(other)),
                })
            })?;
            for (slot, report) in last.iter_mut().zip(reports) {
                *slot = Some(report);
            }
            bar.inc(group.len() as u64);
        }
        let states = gpu
            .read_states()
            .map_err(|e| CliError::Simulation(with_sources(&e)))?;
        for (k, state) in states.iter().enumerate() {
            let report = last[k].as_ref();
            out.push(Finished {
                line: world_line(sweep, group[k], state, report).to_string(),
                backend: format!("gpu-{precision}, {} worlds per batch", group.len()),
                metric: args.plot.map(|m| m.value(&scenes[k], state, report)),
            });
        }
    }
    Ok(Some(out))
}

/// What one world left: its JSON line, the backend's name, the `--plot`
/// metric (when plotting).
struct Finished {
    line: String,
    backend: String,
    metric: Option<f64>,
}

/// The `--plot` chart of `metrics` (one per world of `worlds`) and where
/// it goes: OUT with its extension replaced by `METRIC.png`.
fn chart(
    sweep: &Sweep,
    worlds: std::ops::Range<usize>,
    metrics: &[f64],
    metric: Metric,
    out: &std::path::Path,
) -> Result<(PathBuf, Vec<u8>), CliError> {
    let axes = sweep.axes();
    let last = axes.len() - 1;
    let mut series: Vec<Series> = Vec::new();
    for (world, &value) in worlds.zip(metrics) {
        let settings = sweep.settings(world);
        let name = if last == 0 {
            metric.to_string()
        } else {
            format!("{} = {}", settings[0].0, settings[0].1)
        };
        if series.last().is_none_or(|s| s.name != name) {
            series.push(Series {
                name,
                points: Vec::new(),
            });
        }
        if let Some(s) = series.last_mut() {
            s.points.push((settings[last].1, value));
        }
    }
    let title = format!("{metric} after the sweep");
    let bytes = line_chart(
        &title,
        axes[last].path.as_str(),
        metric.name(),
        &series,
        metric.logarithmic(),
    )
    .map_err(|e| CliError::Output(format!("--plot {metric}: {e}")))?;
    Ok((out.with_extension(format!("{metric}.png")), bytes))
}

/// Progress over worlds × frames, on a terminal only.
fn progress(total: u64) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(total);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} world-frames {elapsed} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// The JSON line of one world (see the module docs).
fn world_line(sweep: &Sweep, world: usize, state: &State, report: Option<&StepReport>) -> Value {
    let mut set = Map::new();
    for (path, value) in sweep.settings(world) {
        set.insert(path.to_string(), json!(value));
    }
    let report = report.map_or(Value::Null, |r| {
        json!({
            "max_violation": r.max_violation(),
            "residuals": r.residuals.iter().map(|f| json!({
                "label": f.label,
                "max_violation": f.max_violation,
            })).collect::<Vec<_>>(),
            "active_contacts": r.active_contacts,
            "threads": r.threads,
        })
    });
    json!({
        "world": world,
        "set": set,
        "positions": rows(state, &state.positions),
        "velocities": rows(state, &state.velocities),
        "report": report,
    })
}
