//! `hyperpbd.Simulation`: one scene loaded on one backend, stepped with the
//! interpreter lock released.
//!
//! ```text
//! Simulation(scene, backend, threads)  Plan::compile + hyperpbd::load_with
//! step(frames)       frames × Backend::step, GIL released; the last report
//! positions, …       Backend::read_state, one copy into numpy
//! write_state(x, v)  checked here (shape, finite), then Backend::write_state
//! state_hash()       State::hash as `hyperpbd run` prints it ({:016x})
//! request_contact_forces(on)  Backend::request_contact_forces
//! close()            drops the backend (a GPU backend's device with it)
//! ```
//! Locking: the backend sits behind a mutex that is only ever taken with
//! the GIL released, so a thread holding the GIL never waits for a step
//! that waits for the GIL. A panic inside the crates is caught at the
//! boundary: the call raises RuntimeError and the simulation is closed
//! (its state is unknown), never an abort.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, PoisonError};

use hyperpbd::{Backend, BackendError, BackendKind, Plan, State, StepReport};
use numpy::PyArray2;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};

use crate::arrays::{flat_rows, rows};
use crate::errors::{backend_error, panic_error, scene_error};
use crate::report::report_dict;
use crate::scene::Scene;

/// A scene running on one backend. Positions and velocities come out as
/// numpy float64 arrays of shape (particles, dim), always copies.
///
/// `backend`: "auto" (a hardware GPU in f32 when one runs the scene, else
/// the CPU; `.notice` says which and why), "cpu" (the f64 golden path),
/// "gpu" (f32 kernels) or "gpu-f64". `threads`: CPU threads of the golden
/// path (None: HYPERPBD_THREADS, else every core); results are the same
/// bytes for every count. A GPU simulation owns its device until `close()`
/// (or the end of a `with` block, or garbage collection).
#[pyclass(frozen, module = "hyperpbd", name = "Simulation")]
pub struct Simulation {
    /// `None` once closed.
    backend: Mutex<Option<Box<dyn Backend + Send>>>,
    /// Frames stepped so far (readable while a step runs).
    frames: AtomicU64,
    name: String,
    notice: Option<String>,
    threads: Option<usize>,
    dim: usize,
    particles: usize,
    dt: f64,
}

/// What a call on the backend came to.
enum Outcome<R> {
    Done(R),
    Closed,
    Panicked(Box<dyn std::any::Any + Send>),
}

impl Simulation {
    /// Runs `f` on the backend with the GIL released (see the module docs).
    fn with_backend<R: Send>(
        &self,
        py: Python<'_>,
        what: &str,
        f: impl FnOnce(&mut dyn Backend) -> R + Send,
    ) -> PyResult<R> {
        let outcome = py.detach(|| {
            let mut guard = self.backend.lock().unwrap_or_else(PoisonError::into_inner);
            let Some(backend) = guard.as_mut() else {
                return Outcome::Closed;
            };
            match catch_unwind(AssertUnwindSafe(|| f(backend.as_mut()))) {
                Ok(r) => Outcome::Done(r),
                Err(payload) => {
                    *guard = None;
                    Outcome::Panicked(payload)
                }
            }
        });
        match outcome {
            Outcome::Done(r) => Ok(r),
            Outcome::Closed => Err(PyValueError::new_err(format!(
                "{what}: the simulation is closed"
            ))),
            Outcome::Panicked(payload) => Err(panic_error(payload.as_ref(), what)),
        }
    }

    fn read(&self, py: Python<'_>, what: &str) -> PyResult<State> {
        self.with_backend(py, what, |b| b.read_state())?
            .map_err(|e| backend_error(&e, &format!("{what}: ")))
    }
}

