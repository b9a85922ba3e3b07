//! Subcommands and their shared plumbing.

mod broken_pipe;
mod compare;
mod describe;
mod error;
mod load;
mod output;
mod render;
mod run;
mod software_threads;
mod sweep;
mod threads;

pub use broken_pipe::exit_141_on_broken_pipe;
pub use error::CliError;
use load::{load_scene, parse_backend};

use clap::{Parser, Subcommand};
use hyperpbd::{BackendKind, Plan};
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
    /// Run the built-in demo (a 32×32 cloth with bending lowered by two
    /// moving hands onto a moving conveyor belt) and report.
    Demo {
        /// Frames (steps of 1/60 s) to simulate.
        #[arg(long, default_value_t = 120)]
        frames: u64,
        /// Backend: cpu, gpu (f32), gpu-f64, or auto (a hardware GPU when
        /// there is one, else the CPU, saying why).
        #[arg(long, default_value = "auto", value_parser = parse_backend)]
        backend: BackendKind,
        #[command(flatten)]
        threads: threads::ThreadsArg,
    },
    /// Run the CPU golden path and a GPU backend side by side and print the
    /// per-frame divergence against its derived bound (exit 3 when over).
    Compare(compare::CompareArgs),
    /// Draw a run: PNG frames and an animated GIF (orthographic or
    /// perspective projection of R^N; see docs/rendering.md).
    Render(render::RenderArgs),
    /// Sweep numbers of a scene over ranges (--set PATH=LO:HI:COUNT), one
    /// JSON line per world; --shard K/N runs a slice (see docs/sweeps.md).
    Sweep(sweep::SweepArgs),
    /// Write a built-in scene as JSON (cloth, tesseract, chain2d, incline5d, barrier4d).
    Scene {
        /// Name of the built-in scene.
        name: String,
        /// Output file (stdout when omitted).
        #[arg(long)]
        out: Option<PathBuf>,
    },
}
pub fn dispatch(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Run(args) => run::run(&args),
        Command::Plan { scene } => {
            let scene = load_scene(&scene)?;
            let plan = Plan::compile(&scene).map_err(|e| CliError::Input(e.to_string()))?;
            print!("{}", describe::describe(&plan));
            println!("{}", software_threads::dispatches_line(&plan));
            Ok(())
        }
        Command::Info => {
            info();
            Ok(())
        }
        Command::Demo {
            frames,
            backend,
            threads,
        } => {
            threads.apply();
            run::demo(frames, backend)
        }
        Command::Compare(args) => compare::compare(&args),
        Command::Render(args) => render::render(&args),
        Command::Sweep(args) => sweep::sweep(&args),
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
    match hyperpbd::gpu::ShaderPath::current(hyperpbd::Precision::F32) {
        Ok(path) => println!("{}", path.describe()),
        Err(e) => println!("shader path: none ({e})"),
    }
    println!("CPU golden backend: cpu-f64 (always available)");
    println!("{}", software_threads::info_line());
}
