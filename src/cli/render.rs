//! `hyperpbd render`: PNG frames and an animated GIF of a run.
//!
//! Options are checked against the scene before anything runs (bad input
//! exits 2 and writes nothing); the run is simulated completely, then
//! framed once over all recorded snapshots and drawn (see
//! `hyperpbd-render` and docs/rendering.md).

use super::error::CliError;
use super::load::{load_backend, load_scene, parse_backend};
use super::output::write_file;
use hyperpbd::{BackendKind, Plan, Scene, State};
use hyperpbd_render::{
    ColorBy, GifEncoder, Options, RenderError, Renderer, Snapshot, View, parse_axes,
};
use std::path::{Path, PathBuf};

/// Options of `hyperpbd render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    #[command(flatten)]
    threads: super::threads::ThreadsArg,
    /// Scene file (JSON), or the name of a built-in scene (cloth,
    /// tesseract, chain2d, incline5d) when no such file exists.
    scene: String,
    /// Backend: cpu, gpu (f32), gpu-f64 or auto.
    #[arg(long, default_value = "auto", value_parser = parse_backend)]
    backend: BackendKind,
    /// Number of frames (steps of the scene's dt) to simulate.
    #[arg(long, default_value_t = 120)]
    frames: u64,
    /// Draw every K-th frame (and the initial and the last one).
    #[arg(long, default_value_t = 2)]
    every: u64,
    /// Output directory (created); default out/render/<scene name>.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Axes shown, e.g. 0,1 (horizontal, vertical) or, with --perspective,
    /// up to four: horizontal, vertical, depth, 4th. Numbers or x,y,z,w.
    /// Default: axis 0 horizontal, the up axis (opposite gravity, else 1)
    /// vertical.
    #[arg(long)]
    axes: Option<String>,
    /// Perspective camera (dim ≥ 3; dim ≥ 4 adds a 4D→3D perspective along
    /// the 4th axis) with depth shading.
    #[arg(long)]
    perspective: bool,
    /// Turn the scene in the plane of these two axes, e.g. 0,3.
    #[arg(long)]
    rotate: Option<String>,
    /// Angular speed of --rotate in rad per simulated second.
    #[arg(long, default_value_t = 0.5, requires = "rotate")]
    rotate_speed: f64,
    /// What the colours encode.
    #[arg(long, value_enum, default_value_t = ColorArg::Speed)]
    color: ColorArg,
    /// Picture width in pixels.
    #[arg(long, default_value_t = 480)]
    width: u32,
    /// Picture height in pixels.
    #[arg(long, default_value_t = 360)]
    height: u32,
    /// Perspective camera azimuth in degrees (turns about the up axis).
    #[arg(long, default_value_t = 30.0, allow_negative_numbers = true)]
    azimuth: f64,
    /// Perspective camera elevation in degrees (positive looks down).
    #[arg(long, default_value_t = 25.0, allow_negative_numbers = true)]
    elevation: f64,
    /// Smallest disc radius in pixels (particles of radius 0 get this).
    /// Default: 3.5 for at most 100 particles, else 2, scaled with the
    /// picture size.
    #[arg(long)]
    min_radius: Option<f64>,
    /// Colours per GIF frame (2..=256): fewer make a smaller file.
    #[arg(long, default_value_t = 256)]
    gif_colors: usize,
    /// Write PNGs with a palette of at most N colours (2..=256): lossy,
    /// several times smaller (docs/gallery.md uses this).
    #[arg(long)]
    png_colors: Option<usize>,
    /// Write only the animation, no PNG frames (the last frame is still
    /// written as last.png).
    #[arg(long)]
    no_frames: bool,
}

#[derive(Debug, Clone, Copy, clap::ValueEnum)]
enum ColorArg {
    /// Speed, relative to the fastest particle of the run.
    Speed,
    /// Relative constraint violation, log scale 1e-6 .. 1e-1.
    Residual,
}

/// Bad options are bad input (exit 2); encoder failures are output errors.
fn render_error(e: RenderError) -> CliError {
    match e {
        RenderError::Encode { .. } => CliError::Output(e.to_string()),
        _ => CliError::Input(e.to_string()),
    }
}

/// A scene file, or a built-in scene by name when no such file exists.
fn scene_and_name(arg: &str) -> Result<(Scene, String), CliError> {
    let path = Path::new(arg);
    if !path.exists()
        && let Some(scene) = hyperpbd::scenes::by_name(arg)
    {
        return Ok((scene, arg.to_string()));
    }
    let scene = load_scene(path)?;
    let name = path
        .file_stem()
        .map_or_else(|| "scene".to_string(), |s| s.to_string_lossy().into_owned());
    Ok((scene, name))
}

/// GIF delay for one drawn frame: the simulated time between pictures,
/// in centiseconds, at least 2.
pub fn gif_delay_cs(dt: f64, every: u64) -> u16 {
    (100.0 * dt * every as f64).round().clamp(2.0, 6000.0) as u16
}

