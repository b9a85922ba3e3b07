//! A step's report as a Python dict.
//!
//! ```text
//! {"max_violation": float,                 max over families (0 with none)
//!  "residuals": {label: float, …},         per family, authored order
//!  "active_contacts": int,                 positive multipliers, last substep
//!  "threads": int,                         CPU threads (0 on a GPU)
//!  "retries": int,                         guard rejections retried
//!  "kernel_calls": {stage: int, …},        per stage in this step
//!  "minimisation": [{"iterations", "initial_residual", "final_residual",
//!                    "status"}, …],        barrier path, one per substep
//!  "contact_forces": {"obstacles": (O, N), "particles": (P, N),
//!                     "obstacle_power": (O,)}
//!                                          float64 arrays, only when requested
//!                                          (Simulation.request_contact_forces)
//! ```

use crate::arrays::rows;
use hyperpbd::{MinimisationStatus, StepReport};
use pyo3::intern;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};

/// `report` as a dict (see the module docs). Keys are interned: a
/// `step(frames=1)` call builds this dict every frame.
pub fn report_dict<'py>(py: Python<'py>, report: &StepReport) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    dict.set_item(intern!(py, "max_violation"), report.max_violation())?;
    let residuals = PyDict::new(py);
    for r in &report.residuals {
        residuals.set_item(&r.label, r.max_violation)?;
    }
    dict.set_item(intern!(py, "residuals"), residuals)?;
    dict.set_item(intern!(py, "active_contacts"), report.active_contacts)?;
    dict.set_item(intern!(py, "threads"), report.threads)?;
    dict.set_item(intern!(py, "retries"), report.retries())?;
    let calls = PyDict::new(py);
    for (stage, count) in &report.kernel_calls {
        calls.set_item(stage.as_str(), count)?;
    }
    dict.set_item(intern!(py, "kernel_calls"), calls)?;
    let minimisation = PyList::empty(py);
    for m in &report.minimisation {
        let entry = PyDict::new(py);
        entry.set_item(intern!(py, "iterations"), m.iterations)?;
        entry.set_item(intern!(py, "initial_residual"), m.initial_residual)?;
        entry.set_item(intern!(py, "final_residual"), m.final_residual)?;
        entry.set_item(intern!(py, "status"), status(&m.status))?;
        minimisation.append(entry)?;
    }
    dict.set_item(intern!(py, "minimisation"), minimisation)?;
    if let Some(f) = &report.contact_forces {
        let forces = PyDict::new(py);
        forces.set_item(
            intern!(py, "obstacles"),
            rows(py, f.obstacles.clone(), f.dim)?,
        )?;
        forces.set_item(
            intern!(py, "particles"),
            rows(py, f.particles.clone(), f.dim)?,
        )?;
        let power = numpy::PyArray1::from_vec(py, f.obstacle_power.clone());
        forces.set_item(intern!(py, "obstacle_power"), power)?;
        dict.set_item(intern!(py, "contact_forces"), forces)?;
    }
    Ok(dict)
}

/// How a minimisation ended, in words.
fn status(status: &MinimisationStatus) -> String {
    match status {
        MinimisationStatus::Converged => "converged".into(),
        MinimisationStatus::BudgetExhausted => "budget exhausted".into(),
        MinimisationStatus::RoundingFloor => "rounding floor".into(),
        MinimisationStatus::Refused(why) => format!("refused: {why}"),
    }
}
