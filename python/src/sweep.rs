//! `hyperpbd.sweep`: one scene, numbers of it set to listed values, one
//! world per combination, the same worlds `hyperpbd sweep` runs.
//!
//! ```text
//! axes      {PATH: [v0, v1, …] or "LO:HI:COUNT", …}   PATH as errors name
//!           fields (damping.rate, obstacles[0].friction, gravity[1]);
//!           "LO:HI:COUNT" is `--set PATH=LO:HI:COUNT` (hyperpbd's SweepAxis)
//! worlds    the cartesian product, the last axis varying fastest:
//!           w = Σ_a i_a · Π_{b > a} count_b
//! world w   the scene's document with its values written in (FieldPath::set),
//!           parsed and validated like a scene file; every world is checked
//!           before any runs
//! cpu       worlds in parallel on `threads` threads, one thread each (the
//!           CLI's schedule; any count gives the same bytes)
//! gpu, …    GPU batches, as the CLI runs them (hyperpbd::batch::GpuBatch:
//!           XPBD worlds in the same dispatches, incremental-potential
//!           worlds in lockstep; world k bit for bit its own run in f64);
//!           where the worlds cannot share a batch (another topology, law
//!           or solver) a UserWarning says which world and why, and they run
//!           one backend each, in order, with the same results
//! auto      one backend per world, in order
//! ```

use std::ffi::CString;
use std::panic::{AssertUnwindSafe, catch_unwind};

