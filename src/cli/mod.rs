//! Subcommands and their shared plumbing.

mod broken_pipe;
mod compare;
mod describe;
mod output;
mod render;
mod run;

pub use broken_pipe::exit_141_on_broken_pipe;

use clap::{Parser, Subcommand};
use hyperpbd::{Backend, BackendKind, Plan, Scene, State};
use std::path::PathBuf;

/// hyperpbd: N-dimensional XPBD particle physics (f64 CPU golden path,
/// wgpu compute backend).
#[derive(Debug, Parser)]
#[command(name = "hyperpbd", version, about)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Simulate a JSON scene and write its final state and/or trajectory.
    Run(run::RunArgs),
    /// Print the compiled plan of a scene: stages, families, colors, counts.
    Plan {
        /// Scene file (JSON).
        scene: PathBuf,
    },
    /// List GPU adapters.
    Info,
    /// Run the built-in demo (a 32×32 cloth falling on a plane) and report.
    Demo {
        /// Frames (steps of 1/60 s) to simulate.
        #[arg(long, default_value_t = 120)]
        frames: u64,
        /// Backend: cpu, gpu (f32), gpu-f64, or auto (a hardware GPU when
        /// there is one, else the CPU, saying why).
        #[arg(long, default_value = "auto", value_parser = parse_backend)]
        backend: BackendKind,
    },
    /// Run the CPU golden path and a GPU backend side by side and print the
    /// per-frame divergence against its derived bound (exit 3 when over).
    Compare(compare::CompareArgs),
    /// Draw a run: PNG frames and an animated GIF (orthographic or
    /// perspective projection of R^N; see docs/rendering.md).
    Render(render::RenderArgs),
    /// Write a built-in scene as JSON (cloth, tesseract, chain2d, incline5d, barrier4d).
    Scene {
        /// Name of the built-in scene.
        name: String,
        /// Output file (stdout when omitted).
        #[arg(long)]
        out: Option<PathBuf>,
    },
}

/// `--backend NAME` (see [`BackendKind`]'s names).
pub fn parse_backend(name: &str) -> Result<BackendKind, String> {
    name.parse()
}

/// A CLI failure with its exit code.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// Bad input: scene file, options.
    #[error("{0}")]
    Input(String),
    /// The simulation failed (a step error); nothing was written.
    #[error("{0}")]
    Simulation(String),
    /// Writing output failed.
    #[error("{0}")]
    Output(String),
}

impl CliError {
    /// 2 for bad input, 3 for a failed simulation, 4 for output errors.
    pub fn exit_code(&self) -> u8 {
        match self {
            CliError::Input(_) => 2,
            CliError::Simulation(_) => 3,
            CliError::Output(_) => 4,
        }
    }
}

pub fn dispatch(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Run(args) => run::run(&args),
        Command::Plan { scene } => {
            let scene = load_scene(&scene)?;
            let plan = Plan::compile(&scene).map_err(|e| CliError::Input(e.to_string()))?;
            print!("{}", describe::describe(&plan));
            Ok(())
        }
        Command::Info => {
            info();
            Ok(())
        }
        Command::Demo { frames, backend } => run::demo(frames, backend),
        Command::Compare(args) => compare::compare(&args),
        Command::Render(args) => render::render(&args),
        Command::Scene { name, out } => {
            let scene = hyperpbd::scenes::by_name(&name).ok_or_else(|| {
                CliError::Input(format!(
                    "unknown scene {name:?}; built-in scenes: {}",
                    hyperpbd::scenes::NAMES.join(", ")
                ))
            })?;
            let text = scene.to_json_string() + "\n";
            match out {
                Some(path) => output::write_file(&path, text.as_bytes()),
                None => {
                    print!("{text}");
                    Ok(())
                }
            }
        }
    }
}

/// Reads and validates a scene file; errors name the field.
pub fn load_scene(path: &std::path::Path) -> Result<Scene, CliError> {
    Scene::from_json_file(path).map_err(|e| CliError::Input(format!("{}: {e}", path.display())))
}

fn info() {
    let adapters = hyperpbd::gpu::list_adapters();
    if adapters.is_empty() {
        println!(
            "no GPU adapters found (install a Vulkan driver, e.g. apt-get install mesa-vulkan-drivers libvulkan1)"
        );
    }
    for a in adapters {
        println!("{a}");
    }
    println!("CPU golden backend: cpu-f64 (always available)");
}

/// Loads `plan` on the backend `kind` names ([`hyperpbd::load`]; `auto`
/// says on stderr what it picked and why). A GPU that cannot run the plan
/// is bad input for `--backend gpu`, never a silent CPU fallback.
pub fn load_backend(
    kind: BackendKind,
    plan: Plan,
    state: &State,
) -> Result<Box<dyn Backend>, CliError> {
    hyperpbd::load(plan, state, kind).map_err(|e| match kind {
        BackendKind::Gpu(_) => CliError::Input(format!("--backend gpu: {e}")),
        _ => CliError::Input(e.to_string()),
    })
}

/// An error and every source under it, `: `-separated (a failed rollback
/// names the step failure it could not undo).
pub fn with_sources(error: &dyn std::error::Error) -> String {
    let mut text = error.to_string();
    let mut source = error.source();
    while let Some(e) = source {
        text.push_str(&format!(": {e}"));
        source = e.source();
    }
    text
}
