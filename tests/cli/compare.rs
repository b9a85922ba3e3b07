//! `hyperpbd compare`'s verdict: exit 0 when every frame is within the
//! bound, exit 3 (and an `OVER` line per offending frame) when one is not.
//!
//! A healthy GPU stays within its bound, so the over-bound path is reached
//! through the hidden `--bound-factor`, which scales every bound: at 0 any
//! nonzero f32 difference is over it. The same run at the default factor
//! must pass, so the failure is the bound's doing and nothing else's. Both
//! solvers go through the one comparison loop: XPBD (the example scene)
//! and the incremental potential (`scenes/barrier4d.json`).

use super::*;

/// Runs `compare SCENE --frames 3 --precision f32 [--bound-factor F]`.
fn compare(scene: &Path, factor: Option<&str>) -> Output {
    let mut args = vec![
        "compare".into(),
        scene.as_os_str().to_owned(),
        "--frames".into(),
        "3".into(),
        "--precision".into(),
        "f32".into(),
    ];
    if let Some(f) = factor {
        args.extend(["--bound-factor".into(), f.into()]);
    }
    hyperpbd::<_, std::ffi::OsString>(args)
}

/// The verdict of both solvers' comparisons at the true bound and at zero.
#[test]
fn compare_exits_3_on_an_over_bound_frame() {
    if adapter_or_skip("compare_exits_3_on_an_over_bound_frame", Precision::F32).is_none() {
        return;
    }
    let dir = TempDir::new("compare");
    let example = dir.write("example.json", EXAMPLE);
    let barrier = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/barrier4d.json");
    for scene in [example.as_path(), barrier.as_path()] {
        let within = compare(scene, None);
        assert_success(&within);
        assert!(
            text(&within.stdout).contains("all 3 frames within the bound"),
            "{}",
            text(&within.stdout)
        );

        let over = compare(scene, Some("0"));
        let stdout = text(&over.stdout);
        let stderr = text(&over.stderr);
        assert_eq!(over.status.code(), Some(3), "{stdout}{stderr}");
        let over_lines = stdout.lines().filter(|l| l.ends_with("OVER")).count();
        assert!(over_lines >= 1, "{stdout}");
        assert_eq!(
            stderr,
            format!("error: {over_lines} of 3 frames over the bound\n"),
            "{stdout}"
        );
        assert!(!stdout.contains("within the bound"), "{stdout}");
    }
}

/// A bound factor that is negative or not a number is bad input.
#[test]
fn compare_refuses_a_bad_bound_factor() {
    let dir = TempDir::new("compare-factor");
    let example = dir.write("example.json", EXAMPLE);
    for factor in ["-1", "NaN", "inf"] {
        let out = compare(&example, Some(factor));
        assert_eq!(out.status.code(), Some(2), "{factor}");
        assert_eq!(
            text(&out.stderr),
            "error: --bound-factor: must be finite and >= 0\n"
        );
    }
}

/// `--exact`: on lavapipe every f32 frame is the f32 reference's bit for
/// bit, and the run says so; a plan the reference does not run, or f64, is
/// refused as bad input.
#[test]
fn compare_exact_holds_the_gpu_to_the_f32_reference() {
    let Some((_, summary)) = adapter_or_skip(
        "compare_exact_holds_the_gpu_to_the_f32_reference",
        Precision::F32,
    ) else {
        return;
    };
    let dir = TempDir::new("compare-exact");
    let example = dir.write("example.json", EXAMPLE);
    let mut args: Vec<std::ffi::OsString> = vec![
        "compare".into(),
        example.as_os_str().to_owned(),
        "--frames".into(),
        "3".into(),
        "--exact".into(),
    ];
    let out = hyperpbd::<_, std::ffi::OsString>(args.clone());
    let stdout = text(&out.stdout);
    if common::exact::f32_identical(&summary) {
        assert_success(&out);
        assert!(
            stdout.contains("f32 reference: the GPU matched it bit for bit in 3 of 3 frames"),
            "{stdout}"
        );
    } else {
        // Another adapter may contract: the reference column says by how much.
        println!("{stdout}");
    }
    args.extend(["--precision".into(), "f64".into()]);
    let out = hyperpbd::<_, std::ffi::OsString>(args);
    assert_eq!(out.status.code(), Some(2));
    assert!(text(&out.stderr).contains("--exact: needs --precision f32"));
}
