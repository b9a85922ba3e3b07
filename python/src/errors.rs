//! Rust errors as Python exceptions, keeping the Rust error's words.
//!
//! ```text
//! SceneError    (ValueError)    a scene that cannot be simulated; .path is the
//!                               offending field ("particles[3].mass"), None for
//!                               an unreadable file
//! StepError     (RuntimeError)  a step that failed; the state is exactly as
//!                               before that step
//! GpuError      (RuntimeError)  no adapter, a missing feature, device lost, out
//!                               of memory, a rollback the device could not do
//! ValueError                    a call that does not fit the simulation (wrong
//!                               shape, non-finite value, no force term)
//! ```
//! Every scene error's message is `PATH: why` (hyperpbd-core's error
//! module: the path in the JSON document's notation) except an unreadable
//! file; `.path` is that prefix.

use hyperpbd::{BackendError, SceneError as RustSceneError, with_sources};
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

create_exception!(
    hyperpbd,
    SceneError,
    PyValueError,
    "A scene that cannot be simulated. `.path` names the offending field \
     (\"particles[3].mass\", \"constraints[0].compliance\"), None when the \
     file could not be read."
);
create_exception!(
    hyperpbd,
    StepError,
    PyRuntimeError,
    "A step that could not complete (a non-finite particle, a refused \
     minimisation, a guard rejection). The simulation's state is exactly \
     as before the failed step; `.frame` is that step's number in the call."
);
create_exception!(
    hyperpbd,
    GpuError,
    PyRuntimeError,
    "The GPU could not do what was asked: no adapter, a missing feature \
     (SHADER_F64 for gpu-f64), device lost, out of memory. Never a silent \
     fallback to the CPU."
);

/// Adds the exception classes to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("SceneError", py.get_type::<SceneError>())?;
    m.add("StepError", py.get_type::<StepError>())?;
    m.add("GpuError", py.get_type::<GpuError>())?;
    Ok(())
}

/// The field a scene error names: the `PATH` of its `PATH: why` message.
fn path_of(error: &RustSceneError, message: &str) -> Option<String> {
    if let RustSceneError::Io { .. } = error {
        return None;
    }
    message.split_once(": ").map(|(path, _)| path.to_string())
}

/// `error` as `SceneError(prefix + message)` with `.path`.
pub fn scene_error(py: Python<'_>, error: &RustSceneError, prefix: &str) -> PyErr {
    let message = error.to_string();
    let path = path_of(error, &message);
    let err = SceneError::new_err(format!("{prefix}{message}"));
    // Setting an attribute on a fresh exception instance cannot fail
    // short of memory exhaustion; the message alone is still right then.
    let _ = err.value(py).setattr("path", path);
    err
}

/// A backend failure as its Python exception (see the module docs);
/// `prefix` says where (`"frame 3: "`).
pub fn backend_error(error: &BackendError, prefix: &str) -> PyErr {
    let message = format!("{prefix}{}", with_sources(error));
    match error {
        BackendError::Step(_) => StepError::new_err(message),
        BackendError::Gpu(_) | BackendError::RollbackFailed { .. } => GpuError::new_err(message),
        BackendError::InvalidCall(_) => PyValueError::new_err(message),
        // BackendError is #[non_exhaustive]: a variant added later is
        // still an exception carrying its words, never a panic.
        _ => PyRuntimeError::new_err(message),
    }
}

/// A panic caught at the boundary: an internal error, never an abort.
pub fn panic_error(payload: &(dyn std::any::Any + Send), what: &str) -> PyErr {
    let why = payload
        .downcast_ref::<&str>()
        .map(|s| (*s).to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into());
    PyRuntimeError::new_err(format!(
        "internal error in hyperpbd ({what}): {why}; this is a bug, please report it"
    ))
}
