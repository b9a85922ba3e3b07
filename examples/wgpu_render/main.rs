//! Steps a scene on the GPU backend built on this program's own wgpu
//! device and draws its particles with a wgpu render pipeline straight
//! from the backend's exported positions — no host copy of the vertex
//! data — into a PNG (headless: no window, no surface).
//!
//! ```text
//! cargo run --release --example wgpu_render -- SCENE --frames N --out FILE.png
//! ```
//! The camera is the CPU renderer's orthographic framing of the final
//! state (`hyperpbd render` draws the same view), read back once for that
//! purpose only.

mod draw;

use clap::Parser;
use hyperpbd::gpu::{GpuBackend, request_adapter, request_device};
use hyperpbd::{Backend, Plan, Precision, Scene, State};
use hyperpbd_render::{Options, Renderer, Snapshot, View};

/// Draw a scene's particles from the GPU backend's own buffers.
#[derive(Parser)]
struct Args {
    /// Scene JSON file.
    scene: std::path::PathBuf,
    /// Frames to simulate before drawing.
    #[arg(long, default_value_t = 60)]
    frames: u64,
    /// Output PNG.
    #[arg(long)]
    out: std::path::PathBuf,
    /// Picture width in pixels.
    #[arg(long, default_value_t = 480)]
    width: u32,
    /// Picture height in pixels.
    #[arg(long, default_value_t = 360)]
    height: u32,
}

fn main() {
    let args = Args::parse();
    if let Err(e) = run(&args) {
        eprintln!("error: {e}");
        std::process::exit(1);
    }
}

fn run(args: &Args) -> Result<(), String> {
    let scene = Scene::from_json_file(&args.scene).map_err(|e| e.to_string())?;
    let picture = simulate_and_draw(&scene, args.frames, (args.width, args.height))?.0;
    let file =
        std::fs::File::create(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let mut encoder =
        png::Encoder::new(std::io::BufWriter::new(file), picture.width, picture.height);
    encoder.set_color(png::ColorType::Rgba);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
    writer
        .write_image_data(&picture.rgba)
        .map_err(|e| e.to_string())?;
    writer.finish().map_err(|e| e.to_string())?;
    println!("wrote {}", args.out.display());
    Ok(())
}

/// Runs `scene` `frames` frames on gpu-f32 on a device of this program and
/// draws it; also returns the final state and the CPU renderer that framed
/// it (the test draws the same state on the CPU).
pub fn simulate_and_draw(
    scene: &Scene,
    frames: u64,
    size: (u32, u32),
) -> Result<(draw::Picture, State, Renderer), String> {
    let precision = Precision::F32;
    let (adapter, summary) = request_adapter(precision).map_err(|e| e.to_string())?;
    eprintln!("adapter: {summary}");
    let (device, queue) = request_device(&adapter, precision).map_err(|e| e.to_string())?;
    let plan = Plan::compile(scene).map_err(|e| e.to_string())?;
    let mut backend = GpuBackend::with_device(
        &adapter,
        device.clone(),
        queue.clone(),
        plan,
        &State::from_scene(scene),
        precision,
    )
    .map_err(|e| e.to_string())?;
    for _ in 0..frames {
        backend.step().map_err(|e| e.to_string())?;
    }
    // The camera frames the final state: one read-back, for the camera.
    let state = backend.read_state().map_err(|e| e.to_string())?;
    let options = Options {
        width: size.0,
        height: size.1,
        ..Options::default()
    };
    let view = View::new(scene, &options).map_err(|e| e.to_string())?;
    let snapshot = Snapshot {
        frame: frames,
        time: frames as f64 * scene.dt,
        state: state.clone(),
    };
    let renderer = Renderer::new(scene, view, &[snapshot]).map_err(|e| e.to_string())?;
    let map = renderer
        .pixel_map()
        .ok_or("the default view of this scene is not orthographic")?;
    let radii: Vec<f32> = scene
        .particles
        .iter()
        .map(|p| (p.radius * map.scale).max(map.min_radius_px) as f32)
        .collect();
    let picture = draw::draw(&device, &queue, &backend, &radii, &map, size)?;
    Ok((picture, state, renderer))
}
