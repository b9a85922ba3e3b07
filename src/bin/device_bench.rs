//! The timing half of `scripts/device-check.sh`: one process, one JSON
//! object per line on stdout (`{"kind": …, …}`), each measurement the
//! median of a few timed steps after warm-up steps.
//!
//! ```text
//! step      hanging cloth n², gpu-P (fused schedule as chosen), median s per
//!           step; fit t = a + b·N over N = n² particles (least squares):
//!           a = fixed cost per step (s), 1/b = particles per second, and
//!           bytes/s = (bytes a step moves per particle) / b
//! frame     chain20 and cloth256 under each schedule (exact, fused, small),
//!           f32 and f64: s per step and dispatches per step
//! dispatch  one dependent dispatch: predict on a 64-particle cloth repeated
//!           R = 1 and R = 1 + D times in one pass and one submit;
//!           (t(1 + D) − t(1)) / D
//! batch     chain2d × W worlds (GpuBatch, f32): worlds·steps per second
//! implicit  W implicit chains (chain2d_implicit, gravity swept; GpuBatch,
//!           f32, the worlds in lockstep) against the W single runs one
//!           after another: seconds and host waits of both, and what one
//!           host wait costs, (t_alone − t_batch) / (waits_alone − waits_batch)
//! granular  pit16k (scenes::pit3d(26, 24)) and the 100k column
//!           (column3d_100k), gpu-f32: s per frame and host waits per frame
//! ```
//! `--dry` runs every row at tiny sizes (lavapipe, a few seconds);
//! `--only KIND[,KIND…]` runs some kinds. A row that cannot run (no f64, a
//! schedule the scene does not fit) is a `{"kind": "skipped", …}` line
//! naming why, never a silent omission.
//!
//! `cargo build --release --bin device_bench` (a binary of the root crate,
//! so the integration tests get a fresh one: tests/device_check.rs)

use std::time::Instant;

use hyperpbd::batch::{Batch, GpuBatch};
use hyperpbd::gpu::{GpuBackend, StepMode, XpbdOptions};
use hyperpbd::{Backend, Kernel, Plan, Precision, Scene, State, scenes};

/// Sizes of one run: full (the GPU machine) or dry (lavapipe, seconds).
struct Sizes {
    cloth: &'static [usize],
    frame_cloth: usize,
    worlds: &'static [usize],
    /// Implicit chains and frames of the implicit row.
    implicit: (usize, usize),
    pit: (usize, usize),
    column: (usize, usize),
    steps: usize,
    warmup: usize,
    repeats: u32,
}

const FULL: Sizes = Sizes {
    cloth: &[64, 128, 256, 512, 1024],
    frame_cloth: 256,
    worlds: &[16, 256, 4096],
    implicit: (16, 30),
    pit: (26, 24),
    column: (40, 64),
    steps: 15,
    warmup: 3,
    repeats: 400,
};

const DRY: Sizes = Sizes {
    cloth: &[4, 8, 12, 16],
    frame_cloth: 8,
    worlds: &[2, 4, 16],
    implicit: (2, 2),
    pit: (4, 3),
    column: (4, 4),
    steps: 3,
    warmup: 1,
    repeats: 20,
};

/// One JSON line: `kind` plus the given fields (values already JSON).
fn emit(kind: &str, fields: &[(&str, String)]) {
    let mut line = format!("{{\"kind\": \"{kind}\"");
    for (name, value) in fields {
        line += &format!(", \"{name}\": {value}");
    }
    println!("{line}}}");
}

fn text(s: &str) -> String {
    format!("{s:?}")
}

fn skipped(what: &str, why: &str) {
    emit("skipped", &[("what", text(what)), ("why", text(why))]);
}

