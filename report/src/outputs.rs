//! The files a run writes, relative to the output directory, and how:
//! every one through [`hyperpbd::atomic_file::write_atomically`]
//! (temporary sibling, fsync, rename), its directory created first.
//!
//! ```text
//! OUT/accuracy.md                  tables, figures, headline answers
//! OUT/figures/accuracy_pareto.png  every case: error vs time, frontiers
//! OUT/figures/accuracy_cloth.png   the cloth, large, with the target line
//! OUT/figures/scaling.png          ms per step vs particles, fitted exponents
//! OUT/figures/accuracy.json        every number above (serde of Report)
//! OUT/effects.md                   the effect-cost tables
//! OUT/figures/effects.json         their numbers
//! OUT/figures/implicit.json        the implicit rows (Newton × CG budgets)
//! OUT/figures/patch.json           the patch study (patch_study.rs)
//! OUT/figures/accuracy_patch.png   its error against time, per law
//! ```

use crate::measured::AccuracyError;
use hyperpbd::atomic_file::write_atomically;
use std::path::Path;

/// Every case: error against time, frontiers.
pub const PARETO: &str = "figures/accuracy_pareto.png";
/// The cloth, large, with the target line.
pub const CLOTH: &str = "figures/accuracy_cloth.png";
/// ms per step against particles.
pub const SCALING: &str = "figures/scaling.png";
/// Every number of the report.
pub const JSON: &str = "figures/accuracy.json";
/// The accuracy report.
pub const MARKDOWN: &str = "accuracy.md";
/// The effect-cost tables.
pub const EFFECTS_MARKDOWN: &str = "effects.md";
/// Their numbers, as named from `effects.md`.
pub const EFFECTS_JSON_NAME: &str = "effects.json";
/// Their numbers.
pub const EFFECTS_JSON: &str = "figures/effects.json";

/// The implicit rows' numbers.
pub const IMPLICIT_JSON: &str = "figures/implicit.json";

/// The patch study's numbers.
pub const PATCH_JSON: &str = "figures/patch.json";
/// The patch study's figure.
pub const PATCH_PNG: &str = "figures/accuracy_patch.png";

/// Writes `bytes` to `path` atomically, creating its directory first.
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<(), AccuracyError> {
    let fail =
        |e: std::io::Error| AccuracyError::Output(format!("cannot write {}: {e}", path.display()));
    if let Some(dir) = path.parent()
        && !dir.as_os_str().is_empty()
    {
        std::fs::create_dir_all(dir).map_err(fail)?;
    }
    write_atomically(path, bytes).map_err(fail)
}
