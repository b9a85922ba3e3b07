//! Subcommands and their shared plumbing.

mod accuracy;
mod broken_pipe;
mod compare;
mod compare_barrier;
mod output;
mod render;
mod run;

pub use broken_pipe::exit_quietly_on_broken_pipe;

use clap::{Parser, Subcommand, ValueEnum};
use hyperpbd::gpu::{GpuBackend, Precision, software_threads};
use hyperpbd::{Backend, CpuBackend, Plan, Scene, State};
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
        /// Backend to use.
        #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
        backend: BackendChoice,
    },
    /// Run the CPU golden path and a GPU backend side by side and print the
    /// per-frame divergence against its derived bound (exit 3 when over).
    Compare(compare::CompareArgs),
    /// Measure what accuracy costs in time: error against wall time per
    /// backend, substeps and iterations; scaling; effect costs. Writes a
    /// markdown report with PNG figures.
    Accuracy(accuracy::AccuracyArgs),
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

/// Which backend runs the scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BackendChoice {
    /// The f64 CPU golden path.
    Cpu,
    /// The wgpu backend in f32 (an error if it cannot run).
    Gpu,
    /// The wgpu backend in f64 (needs SHADER_F64; an error if missing).
    GpuF64,
    /// A hardware GPU in f32 when one can run the scene, else the CPU,
    /// saying which and why.
    Auto,
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
            print!("{}", plan.describe());
            print_gpu_dispatches(&plan);
            Ok(())
        }
        Command::Info => {
            info();
            Ok(())
        }
        Command::Demo { frames, backend } => run::demo(frames, backend),
        Command::Compare(args) => compare::compare(&args),
        Command::Render(args) => render::render(&args),
        Command::Accuracy(args) => accuracy::accuracy(&args),
        Command::Scene { name, out } => {
            let scene = hyperpbd::scenes::by_name(&name).ok_or_else(|| {
                CliError::Input(format!(
                    "unknown scene {name:?}; built-in scenes: {}",
                    hyperpbd::scenes::NAMES.join(", ")
                ))
            })?;
            let text = scene.to_json_string() + "\n";
            match out {
                Some(path) => output::write_atomically(&path, text.as_bytes()),
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
    println!(
        "lavapipe threads: {}",
        match std::env::var(software_threads::VARIABLE) {
            Ok(value) => format!(
                "{}={value} (from the environment)",
                software_threads::VARIABLE
            ),
            Err(_) => format!(
                "chosen per scene by run, demo and render: one thread ({}=0) when the \
                 largest dispatch has fewer than {} items, lavapipe's default above; set {} \
                 to override",
                software_threads::VARIABLE,
                software_threads::CROSSOVER,
                software_threads::VARIABLE
            ),
        }
    );
}

/// `hyperpbd plan`: the GPU schedule the first adapter would run and its
/// dispatches per step.
fn print_gpu_dispatches(plan: &Plan) {
    let (software, on) = match hyperpbd::gpu::request_adapter(Precision::F32) {
        Ok((_, summary)) => (summary.device_type == "Cpu", summary.name),
        Err(_) => (false, "a hardware GPU (no adapter here)".to_string()),
    };
    match hyperpbd::gpu::dispatches_per_step(plan, software) {
        Some((mode, chosen, exact)) => println!(
            "gpu step on {on}: {} schedule, {chosen} compute dispatches per step \
             (one per kernel call: {exact})",
            mode.as_str()
        ),
        None => println!("gpu step: incremental potential, dispatched per Newton iteration"),
    }
}

/// The notice `run`, `demo` and `render` print when the GPU backend runs on
/// a software adapter: the threads it got.
fn software_notice(summary: &hyperpbd::gpu::AdapterSummary, threads: &software_threads::Threads) {
    if summary.device_type == "Cpu" {
        eprintln!("notice: {} threads: {threads}", summary.name);
    }
}

/// Sets lavapipe's threads for `plan` ([`software_threads`]) before the
/// process's first wgpu instance; the first call of the process decides.
/// Returns what the GPU backend will run with.
fn set_software_threads(plan: &Plan) -> software_threads::Threads {
    static DECIDED: std::sync::Once = std::sync::Once::new();
    DECIDED.call_once(|| {
        if let Some(value) = software_threads::Threads::for_plan(plan).wanted() {
            // SAFETY: `set_var` is unsound only while another thread reads
            // or writes the environment. The command line is single-threaded
            // up to here: it starts no threads (no rayon in core or cpu), and
            // run, demo and render reach this before creating any wgpu
            // instance, so no driver thread exists yet; `Once` makes it the
            // first and only write.
            unsafe { std::env::set_var(software_threads::VARIABLE, value) };
        }
    });
    software_threads::Threads::for_plan(plan)
}

/// Chooses and loads a backend, printing what was picked and why.
pub fn load_backend(
    choice: BackendChoice,
    plan: Plan,
    state: &State,
) -> Result<Box<dyn Backend>, CliError> {
    // lavapipe's threads follow the scene's size: decided before any
    // adapter is looked up.
    let threads = set_software_threads(&plan);
    let gpu = |plan: Plan, precision: Precision| -> Result<Box<dyn Backend>, CliError> {
        if plan.incremental_potential.is_some() {
            let b = hyperpbd::gpu::GpuBarrierBackend::new(plan, state, precision)
                .map_err(|e| CliError::Input(format!("--backend gpu: {e}")))?;
            software_notice(b.adapter(), &threads);
            return Ok(Box::new(b));
        }
        let b = GpuBackend::new(plan, state, precision)
            .map_err(|e| CliError::Input(format!("--backend gpu: {e}")))?;
        software_notice(b.adapter(), &threads);
        Ok(Box::new(b))
    };
    match choice {
        BackendChoice::Cpu => Ok(Box::new(
            CpuBackend::new(plan, state).map_err(|e| CliError::Input(e.to_string()))?,
        )),
        BackendChoice::Gpu => gpu(plan, Precision::F32),
        BackendChoice::GpuF64 => gpu(plan, Precision::F64),
        BackendChoice::Auto => {
            let why = match hyperpbd::gpu::request_adapter(Precision::F32) {
                Err(e) => format!("no GPU adapter ({e})"),
                Ok((_, summary)) if summary.device_type == "Cpu" => format!(
                    "the only adapter, {}, is a software rasteriser running on this CPU \
                     (pass --backend gpu to use it anyway)",
                    summary.name
                ),
                Ok(_) if plan.dim > hyperpbd::gpu::shader::MAX_GPU_DIM => format!(
                    "dimension {} is above the GPU kernels' limit of {}",
                    plan.dim,
                    hyperpbd::gpu::shader::MAX_GPU_DIM
                ),
                Ok((adapter, summary)) if plan.incremental_potential.is_some() => {
                    match hyperpbd::gpu::GpuBarrierBackend::with_adapter(
                        &adapter,
                        plan.clone(),
                        state,
                        Precision::F32,
                    ) {
                        Ok(b) => {
                            eprintln!("notice: backend auto -> gpu-f32 on {}", summary.name);
                            return Ok(Box::new(b));
                        }
                        Err(e) => {
                            format!("the GPU backend failed to load on {}: {e}", summary.name)
                        }
                    }
                }
                Ok((adapter, summary)) => {
                    match GpuBackend::with_adapter(&adapter, plan.clone(), state, Precision::F32) {
                        Ok(b) => {
                            eprintln!("notice: backend auto -> gpu-f32 on {}", summary.name);
                            return Ok(Box::new(b));
                        }
                        Err(e) => {
                            format!("the GPU backend failed to load on {}: {e}", summary.name)
                        }
                    }
                }
            };
            eprintln!("notice: backend auto -> cpu-f64 (the f64 CPU golden path): {why}");
            Ok(Box::new(
                CpuBackend::new(plan, state).map_err(|e| CliError::Input(e.to_string()))?,
            ))
        }
    }
}
