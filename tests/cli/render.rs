//! Pictures: `hyperpbd-render` and `hyperpbd render` / `hyperpbd demo`.
//!
//! - a picture has the requested size and is not blank; the ground is drawn;
//! - moving particles change the picture, a still scene does not;
//! - small goldens (tests/golden/*.png) compared with a stated pixel
//!   tolerance; regenerate with `HYPERPBD_BLESS=1 cargo test --release
//!   --test cli -- render::` and look at the new pictures before committing them;
//! - bad options exit 2 with one message naming the option, and write nothing;
//! - two renders of the same (deterministic, CPU) run are byte-identical.

use hyperpbd::{Backend, Particle, Scene, SceneBuilder};
use hyperpbd_render::{ColorBy, GifEncoder, Image, Options, Renderer, Snapshot, View};
use std::path::Path;

use super::{TempDir, assert_success, hyperpbd_in, text};

fn repo(path: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join(path)
        .to_string_lossy()
        .into_owned()
}

/// Runs `scene` on the CPU golden path, keeping frame 0 and every
/// `every`-th frame up to `frames`.
fn run(scene: &Scene, frames: u64, every: u64) -> Vec<Snapshot> {
    let mut backend = hyperpbd::cpu_backend(scene).expect("backend");
    let mut snapshots = vec![Snapshot {
        frame: 0,
        time: 0.0,
        state: backend.read_state().expect("state"),
    }];
    for frame in 1..=frames {
        backend.step().expect("step");
        if frame % every == 0 {
            snapshots.push(Snapshot {
                frame,
                time: frame as f64 * scene.dt,
                state: backend.read_state().expect("state"),
            });
        }
    }
    snapshots
}

fn render(scene: &Scene, options: &Options, snapshots: &[Snapshot]) -> Vec<Image> {
    let view = View::new(scene, options).expect("view");
    let renderer = Renderer::new(scene, view, snapshots).expect("renderer");
    snapshots
        .iter()
        .map(|s| renderer.draw(s).expect("draw"))
        .collect()
}

fn small(width: u32, height: u32) -> Options {
    Options {
        width,
        height,
        ..Options::default()
    }
}

const BACKGROUND: [u8; 4] = [248, 247, 243, 255];

fn pixels(image: &Image) -> Vec<[u8; 4]> {
    image
        .rgba()
        .chunks_exact(4)
        .map(|p| [p[0], p[1], p[2], p[3]])
        .collect()
}

fn differing_pixels(a: &Image, b: &Image) -> usize {
    pixels(a)
        .iter()
        .zip(pixels(b))
        .filter(|(p, q)| **p != *q)
        .count()
}

// ---------------------------------------------------------------- what is drawn

#[test]
fn picture_has_the_requested_size_and_is_not_blank() {
    let scene = hyperpbd::scenes::chain2d();
    let snapshots = run(&scene, 10, 10);
    for (w, h) in [(200, 150), (97, 61)] {
        let image = &render(&scene, &small(w, h), &snapshots)[1];
        assert_eq!((image.width(), image.height()), (w, h));
        let px = pixels(image);
        let drawn = px.iter().filter(|p| **p != BACKGROUND).count();
        assert!(
            drawn * 50 > px.len(),
            "{w}x{h}: only {drawn} of {} pixels differ from the background",
            px.len()
        );
        let mut colours = px.clone();
        colours.sort_unstable();
        colours.dedup();
        assert!(
            colours.len() >= 8,
            "{w}x{h}: only {} colours",
            colours.len()
        );
        assert!(px.iter().all(|p| p[3] == 255), "pictures are opaque");
    }
}

#[test]
fn ground_is_shaded_below_the_hanging_bridge() {
    // chain2d: a bridge at 1.4..2 m over the plane y = 0, which is within
    // one picture size of it, so the framing includes a strip of ground.
    let scene = hyperpbd::scenes::chain2d();
    let snapshots = run(&scene, 1, 1);
    let image = &render(&scene, &small(160, 120), &snapshots)[0];
    let bottom = image.pixel(80, 118).expect("pixel");
    let top = image.pixel(80, 1).expect("pixel");
    assert_eq!(top, BACKGROUND, "sky above the bridge");
    assert_eq!(
        bottom,
        [214, 208, 196, 255],
        "shaded half-space below the ground line"
    );
}

