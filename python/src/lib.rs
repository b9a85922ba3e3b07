//! `hyperpbd._native`: the Python module over the hyperpbd facade (scenes,
//! the backend factory, step reports, sweeps, the state hash). Nothing
//! here simulates: every number comes from the Rust crates.
//!
//! ```text
//! Scene        scene.rs        from_json / load / builtin / to_json
//! Simulation   simulation.rs   step (GIL released), numpy state, close
//! sweep        sweep.rs        one world per combination of values
//! exceptions   errors.rs       SceneError(ValueError), StepError, GpuError
//! ```

mod arrays;
mod errors;
mod report;
mod scene;
mod simulation;
mod sweep;

use pyo3::prelude::*;

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<scene::Scene>()?;
    m.add_class::<simulation::Simulation>()?;
    m.add_function(wrap_pyfunction!(sweep::sweep, m)?)?;
    errors::register(m)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
