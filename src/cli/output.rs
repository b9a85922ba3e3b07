//! Output files: JSON states with round-trip f64, written atomically
//! (temporary file, then rename) so a failed run never leaves a partial
//! file behind.

use super::CliError;
use hyperpbd::State;
use std::io::Write;
use std::path::{Path, PathBuf};

/// One state record: `{"time", "frames", "positions", "velocities"}`.
pub fn state_json(time: f64, frames: u64, state: &State) -> String {
    let rows = |flat: &[f64]| -> Vec<Vec<f64>> {
        if state.dim == 0 {
            return Vec::new();
        }
        flat.chunks(state.dim).map(<[f64]>::to_vec).collect()
    };
    serde_json::json!({
        "time": time,
        "frames": frames,
        "positions": rows(&state.positions),
        "velocities": rows(&state.velocities),
    })
    .to_string()
}

/// The temporary sibling of `path` used while writing.
pub fn temporary_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".tmp");
    path.with_file_name(name)
}

/// Writes `bytes` to `path` via a temporary file and a rename.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    let tmp = temporary_path(path);
    let result = std::fs::File::create(&tmp)
        .and_then(|mut f| f.write_all(bytes).and_then(|()| f.sync_all()))
        .and_then(|()| std::fs::rename(&tmp, path));
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        CliError::Output(format!("cannot write {}: {e}", path.display()))
    })
}