#[pymethods]
impl Simulation {
    #[new]
    #[pyo3(signature = (scene, backend = "auto", threads = None))]
    fn new(
        py: Python<'_>,
        scene: &Bound<'_, Scene>,
        backend: &str,
        threads: Option<usize>,
    ) -> PyResult<Self> {
        let kind: BackendKind = backend.parse().map_err(PyValueError::new_err)?;
        if threads == Some(0) {
            return Err(PyValueError::new_err(
                "threads: must be at least 1 (or None)",
            ));
        }
        let scene = &scene.get().scene;
        let plan = Plan::compile(scene).map_err(|e| scene_error(py, &e, ""))?;
        let (dim, particles, dt) = (plan.dim, scene.particles.len(), plan.dt);
        let state = State::from_scene(scene);
        let loaded = py
            .detach(|| {
                catch_unwind(AssertUnwindSafe(|| {
                    hyperpbd::load_with(plan, &state, kind, threads)
                }))
            })
            .map_err(|payload| panic_error(payload.as_ref(), "loading the backend"))?
            .map_err(|e| backend_error(&e, &format!("backend {kind}: ")))?;
        let name = loaded.backend.name();
        let threads = match name.starts_with("cpu") {
            true => Some(match threads {
                Some(n) => n,
                None => hyperpbd::default_threads().map_err(|e| backend_error(&e, ""))?,
            }),
            false => None,
        };
        Ok(Simulation {
            backend: Mutex::new(Some(loaded.backend)),
            frames: AtomicU64::new(0),
            name,
            notice: loaded.notice,
            threads,
            dim,
            particles,
            dt,
        })
    }

