//! What every simulating command loads: a validated scene and a backend.

use super::error::CliError;
use hyperpbd::{Backend, BackendKind, Plan, Scene, State};

/// `--backend NAME` (see [`BackendKind`]'s names).
pub fn parse_backend(name: &str) -> Result<BackendKind, String> {
    name.parse()
}

/// Reads and validates a scene file; errors name the field.
pub fn load_scene(path: &std::path::Path) -> Result<Scene, CliError> {
    Scene::from_json_file(path).map_err(|e| CliError::Input(format!("{}: {e}", path.display())))
}

/// Loads `plan` on the backend `kind` names ([`hyperpbd::load`]; `auto`
/// says on stderr what it picked and why). A GPU that cannot run the plan
/// is bad input for `--backend gpu`, never a silent CPU fallback.
pub fn load_backend(
    kind: BackendKind,
    plan: Plan,
    state: &State,
) -> Result<Box<dyn Backend>, CliError> {
    if kind != BackendKind::Cpu {
        super::software_threads::choose(&plan);
        super::software_threads::notice(kind, &plan);
    }
    hyperpbd::load(plan, state, kind).map_err(|e| match kind {
        BackendKind::Gpu(_) => CliError::Input(format!("--backend gpu: {e}")),
        _ => CliError::Input(e.to_string()),
    })
}