#[test]
fn moving_particles_change_the_picture_and_still_ones_do_not() {
    // A free particle falling under gravity, no obstacles.
    let mut b = SceneBuilder::new(2).dt(1.0 / 60.0).gravity_along(1, 9.81);
    b.particle(Particle::new(vec![0.0, 0.0], 1.0));
    b.particle(Particle::fixed(vec![1.0, 0.0]));
    let falling = b.build().expect("scene");
    let images = render(&falling, &small(120, 90), &run(&falling, 30, 10));
    for pair in images.windows(2) {
        assert!(
            differing_pixels(&pair[0], &pair[1]) > 20,
            "the falling particle moved, the picture must too"
        );
    }

    // Nothing moves without gravity: every frame is the same picture.
    let mut b = SceneBuilder::new(2).dt(1.0 / 60.0);
    b.particle(Particle::new(vec![0.0, 0.0], 1.0));
    b.particle(Particle::new(vec![1.0, 0.5], 1.0));
    let still = b.build().expect("scene");
    let images = render(&still, &small(120, 90), &run(&still, 30, 10));
    for pair in images.windows(2) {
        assert_eq!(differing_pixels(&pair[0], &pair[1]), 0);
    }

    // Turning the view moves the picture of a still scene.
    let mut b = SceneBuilder::new(4).dt(1.0 / 60.0);
    for k in 0..4 {
        let mut x = vec![0.0; 4];
        x[k] = 1.0;
        b.particle(Particle::new(x, 1.0));
    }
    let still4 = b.build().expect("scene");
    let turning = Options {
        perspective: true,
        rotate: Some(vec![0, 3]),
        rotate_speed: 1.0,
        ..small(120, 90)
    };
    let images = render(&still4, &turning, &run(&still4, 30, 15));
    assert!(differing_pixels(&images[0], &images[2]) > 20);
}

#[test]
fn residual_colouring_differs_from_speed_colouring() {
    let scene = hyperpbd::scenes::chain2d();
    let snapshots = run(&scene, 20, 20);
    let speed = &render(&scene, &small(160, 120), &snapshots)[1];
    let residual = &render(
        &scene,
        &Options {
            color: ColorBy::Residual,
            ..small(160, 120)
        },
        &snapshots,
    )[1];
    assert!(differing_pixels(speed, residual) > 50);
}

// ---------------------------------------------------------------- goldens

/// Pixel tolerance of the goldens. The physics (CPU f64) is bit-identical
/// everywhere; the rasteriser is not quite: tiny-skia's SIMD and scalar
/// pipelines (and f32 rounding on other targets) may move the coverage of
/// anti-aliased edge pixels by a few levels. So a pixel matches when every
/// channel is within `CHANNEL_TOLERANCE` of the golden, and at most
/// `MISMATCH_FRACTION` of the pixels may not match. A real change (a moved
/// particle, a missing edge, another colour) breaks far more.
const CHANNEL_TOLERANCE: u8 = 24;
const MISMATCH_FRACTION: f64 = 0.005;

fn check_golden(name: &str, image: &Image) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(format!("{name}.png"));
    let bless = "HYPERPBD_BLESS=1 cargo test --release --test cli -- render::";
    if std::env::var_os("HYPERPBD_BLESS").is_some_and(|v| v == "1") {
        std::fs::create_dir_all(path.parent().expect("parent")).expect("create tests/golden");
        std::fs::write(&path, image.to_png().expect("png")).expect("write golden");
        eprintln!("blessed {}", path.display());
        return;
    }
    let actual = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{name}.actual.png"));
    let bytes = std::fs::read(&path).unwrap_or_else(|e| {
        panic!(
            "golden {} is missing ({e}); create it with `{bless}` and look at it first",
            path.display()
        )
    });
    let golden = Image::from_png(&bytes).expect("decode golden");
    assert_eq!(
        (golden.width(), golden.height()),
        (image.width(), image.height()),
        "golden {} has another size; regenerate it with `{bless}`",
        path.display()
    );
    let mismatched = pixels(&golden)
        .iter()
        .zip(pixels(image))
        .filter(|(g, a)| {
            g.iter()
                .zip(a)
                .any(|(x, y)| x.abs_diff(*y) > CHANNEL_TOLERANCE)
        })
        .count();
    let total = pixels(image).len();
    let fraction = mismatched as f64 / total as f64;
    println!(
        "{name}: {mismatched} of {total} pixels beyond ±{CHANNEL_TOLERANCE} per channel: {:.4} % / bound {:.4} %",
        100.0 * fraction,
        100.0 * MISMATCH_FRACTION
    );
    if fraction > MISMATCH_FRACTION {
        std::fs::write(&actual, image.to_png().expect("png")).expect("write actual");
        panic!(
            "{name}: {mismatched} of {total} pixels ({:.3} %) differ from {} by more than {CHANNEL_TOLERANCE}/255 \
             in some channel (bound {:.3} %). The new picture is {}. If the change is intended \
             (drawing or physics changed), look at it, then regenerate the golden with `{bless}`.",
            100.0 * fraction,
            path.display(),
            100.0 * MISMATCH_FRACTION,
            actual.display()
        );
    }
}