pub fn render(args: &RenderArgs) -> Result<(), CliError> {
    args.threads.apply();
    if args.every == 0 {
        return Err(CliError::Input(
            "--every: must be at least 1 (draw every K-th frame)".into(),
        ));
    }
    for (option, value) in [
        ("--gif-colors", Some(args.gif_colors)),
        ("--png-colors", args.png_colors),
    ] {
        if let Some(colors) = value
            && !(2..=256).contains(&colors)
        {
            return Err(CliError::Input(format!(
                "{option}: {colors} colours is outside 2..=256"
            )));
        }
    }
    let (scene, name) = scene_and_name(&args.scene)?;
    let options = Options {
        width: args.width,
        height: args.height,
        axes: args
            .axes
            .as_deref()
            .map(|t| parse_axes("--axes", t))
            .transpose()
            .map_err(render_error)?,
        perspective: args.perspective,
        rotate: args
            .rotate
            .as_deref()
            .map(|t| parse_axes("--rotate", t))
            .transpose()
            .map_err(render_error)?,
        rotate_speed: args.rotate_speed,
        color: match args.color {
            ColorArg::Speed => ColorBy::Speed,
            ColorArg::Residual => ColorBy::Residual,
        },
        azimuth_deg: args.azimuth,
        elevation_deg: args.elevation,
        min_radius_px: args.min_radius,
    };
    // Checked before anything runs: bad options exit 2 and write nothing.
    let view = View::new(&scene, &options).map_err(render_error)?;
    let plan = Plan::compile(&scene).map_err(|e| CliError::Input(e.to_string()))?;
    let dt = plan.dt;
    let initial = State::from_scene(&scene);
    let mut backend = load_backend(args.backend, plan, &initial)?;

    let mut snapshots = vec![Snapshot {
        frame: 0,
        time: 0.0,
        state: initial,
    }];
    for frame in 1..=args.frames {
        backend
            .step()
            .map_err(|e| CliError::Simulation(format!("frame {frame}: {e}")))?;
        if frame % args.every == 0 || frame == args.frames {
            let state = backend
                .read_state()
                .map_err(|e| CliError::Simulation(e.to_string()))?;
            snapshots.push(Snapshot {
                frame,
                time: frame as f64 * dt,
                state,
            });
        }
    }

    let renderer = Renderer::new(&scene, view, &snapshots).map_err(render_error)?;
    let dir = args
        .out
        .clone()
        .unwrap_or_else(|| Path::new("out").join("render").join(&name));
    std::fs::create_dir_all(&dir)
        .map_err(|e| CliError::Output(format!("cannot create {}: {e}", dir.display())))?;
    let mut gif = GifEncoder::new(
        args.width,
        args.height,
        gif_delay_cs(dt, args.every),
        args.gif_colors,
    )
    .map_err(render_error)?;
    let mut last_png = Vec::new();
    for snap in &snapshots {
        let image = renderer.draw(snap).map_err(render_error)?;
        let png = match args.png_colors {
            Some(colors) => image.to_png_indexed(colors),
            None => image.to_png(),
        }
        .map_err(render_error)?;
        if !args.no_frames {
            write_file(&dir.join(format!("frame_{:05}.png", snap.frame)), &png)?;
        }
        gif.push(&image).map_err(render_error)?;
        last_png = png;
    }
    let gif_path = dir.join(format!("{name}.gif"));
    write_file(&gif_path, &gif.finish(100).map_err(render_error)?)?;
    let last_path = dir.join("last.png");
    write_file(&last_path, &last_png)?;

    println!(
        "{name}: {} frames on {}, {} pictures {}x{}",
        args.frames,
        backend.name(),
        snapshots.len(),
        args.width,
        args.height
    );
    println!("view: {}", renderer.view().describe());
    println!("framing: the bounding box of the whole run (fixed camera)");
    println!("{}", renderer.legend());
    if !args.no_frames {
        println!(
            "wrote {}/frame_NNNNN.png ({} frames)",
            dir.display(),
            snapshots.len()
        );
    }
    println!("wrote {}", last_path.display());
    println!("wrote {}", gif_path.display());
    Ok(())
}

/// Draws the last state of the demo to `path` (perspective view, framed
/// on that state).
pub fn demo_picture(scene: &Scene, last: &State, time: f64, path: &Path) -> Result<(), CliError> {
    let options = Options {
        perspective: true,
        elevation_deg: 25.0,
        ..Options::default()
    };
    let view = View::new(scene, &options).map_err(render_error)?;
    let snapshots = [Snapshot {
        frame: 0,
        time,
        state: last.clone(),
    }];
    let renderer = Renderer::new(scene, view, &snapshots).map_err(render_error)?;
    let png = renderer
        .draw(&snapshots[0])
        .and_then(|image| image.to_png())
        .map_err(render_error)?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| CliError::Output(format!("cannot create {}: {e}", dir.display())))?;
    }
    write_file(path, &png)
}
