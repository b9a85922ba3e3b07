//! numpy in and out: `(particles, dim)` float64 arrays <-> the flat
//! row-major vectors of hyperpbd's `State` (`x[i * dim + a]`).
//!
//! ```text
//! out   Vec<f64> handed to numpy as the array's buffer (no second copy),
//!       viewed as (len / dim, dim)
//! in    any array-like numpy converts to float64; shape must be exactly
//!       (particles, dim) and every value finite, else ValueError naming
//!       the argument (and the first bad element as NAME[i][a])
//! ```

use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLikeDyn, PyArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// `flat` as a `(len / dim, dim)` array owning the vector's buffer.
pub fn rows<'py>(
    py: Python<'py>,
    flat: Vec<f64>,
    dim: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let n = flat.len().checked_div(dim).unwrap_or(0);
    PyArray1::from_vec(py, flat).reshape([n, dim])
}

/// `value` as a flat row-major vector, checked to be `(n, dim)` and finite.
pub fn flat_rows(name: &str, value: &Bound<'_, PyAny>, n: usize, dim: usize) -> PyResult<Vec<f64>> {
    let array = value
        .extract::<PyArrayLikeDyn<'_, f64, AllowTypeChange>>()
        .map_err(|e| {
            PyValueError::new_err(format!(
                "{name}: expected an array of shape ({n}, {dim}) of numbers ({e})"
            ))
        })?;
    let view = array.as_array();
    if view.shape() != [n, dim] {
        return Err(PyValueError::new_err(format!(
            "{name}: expected shape ({n}, {dim}) (particles, dim), got {:?}",
            view.shape()
        )));
    }
    // Logical (row-major) order whatever the memory layout.
    let flat: Vec<f64> = view.iter().copied().collect();
    if let Some(k) = flat.iter().position(|x| !x.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "{name}[{}][{}]: value {} is not finite",
            k / dim,
            k % dim,
            flat[k]
        )));
    }
    Ok(flat)
}