/// Median seconds of `steps` calls of `f` after `warmup` calls.
fn median<E: std::fmt::Display>(
    warmup: usize,
    steps: usize,
    mut f: impl FnMut() -> Result<(), E>,
) -> Result<f64, String> {
    for _ in 0..warmup {
        f().map_err(|e| e.to_string())?;
    }
    let mut times = Vec::with_capacity(steps);
    for _ in 0..steps.max(1) {
        let start = Instant::now();
        f().map_err(|e| e.to_string())?;
        times.push(start.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    Ok(times[times.len() / 2])
}

fn load(
    adapter: &wgpu::Adapter,
    scene: &Scene,
    precision: Precision,
    mode: Option<StepMode>,
) -> Result<GpuBackend, String> {
    let plan = Plan::compile(scene).map_err(|e| e.to_string())?;
    let state = State::from_scene(scene);
    let options = XpbdOptions { origin: None, mode };
    GpuBackend::with_options(adapter, plan, &state, precision, options).map_err(|e| e.to_string())
}

/// Least-squares line through (x, y): (intercept, slope).
fn fit(points: &[(f64, f64)]) -> (f64, f64) {
    let n = points.len() as f64;
    let (sx, sy) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), &(x, y)| (a + x, b + y));
    let (mx, my) = (sx / n, sy / n);
    let sxx: f64 = points.iter().map(|&(x, _)| (x - mx) * (x - mx)).sum();
    let sxy: f64 = points.iter().map(|&(x, y)| (x - mx) * (y - my)).sum();
    let slope = if sxx > 0.0 { sxy / sxx } else { 0.0 };
    (my - slope * mx, slope)
}

/// Bytes a substep of the hanging cloth moves per particle, lower bound:
/// predict and velocity read and write position, previous position and
/// velocity (3 vectors of 3 reals each way) plus inverse mass; the
/// projection reads and writes positions once per colour pass.
fn bytes_per_particle(precision: Precision, substeps: u32) -> f64 {
    let real = match precision {
        Precision::F32 => 4.0,
        Precision::F64 => 8.0,
    };
    f64::from(substeps) * (2.0 * 3.0 * 3.0 * real + real + 2.0 * 3.0 * real)
}

fn step_rows(adapter: &wgpu::Adapter, sizes: &Sizes, precision: Precision) {
    let mut points = Vec::new();
    let mut substeps = 1;
    for &n in sizes.cloth {
        let scene = scenes::hanging_cloth(n);
        substeps = scene.substeps;
        let particles = (n * n) as f64;
        match load(adapter, &scene, precision, None)
            .and_then(|mut b| median(sizes.warmup, sizes.steps, || b.step().map(drop)))
        {
            Ok(t) => {
                points.push((particles, t));
                emit(
                    "step",
                    &[
                        ("precision", text(&precision.to_string())),
                        ("n", n.to_string()),
                        ("particles", particles.to_string()),
                        ("seconds", format!("{t:e}")),
                    ],
                );
            }
            Err(e) => skipped(&format!("step gpu-{precision} {n}²"), &e),
        }
    }
    if points.len() >= 2 {
        let (a, b) = fit(&points);
        let per_particle = bytes_per_particle(precision, substeps);
        emit(
            "step_fit",
            &[
                ("precision", text(&precision.to_string())),
                ("a_seconds", format!("{a:e}")),
                ("b_seconds_per_particle", format!("{b:e}")),
                (
                    "particles_per_second",
                    format!("{:e}", if b > 0.0 { 1.0 / b } else { 0.0 }),
                ),
                ("bytes_per_particle_step", format!("{per_particle}")),
                (
                    "bytes_per_second",
                    format!("{:e}", if b > 0.0 { per_particle / b } else { 0.0 }),
                ),
            ],
        );
    }
}

fn frame_rows(adapter: &wgpu::Adapter, sizes: &Sizes) {
    let mut chain = scenes::chain2d();
    chain.substeps = 10;
    let name = format!("cloth{}", sizes.frame_cloth);
    for (scene_name, scene) in [
        ("chain20", chain),
        (name.as_str(), scenes::cloth(sizes.frame_cloth)),
    ] {
        for precision in [Precision::F32, Precision::F64] {
            for mode in [StepMode::Exact, StepMode::Fused, StepMode::Small] {
                let what = format!("frame {scene_name} gpu-{precision}-{}", mode.as_str());
                match load(adapter, &scene, precision, Some(mode)).and_then(|mut b| {
                    let t = median(sizes.warmup, sizes.steps, || b.step().map(drop))?;
                    Ok((t, b.dispatches_per_step()))
                }) {
                    Ok((t, dispatches)) => emit(
                        "frame",
                        &[
                            ("scene", text(scene_name)),
                            ("precision", text(&precision.to_string())),
                            ("schedule", text(mode.as_str())),
                            ("dispatches", dispatches.to_string()),
                            ("seconds", format!("{t:e}")),
                        ],
                    ),
                    Err(e) => skipped(&what, &e),
                }
            }
        }
    }
}

