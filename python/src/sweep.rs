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
//! gpu, …    one backend per world, in order (no GPU batching here; in f64
//!           the CLI's batches give world k bit for bit its own run)
//! ```

use std::panic::{AssertUnwindSafe, catch_unwind};

use hyperpbd::sweep::{FieldPath, SweepAxis, SweepError};
use hyperpbd::{BackendError, BackendKind, Plan, Scene as RustScene, State, StepReport};
use pyo3::exceptions::PyValueError;
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
/// SceneError naming the world and the field before anything runs.
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
                    BackendKind::Gpu(_) | BackendKind::Auto => {
                        (0..count).map(|w| run(w, threads)).collect()
                    }
                }
            }))
        })
        .map_err(|payload| panic_error(payload.as_ref(), "sweep"))?;
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
