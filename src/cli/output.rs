//! Output files: JSON states with round-trip f64, written atomically
//! (`hyperpbd::atomic_file`: temporary file, fsync, rename) so a failed run
//! never leaves a partial file behind.

use super::error::CliError;
use hyperpbd::atomic_file::write_atomically;
use hyperpbd::{ContactForces, State};
use std::path::Path;

/// One state record: `{"time", "frames", "positions", "velocities"}`.
pub fn state_json(time: f64, frames: u64, state: &State) -> String {
    serde_json::json!({
        "time": time,
        "frames": frames,
        "positions": rows(state, &state.positions),
        "velocities": rows(state, &state.velocities),
    })
    .to_string()
}

/// One frame of contact forces: `{"frame", "time", "obstacles": [{"force",
/// "power"}], "particles"}` (round-trip f64).
pub fn forces_json(time: f64, frame: u64, forces: &ContactForces) -> String {
    let obstacles: Vec<serde_json::Value> = (0..forces.obstacle_count())
        .map(|o| {
            serde_json::json!({ "force": forces.obstacle(o), "power": forces.obstacle_power[o] })
        })
        .collect();
    let particles = chunk_rows(forces.dim, &forces.particles);
    serde_json::json!({
        "frame": frame,
        "time": time,
        "obstacles": obstacles,
        "particles": particles,
    })
    .to_string()
}

/// `flat` (positions or velocities of `state`) as one row per particle.
pub fn rows(state: &State, flat: &[f64]) -> Vec<Vec<f64>> {
    chunk_rows(state.dim, flat)
}

/// `flat` as rows of `dim` values (none for dim 0).
fn chunk_rows(dim: usize, flat: &[f64]) -> Vec<Vec<f64>> {
    if dim == 0 {
        return Vec::new();
    }
    flat.chunks(dim).map(<[f64]>::to_vec).collect()
}

/// Writes `bytes` to `path` atomically ([`write_atomically`]); a failure
/// is an output error naming the path.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    write_atomically(path, bytes)
        .map_err(|e| CliError::Output(format!("cannot write {}: {e}", path.display())))
}