#[test]
fn golden_example_orthographic_residual() {
    // The example scene (a pendulum, a triangle, a tetrahedron, a plane
    // with friction) falls and swings: frame 15 differs from frame 30 in
    // several % of the pixels, far beyond the tolerance.
    let scene = Scene::from_json_file(Path::new(&repo("scenes/example.json"))).expect("scene");
    let options = Options {
        color: ColorBy::Residual,
        ..small(160, 120)
    };
    let snapshots = run(&scene, 30, 15);
    let images = render(&scene, &options, &snapshots);
    check_golden("example_frame30", &images[2]);
}

#[test]
fn golden_tesseract_perspective_turning() {
    let scene = hyperpbd::scenes::tesseract();
    let options = Options {
        perspective: true,
        rotate: Some(vec![0, 2]),
        rotate_speed: 0.8,
        ..small(160, 120)
    };
    let snapshots = run(&scene, 30, 15);
    let images = render(&scene, &options, &snapshots);
    check_golden("tesseract_frame30", &images[2]);
}

// ---------------------------------------------------------------- determinism

#[test]
fn same_run_same_bytes() {
    let scene = hyperpbd::scenes::tesseract();
    let options = Options {
        perspective: true,
        rotate: Some(vec![0, 2]),
        ..small(120, 90)
    };
    let a = render(&scene, &options, &run(&scene, 6, 3));
    let b = render(&scene, &options, &run(&scene, 6, 3));
    let encode = |images: &[Image]| {
        let mut gif = GifEncoder::new(120, 90, 5, 64).expect("gif");
        for image in images {
            gif.push(image).expect("push");
        }
        let pngs: Vec<Vec<u8>> = images.iter().map(|i| i.to_png().expect("png")).collect();
        (pngs, gif.finish(50).expect("finish"))
    };
    assert!(encode(&a) == encode(&b), "PNG and GIF bytes must repeat");

    // The whole command, twice.
    let dir = TempDir::new("twice");
    let scene_file = repo("scenes/chain2d.json");
    for out in ["a", "b"] {
        let o = hyperpbd_in(
            &dir.0,
            [
                "render",
                &scene_file,
                "--backend",
                "cpu",
                "--frames",
                "8",
                "--every",
                "4",
                "--width",
                "96",
                "--height",
                "72",
                "--out",
                out,
            ],
        );
        assert_success(&o);
    }
    let mut names: Vec<String> = std::fs::read_dir(dir.path("a"))
        .expect("read a")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "chain2d.gif",
            "frame_00000.png",
            "frame_00004.png",
            "frame_00008.png",
            "last.png"
        ]
    );
    for name in &names {
        let a = std::fs::read(dir.path("a").join(name)).expect("read");
        let b = std::fs::read(dir.path("b").join(name)).expect("read");
        assert!(a == b, "{name} differs between two renders of the same run");
    }
}

// ---------------------------------------------------------------- the command

