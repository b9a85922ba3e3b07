//! `hyperpbd.Scene`: a validated scene (JSON text, a file, or a built-in).
//!
//! ```text
//! Scene.from_json(text)   parse + validate (hyperpbd-core's JSON loader)
//! Scene.load(path)        the same from a file
//! Scene.builtin(name)     a scene of `hyperpbd scene NAME`
//! scene.to_json()         the document `hyperpbd scene NAME` writes
//! ```
//! A Scene is immutable: author a variant as JSON (json.loads /
//! json.dumps) and load it again, so every scene was validated.

use std::path::PathBuf;

use crate::errors::scene_error;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// A validated scene: particles, constraint families, obstacles and
/// solver settings in R^dim. Build one with `Scene.from_json`,
/// `Scene.load` or `Scene.builtin`; it cannot be changed afterwards
/// (edit its JSON and load that instead).
#[pyclass(frozen, module = "hyperpbd", name = "Scene")]
pub struct Scene {
    pub scene: hyperpbd::Scene,
}

#[pymethods]
impl Scene {
    /// Parses and validates a scene document (JSON text).
    ///
    /// Raises SceneError naming the offending field (`.path`), e.g.
    /// "particles[3].mass".
    #[staticmethod]
    fn from_json(py: Python<'_>, text: &str) -> PyResult<Scene> {
        hyperpbd::Scene::from_json_str(text)
            .map(|scene| Scene { scene })
            .map_err(|e| scene_error(py, &e, ""))
    }

    /// Reads, parses and validates a scene file.
    ///
    /// Raises SceneError: `.path` names the field, or is None when the
    /// file cannot be read.
    #[staticmethod]
    fn load(py: Python<'_>, path: PathBuf) -> PyResult<Scene> {
        hyperpbd::Scene::from_json_file(&path)
            .map(|scene| Scene { scene })
            .map_err(|e| {
                let prefix = match &e {
                    hyperpbd::SceneError::Io { .. } => String::new(),
                    _ => format!("{}: ", path.display()),
                };
                scene_error(py, &e, &prefix)
            })
    }

    /// A built-in scene by name (`Scene.builtin_names()` lists them):
    /// the scene `hyperpbd scene NAME` writes.
    #[staticmethod]
    fn builtin(name: &str) -> PyResult<Scene> {
        hyperpbd::scenes::by_name(name)
            .map(|scene| Scene { scene })
            .ok_or_else(|| {
                PyValueError::new_err(format!(
                    "unknown scene {name:?}; built-in scenes: {}",
                    builtin_list().join(", ")
                ))
            })
    }

    /// Names `Scene.builtin` accepts (the large ones last).
    #[staticmethod]
    fn builtin_names() -> Vec<&'static str> {
        builtin_list()
    }

    /// The scene as JSON: one particle / family / obstacle per line,
    /// f64 values that round-trip exactly.
    fn to_json(&self) -> String {
        self.scene.to_json_string() + "\n"
    }

    /// Spatial dimension N.
    #[getter]
    fn dim(&self) -> usize {
        self.scene.dim
    }

    /// Time step of one step (one frame), seconds.
    #[getter]
    fn dt(&self) -> f64 {
        self.scene.dt
    }

    /// Number of particles.
    #[getter]
    fn particle_count(&self) -> usize {
        self.scene.particles.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene(dim={}, particles={}, dt={})",
            self.scene.dim,
            self.scene.particles.len(),
            self.scene.dt
        )
    }
}

/// The built-in scenes' names, shipped ones first.
fn builtin_list() -> Vec<&'static str> {
    hyperpbd::scenes::NAMES
        .iter()
        .chain(hyperpbd::scenes::LARGE_NAMES)
        .copied()
        .collect()
}