use hyperpbd::batch::{Batch, BatchError, GpuBatch, gpu_batch_worlds};
use hyperpbd::sweep::{FieldPath, SweepAxis, SweepError};
use hyperpbd::{BackendError, BackendKind, Plan, Precision, Scene as RustScene, State, StepReport};
use pyo3::exceptions::{PyUserWarning, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use rayon::prelude::*;
use serde_json::Value;

use crate::arrays::rows;
use crate::errors::{SceneError, backend_error, panic_error, scene_error};
use crate::report::report_dict;
use crate::scene::Scene;

/// One swept number and its values.
struct Axis {
    path: FieldPath,
    values: Vec<f64>,
}

/// What one world left.
struct Finished {
    state: State,
    report: Option<StepReport>,
    backend: String,
}

/// A world that failed: which, and how.
struct Failed {
    world: usize,
    frame: u64,
    error: BackendError,
}

/// Runs `scene` once per combination of `axes` values for `frames`
/// frames and returns one dict per world, in world order:
/// {"world", "set" ({path: value}), "positions", "velocities" (numpy,
/// (particles, dim)), "report" (the last step's, as Simulation.step
/// returns it), "backend"}.
///
/// `axes` maps a field path ("damping.rate", "obstacles[0].friction") to a
/// list of values or to "LO:HI:COUNT" (as `hyperpbd sweep --set`); the
/// last axis varies fastest. A value that makes an invalid scene raises
/// SceneError naming the world and the field before anything runs. On a
/// GPU the worlds run as `hyperpbd sweep`'s batches; worlds that cannot
/// share one raise a UserWarning and run one backend each.
#[pyfunction]
#[pyo3(signature = (scene, axes, frames = 60, backend = "auto", threads = None))]
pub fn sweep<'py>(
    py: Python<'py>,
    scene: &Bound<'py, Scene>,
    axes: &Bound<'py, PyDict>,
    frames: u64,
    backend: &str,
    threads: Option<usize>,
) -> PyResult<Vec<Bound<'py, PyDict>>> {
    let kind: BackendKind = backend.parse().map_err(PyValueError::new_err)?;
    if threads == Some(0) {
        return Err(PyValueError::new_err(
            "threads: must be at least 1 (or None)",
        ));
    }
    let base_scene = &scene.get().scene;
    let dim = base_scene.dim;
    let axes = parse_axes(axes)?;
    let base: Value = serde_json::to_value(base_scene)
        .map_err(|e| PyValueError::new_err(format!("scene: {e}")))?;
    let count = axes
        .iter()
        .try_fold(1usize, |w, a| w.checked_mul(a.values.len()))
        .ok_or_else(|| PyValueError::new_err("the sweep has more worlds than fit in a usize"))?;
    let settings: Vec<Vec<(String, f64)>> = (0..count).map(|w| world_settings(&axes, w)).collect();
    let mut scenes = Vec::with_capacity(count);
    for (world, set) in settings.iter().enumerate() {
        let mut document = base.clone();
        for (axis, (_, value)) in axes.iter().zip(set) {
            axis.path
                .set(&mut document, dim, *value)
                .map_err(|e| sweep_error(py, &e))?;
        }
        let words = set
            .iter()
            .map(|(p, v)| format!("{p}={v}"))
            .collect::<Vec<_>>()
            .join(", ");
        let scene = RustScene::from_json_str(&document.to_string())
            .map_err(|e| scene_error(py, &e, &format!("worlds[{world}] ({words}): ")))?;
        scenes.push(scene);
    }
    let run = |world: usize, threads: Option<usize>| -> Result<Finished, Failed> {
        let failed = |frame, error| Failed {
            world,
            frame,
            error,
        };
        let scene = &scenes[world];
        // Every world was validated above; compiling it again cannot fail.
        let plan = Plan::compile(scene)
            .map_err(|e| failed(0, BackendError::InvalidCall(e.to_string())))?;
        let state = State::from_scene(scene);
        let mut backend = hyperpbd::load_with(plan, &state, kind, threads)
            .map_err(|e| failed(0, e))?
            .backend;
        let mut report = None;
        for frame in 1..=frames {
            report = Some(backend.step().map_err(|e| failed(frame, e))?);
        }
        Ok(Finished {
            state: backend.read_state().map_err(|e| failed(frames, e))?,
            report,
            backend: backend.name(),
        })
    };
    let mut notice = None;
    let results = py
        .detach(|| {
            catch_unwind(AssertUnwindSafe(|| -> Result<Vec<Finished>, Failed> {
                match kind {
                    BackendKind::Cpu => {
                        let threads = match threads {
                            Some(n) => n,
                            None => hyperpbd::default_threads().map_err(|error| Failed {
                                world: 0,
                                frame: 0,
                                error,
                            })?,
                        };
                        let pool = rayon::ThreadPoolBuilder::new()
                            .num_threads(threads)
                            .build()
                            .map_err(|e| Failed {
                                world: 0,
                                frame: 0,
                                error: BackendError::InvalidCall(format!(
                                    "cannot start {threads} threads: {e}"
                                )),
                            })?;
                        pool.install(|| {
                            (0..count)
                                .into_par_iter()
                                .map(|w| run(w, Some(1)))
                                .collect()
                        })
                    }
                    BackendKind::Gpu(precision) => match run_batched(&scenes, frames, precision)? {
                        Ok(done) => Ok(done),
                        Err(why) => {
                            notice = Some(why);
                            (0..count).map(|w| run(w, threads)).collect()
                        }
                    },
                    BackendKind::Auto => (0..count).map(|w| run(w, threads)).collect(),
                }
            }))
        })
        .map_err(|payload| panic_error(payload.as_ref(), "sweep"))?;
    if let Some(why) = notice {
        let message = format!("sweep: the worlds run one GPU backend each: {why}");
        let message = CString::new(message.replace('\0', " ")).unwrap_or_default();
        PyErr::warn(py, &py.get_type::<PyUserWarning>(), &message, 1)?;
    }
    let finished = results.map_err(|f| {
        let prefix = match f.frame {
            0 => format!("worlds[{}]: ", f.world),
            frame => format!("worlds[{}] frame {frame}: ", f.world),
        };
        backend_error(&f.error, &prefix)
    })?;
    let mut out = Vec::with_capacity(count);
    for (world, (done, set)) in finished.into_iter().zip(settings).enumerate() {
        let row = PyDict::new(py);
        row.set_item("world", world)?;
        let values = PyDict::new(py);
        for (path, value) in set {
            values.set_item(path, value)?;
        }
        row.set_item("set", values)?;
        row.set_item("positions", rows(py, done.state.positions, dim)?)?;
        row.set_item("velocities", rows(py, done.state.velocities, dim)?)?;
        match &done.report {
            Some(report) => row.set_item("report", report_dict(py, report)?)?,
            None => row.set_item("report", py.None())?,
        }
        row.set_item("backend", done.backend)?;
        out.push(row);
    }
    Ok(out)
}