    /// Advances `frames` steps of the scene's dt with the GIL released and
    /// returns the last step's report: {"max_violation", "residuals"
    /// (per family), "active_contacts", "threads", "retries",
    /// "kernel_calls", "minimisation"}.
    ///
    /// Raises StepError when a step fails (`.frame`: its number within
    /// this call); the state is then as before that step, and the frames
    /// before it stay done.
    #[pyo3(signature = (frames = 1))]
    fn step<'py>(&self, py: Python<'py>, frames: u64) -> PyResult<Bound<'py, PyDict>> {
        if frames == 0 {
            return Err(PyValueError::new_err("frames: must be at least 1"));
        }
        let result = self.with_backend(py, "step", |b| {
            let mut last: Option<StepReport> = None;
            for k in 1..=frames {
                match b.step() {
                    Ok(report) => {
                        self.frames.fetch_add(1, Ordering::Relaxed);
                        last = Some(report);
                    }
                    Err(e) => return Err((k, e)),
                }
            }
            Ok(last.unwrap_or_default())
        })?;
        match result {
            Ok(report) => report_dict(py, &report),
            Err((k, e)) => {
                let err = backend_error(&e, &format!("frame {k}: "));
                if let BackendError::Step(_) = e {
                    // A fresh exception instance takes any attribute.
                    let _ = err.value(py).setattr("frame", k);
                }
                Err(err)
            }
        }
    }

    /// Asks every following step to report its contact forces (`on`:
    /// False stops it): the report of `step` then has "contact_forces":
    /// {"obstacles": (obstacles, dim), "particles": (particles, dim),
    /// "obstacle_power": (obstacles,)} — each obstacle's force on the
    /// particles (they press on it with the opposite), each particle's
    /// total contact force, and each obstacle's mean power into the
    /// particles (0 unless it moves), over the last frame. On a GPU a
    /// scene on the coupled implicit step raises GpuError (the XPBD step
    /// and the per-particle barrier path report them).
    #[pyo3(signature = (on = true))]
    fn request_contact_forces(&self, py: Python<'_>, on: bool) -> PyResult<()> {
        self.with_backend(py, "request_contact_forces", |b| {
            b.request_contact_forces(on)
        })?
        .map_err(|e| backend_error(&e, "request_contact_forces: "))
    }

    /// Positions, a numpy float64 array of shape (particles, dim) (a copy).
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let state = self.read(py, "positions")?;
        rows(py, state.positions, self.dim)
    }

    /// Velocities, a numpy float64 array of shape (particles, dim) (a copy).
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let state = self.read(py, "velocities")?;
        rows(py, state.velocities, self.dim)
    }

    /// (positions, velocities) from one read of the state.
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let state = self.read(py, "state")?;
        let positions = rows(py, state.positions, self.dim)?;
        let velocities = rows(py, state.velocities, self.dim)?;
        PyTuple::new(py, [positions, velocities])
    }

    /// Replaces the state. `positions` (and `velocities`, when given; else
    /// they stay) must have shape (particles, dim) and be finite: anything
    /// else raises ValueError and changes nothing.
    #[pyo3(signature = (positions, velocities = None))]
    fn write_state(
        &self,
        py: Python<'_>,
        positions: &Bound<'_, PyAny>,
        velocities: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let (n, dim) = (self.particles, self.dim);
        let positions = flat_rows("positions", positions, n, dim)?;
        let velocities = match velocities {
            Some(v) => Some(flat_rows("velocities", v, n, dim)?),
            None => None,
        };
        self.with_backend(py, "write_state", |b| {
            let velocities = match velocities {
                Some(v) => v,
                None => b.read_state()?.velocities,
            };
            b.write_state(&State {
                dim,
                positions,
                velocities,
            })
        })?
        .map_err(|e| backend_error(&e, "write_state: "))
    }

    /// Replaces the constant external forces, shape (particles, dim),
    /// finite. Only for scenes with a force term ("forces" in the scene
    /// JSON); otherwise ValueError, and nothing changes.
    fn set_forces(&self, py: Python<'_>, forces: &Bound<'_, PyAny>) -> PyResult<()> {
        let forces = flat_rows("forces", forces, self.particles, self.dim)?;
        self.with_backend(py, "set_forces", |b| b.set_forces(&forces))?
            .map_err(|e| backend_error(&e, "set_forces: "))
    }

    /// The 64-bit FNV-1a hash of the state's exact bits, as 16 hex digits:
    /// the `state hash` line `hyperpbd run` prints for the same scene,
    /// backend and frames.
    fn state_hash(&self, py: Python<'_>) -> PyResult<String> {
        Ok(format!("{:016x}", self.read(py, "state_hash")?.hash()))
    }

    /// Simulated time: frames × dt (seconds).
    #[getter]
    fn time(&self) -> f64 {
        self.frames.load(Ordering::Relaxed) as f64 * self.dt
    }

    /// Frames (steps) simulated so far.
    #[getter]
    fn frames(&self) -> u64 {
        self.frames.load(Ordering::Relaxed)
    }

    /// The backend that runs: "cpu-f64", "gpu-f32" or "gpu-f64".
    #[getter]
    fn backend(&self) -> &str {
        &self.name
    }

    /// For backend="auto": what it picked and why (the CLI's notice),
    /// e.g. "backend auto -> cpu-f64 (the f64 CPU golden path): no GPU
    /// adapter (…)". None for a named backend.
    #[getter]
    fn notice(&self) -> Option<&str> {
        self.notice.as_deref()
    }

    /// CPU threads of the golden path; None on a GPU backend.
    #[getter]
    fn threads(&self) -> Option<usize> {
        self.threads
    }

    /// Spatial dimension N.
    #[getter]
    fn dim(&self) -> usize {
        self.dim
    }

    /// Number of particles.
    #[getter]
    fn particle_count(&self) -> usize {
        self.particles
    }

    /// Time step of one frame (seconds).
    #[getter]
    fn dt(&self) -> f64 {
        self.dt
    }

    /// True after `close()`.
    #[getter]
    fn closed(&self, py: Python<'_>) -> bool {
        py.detach(|| {
            self.backend
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .is_none()
        })
    }

    /// Releases the backend (a GPU backend's device and buffers) now.
    /// Idempotent; every later call but the properties raises ValueError.
    fn close(&self, py: Python<'_>) {
        py.detach(|| {
            let backend = self
                .backend
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .take();
            drop(backend);
        });
    }

    fn __enter__(slf: Bound<'_, Self>) -> Bound<'_, Self> {
        slf
    }

    #[pyo3(signature = (*_exc))]
    fn __exit__(&self, py: Python<'_>, _exc: &Bound<'_, PyTuple>) -> bool {
        self.close(py);
        false
    }

    fn __repr__(&self) -> String {
        format!(
            "Simulation(backend={:?}, dim={}, particles={}, frames={})",
            self.name,
            self.dim,
            self.particles,
            self.frames.load(Ordering::Relaxed)
        )
    }
}