fn dispatch_rows(adapter: &wgpu::Adapter, sizes: &Sizes) {
    for precision in [Precision::F32, Precision::F64] {
        let what = format!("dispatch gpu-{precision}");
        let measured =
            load(adapter, &scenes::cloth(8), precision, Some(StepMode::Exact)).and_then(|mut b| {
                b.step().map_err(|e| e.to_string())?;
                let one = median(sizes.warmup, sizes.steps, || {
                    b.repeat_kernel(Kernel::Predict, 1)
                })?;
                let many = median(sizes.warmup, sizes.steps, || {
                    b.repeat_kernel(Kernel::Predict, 1 + sizes.repeats)
                })?;
                Ok((one, many))
            });
        match measured {
            Ok((one, many)) => emit(
                "dispatch",
                &[
                    ("precision", text(&precision.to_string())),
                    ("one_submit_seconds", format!("{one:e}")),
                    ("repeats", sizes.repeats.to_string()),
                    (
                        "seconds_per_dependent_dispatch",
                        format!("{:e}", (many - one) / f64::from(sizes.repeats)),
                    ),
                ],
            ),
            Err(e) => skipped(&what, &e),
        }
    }
}

fn batch_rows(adapter: &wgpu::Adapter, sizes: &Sizes) {
    let base = scenes::chain2d();
    for &w in sizes.worlds {
        let worlds: Vec<Scene> = (0..w)
            .map(|k| {
                let mut s = base.clone();
                if let Some(g) = s.gravity.as_mut() {
                    g[0] = -1.0 + 2.0 * k as f64 / w.max(2) as f64;
                }
                s
            })
            .collect();
        let measured = Batch::new(&worlds)
            .map_err(|e| e.to_string())
            .and_then(|batch| {
                GpuBatch::on_adapter(adapter, &batch, Precision::F32).map_err(|e| e.to_string())
            })
            .and_then(|mut gpu| {
                let t = median(sizes.warmup, sizes.steps, || gpu.step().map(drop))?;
                Ok((t, gpu.dispatches_per_step()))
            });
        match measured {
            Ok((t, dispatches)) => emit(
                "batch",
                &[
                    ("scene", text("chain2d")),
                    ("worlds", w.to_string()),
                    (
                        "dispatches",
                        dispatches.map_or("none".into(), |d| d.to_string()),
                    ),
                    ("seconds", format!("{t:e}")),
                    ("world_steps_per_second", format!("{:e}", w as f64 / t)),
                ],
            ),
            Err(e) => skipped(&format!("batch chain2d × {w}"), &e),
        }
    }
}