#[test]
fn render_command_writes_frames_and_an_animation() {
    let dir = TempDir::new("cli");
    let out = hyperpbd_in(
        &dir.0,
        [
            "render",
            &repo("scenes/tesseract.json"),
            "--backend",
            "cpu",
            "--frames",
            "5",
            "--every",
            "2",
            "--perspective",
            "--rotate",
            "x,w",
            "--width",
            "64",
            "--height",
            "48",
            "--color",
            "residual",
            "--out",
            "pictures",
        ],
    );
    assert_success(&out);
    let stdout = text(&out.stdout);
    assert!(stdout.contains("perspective"), "{stdout}");
    assert!(stdout.contains("turning in plane 0,3"), "{stdout}");
    // Frames 0, 2, 4 and the last one, 5.
    for frame in [0, 2, 4, 5] {
        let path = dir.path(&format!("pictures/frame_{frame:05}.png"));
        let image = Image::from_png(&std::fs::read(&path).expect("frame written")).expect("png");
        assert_eq!((image.width(), image.height()), (64, 48));
    }
    assert_eq!(
        std::fs::read(dir.path("pictures/last.png")).expect("last"),
        std::fs::read(dir.path("pictures/frame_00005.png")).expect("frame 5")
    );
    let gif = std::fs::read(dir.path("pictures/tesseract.gif")).expect("gif written");
    assert_eq!(&gif[..6], b"GIF89a");
    assert_eq!(u16::from_le_bytes([gif[6], gif[7]]), 64);
    assert_eq!(u16::from_le_bytes([gif[8], gif[9]]), 48);
    // No temporary files left behind.
    let leftovers: Vec<_> = std::fs::read_dir(dir.path("pictures"))
        .expect("dir")
        .map(|e| e.expect("entry").file_name())
        .filter(|n| n.to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");

    // A built-in scene by name, default output directory.
    let out = hyperpbd_in(
        &dir.0,
        [
            "render",
            "chain2d",
            "--backend",
            "cpu",
            "--frames",
            "2",
            "--no-frames",
        ],
    );
    assert_success(&out);
    assert!(dir.path("out/render/chain2d/chain2d.gif").is_file());
    assert!(dir.path("out/render/chain2d/last.png").is_file());
    assert!(!dir.path("out/render/chain2d/frame_00000.png").exists());
}

#[test]
fn demo_writes_a_picture_of_its_last_frame() {
    let dir = TempDir::new("demo");
    let out = hyperpbd_in(&dir.0, ["demo", "--frames", "3", "--backend", "cpu"]);
    assert_success(&out);
    let stdout = text(&out.stdout);
    assert!(stdout.contains("out/demo.png"), "{stdout}");
    let image =
        Image::from_png(&std::fs::read(dir.path("out/demo.png")).expect("demo.png")).expect("png");
    assert_eq!((image.width(), image.height()), (480, 360));
}

#[test]
fn bad_options_exit_2_and_write_nothing() {
    let dir = TempDir::new("bad");
    let line = r#"{"dim": 1, "dt": 0.01, "particles": [{"position": [0.0], "mass": 1.0}]}"#;
    std::fs::write(dir.path("line.json"), line).expect("write");
    let cloth = repo("scenes/cloth.json");
    let chain = repo("scenes/chain2d.json");
    let line = dir.path("line.json").to_string_lossy().into_owned();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec![&cloth, "--axes", "0,q"], "--axes: unknown axis \"q\""),
        (
            vec![&cloth, "--axes", "0,3"],
            "--axes: axis 3 in 0,3 is out of range: the scene has dim 3",
        ),
        (
            vec![&cloth, "--axes", "1,1"],
            "--axes: axis 1 appears twice",
        ),
        (
            vec![&cloth, "--axes", "0,1,2"],
            "--axes: 0,1,2: an orthographic view takes exactly 2 axes",
        ),
        (
            vec![&line],
            "--axes: the scene has dim 1, but a picture needs two axes",
        ),
        (vec![&line, "--axes", "0,1"], "--axes: the scene has dim 1"),
        (vec![&cloth, "--every", "0"], "--every: must be at least 1"),
        (
            vec![&chain, "--perspective"],
            "--perspective: a perspective view needs a depth axis, so dim ≥ 3",
        ),
        (
            vec![&cloth, "--rotate", "0,0"],
            "--rotate: axis 0 appears twice",
        ),
        (
            vec![&cloth, "--rotate", "0,1,2"],
            "--rotate: 0,1,2: a rotation plane is two axes",
        ),
        (
            vec![&cloth, "--width", "3"],
            "--width: 3 pixels is outside 16..=4096",
        ),
        (
            vec![&cloth, "--gif-colors", "1"],
            "--gif-colors: 1 colours is outside 2..=256",
        ),
        (
            vec![&cloth, "--perspective", "--elevation", "95"],
            "--elevation: 95 degrees is outside -89..=89",
        ),
    ];
    for (args, message) in cases {
        let mut all = vec!["render"];
        all.extend(args.iter().copied());
        all.extend(["--backend", "cpu", "--frames", "1", "--out", "never"]);
        let out = hyperpbd_in(&dir.0, &all);
        let stderr = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{all:?}\nstderr: {stderr}");
        assert!(
            stderr.contains(message),
            "{all:?}: expected {message:?} in\n{stderr}"
        );
        assert_eq!(stderr.trim().lines().count(), 1, "one message: {stderr}");
        assert!(!dir.path("never").exists(), "{all:?} wrote output");
    }
}