/// Every world of `scenes` on the GPU in batches of at most
/// `gpu_batch_worlds` worlds, `frames` steps each, as `hyperpbd sweep`
/// runs them; `Ok(Err(why))` when the worlds cannot share a batch (why
/// names the world by its index in the sweep).
fn run_batched(
    scenes: &[RustScene],
    frames: u64,
    precision: Precision,
) -> Result<Result<Vec<Finished>, String>, Failed> {
    let mut out = Vec::with_capacity(scenes.len());
    let per_batch = scenes.first().map_or(1, gpu_batch_worlds);
    for (g, group) in scenes.chunks(per_batch).enumerate() {
        let first = g * per_batch;
        let mut gpu = match Batch::new(group).and_then(|b| GpuBatch::new(&b, precision)) {
            Ok(gpu) => gpu,
            Err(e) => return Ok(Err(in_sweep(e, first).to_string())),
        };
        let mut last = vec![None; group.len()];
        for frame in 1..=frames {
            let reports = gpu.step().map_err(|e| batch_failed(e, first, frame))?;
            for (slot, report) in last.iter_mut().zip(reports) {
                *slot = Some(report);
            }
        }
        let states = gpu
            .read_states()
            .map_err(|e| batch_failed(e, first, frames))?;
        let backend = format!("gpu-{precision}, {} worlds per batch", group.len());
        for (state, report) in states.into_iter().zip(last) {
            out.push(Finished {
                state,
                report,
                backend: backend.clone(),
            });
        }
    }
    Ok(Ok(out))
}

/// `error` of a batch whose world 0 is the sweep's world `first`, its
/// world named by its index in the sweep.
fn in_sweep(error: BatchError, first: usize) -> BatchError {
    match error {
        BatchError::Backend { world, source } => BatchError::Backend {
            world: first + world,
            source,
        },
        BatchError::Topology { world, field, what } => BatchError::Topology {
            world: first + world,
            field,
            what,
        },
        BatchError::Scene { world, source } => BatchError::Scene {
            world: first + world,
            source,
        },
        other @ (BatchError::Empty | BatchError::Device { .. } | BatchError::Threads { .. }) => {
            other
        }
    }
}

/// A batch step (or read) of frame `frame` that failed, as the failing
/// world's own run would.
fn batch_failed(error: BatchError, first: usize, frame: u64) -> Failed {
    match in_sweep(error, first) {
        BatchError::Backend { world, source } => Failed {
            world,
            frame,
            error: source,
        },
        BatchError::Device { source } => Failed {
            world: first,
            frame,
            error: source,
        },
        other => Failed {
            world: first,
            frame,
            error: BackendError::InvalidCall(other.to_string()),
        },
    }
}

/// The axes of a sweep from `{path: values or "LO:HI:COUNT"}`.
fn parse_axes(axes: &Bound<'_, PyDict>) -> PyResult<Vec<Axis>> {
    let mut out = Vec::with_capacity(axes.len());
    for (key, values) in axes.iter() {
        let path: String = key.extract()?;
        let parsed: FieldPath = path.parse().map_err(PyValueError::new_err)?;
        let values = if let Ok(range) = values.cast::<PyString>() {
            let axis: SweepAxis = format!("{path}={}", range.to_str()?)
                .parse()
                .map_err(PyValueError::new_err)?;
            (0..axis.count).map(|k| axis.value(k)).collect()
        } else {
            let values: Vec<f64> = values.extract().map_err(|e| {
                PyValueError::new_err(format!(
                    "{path}: expected a list of numbers or \"LO:HI:COUNT\" ({e})"
                ))
            })?;
            if values.is_empty() {
                return Err(PyValueError::new_err(format!("{path}: no values")));
            }
            values
        };
        out.push(Axis {
            path: parsed,
            values,
        });
    }
    Ok(out)
}

/// The (path, value) pairs of world `world`, in axis order.
fn world_settings(axes: &[Axis], world: usize) -> Vec<(String, f64)> {
    let mut rest = world;
    let mut out: Vec<(String, f64)> = axes
        .iter()
        .rev()
        .map(|axis| {
            let k = rest % axis.values.len();
            rest /= axis.values.len();
            (axis.path.to_string(), axis.values[k])
        })
        .collect();
    out.reverse();
    out
}

/// A path that leads to no number of the scene: SceneError with `.path`.
fn sweep_error(py: Python<'_>, error: &SweepError) -> PyErr {
    match error {
        SweepError::Path { path, why } => {
            let err = SceneError::new_err(format!("{path}: {why}"));
            let _ = err.value(py).setattr("path", path);
            err
        }
        SweepError::Base(e) | SweepError::World { source: e, .. } => scene_error(py, e, ""),
        SweepError::TooManyWorlds => PyValueError::new_err(error.to_string()),
    }
}