/// The implicit row (module docs): seconds and host waits of `frames`
/// frames of W implicit chains, batched and one after another.
fn implicit_rows(adapter: &wgpu::Adapter, sizes: &Sizes) {
    let (w, frames) = sizes.implicit;
    let base = match Scene::from_json_str(include_str!("../../scenes/chain2d_implicit.json")) {
        Ok(scene) => scene,
        Err(e) => return skipped("implicit", &e.to_string()),
    };
    let worlds: Vec<Scene> = (0..w)
        .map(|k| {
            let mut s = base.clone();
            if let Some(g) = s.gravity.as_mut() {
                g[1] = -12.0 + 6.0 * k as f64 / (w.max(2) - 1) as f64;
            }
            s
        })
        .collect();
    let measured = || -> Result<[f64; 4], String> {
        let batch = Batch::new(&worlds).map_err(|e| e.to_string())?;
        let mut gpu =
            GpuBatch::on_adapter(adapter, &batch, Precision::F32).map_err(|e| e.to_string())?;
        let (mut batched, mut batch_waits) = (0.0, 0);
        for _ in 0..frames {
            let start = Instant::now();
            let reports = gpu.step().map_err(|e| e.to_string())?;
            batched += start.elapsed().as_secs_f64();
            batch_waits += reports.first().map_or(0, |r| r.host_waits);
        }
        let (mut alone, mut alone_waits) = (0.0, 0);
        for scene in &worlds {
            let plan = Plan::compile(scene).map_err(|e| e.to_string())?;
            let state = State::from_scene(scene);
            let mut b = hyperpbd::load_on_adapter(adapter, plan, &state, Precision::F32)
                .map_err(|e| e.to_string())?;
            for _ in 0..frames {
                let start = Instant::now();
                alone_waits += b.step().map_err(|e| e.to_string())?.host_waits;
                alone += start.elapsed().as_secs_f64();
            }
        }
        Ok([batched, alone, batch_waits as f64, alone_waits as f64])
    };
    match measured() {
        Ok([batched, alone, batch_waits, alone_waits]) => emit(
            "implicit",
            &[
                ("scene", text("chain2d_implicit")),
                ("worlds", w.to_string()),
                ("frames", frames.to_string()),
                ("seconds_batch", format!("{batched:e}")),
                ("seconds_alone", format!("{alone:e}")),
                ("host_waits_batch", batch_waits.to_string()),
                ("host_waits_alone", alone_waits.to_string()),
                ("batch_over_alone", format!("{:e}", batched / alone)),
                (
                    "seconds_per_wait_saved",
                    format!(
                        "{:e}",
                        (alone - batched) / (alone_waits - batch_waits).max(1.0)
                    ),
                ),
            ],
        ),
        Err(e) => skipped(&format!("implicit chain2d_implicit × {w}"), &e),
    }
}

fn granular_rows(adapter: &wgpu::Adapter, sizes: &Sizes) {
    let cases = [
        ("pit", scenes::pit3d(sizes.pit.0, sizes.pit.1)),
        ("column", scenes::column3d(sizes.column.0, sizes.column.1)),
    ];
    for (name, scene) in cases {
        let balls = scene.particles.len();
        let steps = sizes.steps.min(5);
        let measured = load(adapter, &scene, Precision::F32, None).and_then(|mut b| {
            let t = median(1, steps, || b.step().map(drop))?;
            Ok((t, b.dispatches_per_step()))
        });
        match measured {
            Ok((t, dispatches)) => emit(
                "granular",
                &[
                    ("scene", text(name)),
                    ("balls", balls.to_string()),
                    ("dispatches", dispatches.to_string()),
                    ("seconds", format!("{t:e}")),
                ],
            ),
            Err(e) => skipped(&format!("granular {name} ({balls} balls)"), &e),
        }
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dry = args.iter().any(|a| a == "--dry");
    let only: Option<Vec<String>> = args
        .iter()
        .position(|a| a == "--only")
        .and_then(|i| args.get(i + 1))
        .map(|list| list.split(',').map(str::to_owned).collect());
    let wanted = |kind: &str| only.as_ref().is_none_or(|l| l.iter().any(|k| k == kind));
    let sizes = if dry { &DRY } else { &FULL };
    let (adapter, summary) = match hyperpbd::gpu::request_adapter(Precision::F32) {
        Ok(found) => found,
        Err(e) => {
            skipped("every row", &e.to_string());
            return;
        }
    };
    let path = hyperpbd::gpu::ShaderPath::current(Precision::F32)
        .map_or_else(|e| format!("unknown ({e})"), |p| p.as_str().to_owned());
    emit(
        "adapter",
        &[
            ("name", text(&summary.name)),
            ("backend", text(&summary.backend)),
            ("f64", summary.shader_f64.to_string()),
            ("passthrough", summary.passthrough.to_string()),
            ("shader_path", text(&path)),
            ("dry", dry.to_string()),
        ],
    );
    if wanted("step") {
        step_rows(&adapter, sizes, Precision::F32);
        if summary.shader_f64 {
            step_rows(&adapter, sizes, Precision::F64);
        }
    }
    if wanted("frame") {
        frame_rows(&adapter, sizes);
    }
    if wanted("dispatch") {
        dispatch_rows(&adapter, sizes);
    }
    if wanted("batch") {
        batch_rows(&adapter, sizes);
    }
    if wanted("implicit") {
        implicit_rows(&adapter, sizes);
    }
    if wanted("granular") {
        granular_rows(&adapter, sizes);
    }
}
