//! `--threads N` and `HYPERPBD_THREADS`, driven through the binary: the
//! thread count is reported, the state hash does not change with it, and a
//! bad count is refused naming the option or the variable (exit 2).

use std::path::Path;
use std::process::{Command, Output};

fn hyperpbd(args: &[&str], threads_variable: Option<&str>) -> Output {
    let mut command = Command::new(env!("CARGO_BIN_EXE_hyperpbd"));
    command
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .env_remove("HYPERPBD_THREADS");
    if let Some(value) = threads_variable {
        command.env("HYPERPBD_THREADS", value);
    }
    command
        .output()
        .unwrap_or_else(|e| panic!("cannot run hyperpbd: {e}"))
}

fn stdout(output: &Output) -> String {
    String::from_utf8_lossy(&output.stdout).into_owned()
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// The `state hash …` line of `hyperpbd run`.
fn hash_line(output: &Output) -> String {
    assert!(
        output.status.success(),
        "hyperpbd failed: {}",
        stderr(output)
    );
    stdout(output)
        .lines()
        .find(|l| l.starts_with("state hash"))
        .unwrap_or_else(|| panic!("no state hash in:\n{}", stdout(output)))
        .to_string()
}

#[test]
fn run_reports_the_thread_count_and_the_same_hash_for_any_count() {
    let scene = Path::new("scenes").join("sandpile2d.json");
    let scene = scene.to_str().expect("utf-8 path");
    let run = |extra: &[&str], variable: Option<&str>| {
        let mut args = vec!["run", scene, "--backend", "cpu", "--frames", "10"];
        args.extend_from_slice(extra);
        hyperpbd(&args, variable)
    };
    let one = run(&["--threads", "1"], None);
    assert!(stdout(&one).contains("cpu threads 1"), "{}", stdout(&one));
    let three = run(&["--threads", "3"], None);
    assert!(
        stdout(&three).contains("cpu threads 3"),
        "{}",
        stdout(&three)
    );
    let from_variable = run(&[], Some("2"));
    assert!(
        stdout(&from_variable).contains("cpu threads 2"),
        "{}",
        stdout(&from_variable)
    );
    // --threads wins over the variable.
    let both = run(&["--threads", "1"], Some("4"));
    assert!(stdout(&both).contains("cpu threads 1"), "{}", stdout(&both));
    let reference = hash_line(&one);
    for other in [&three, &from_variable, &both] {
        assert_eq!(hash_line(other), reference);
    }
    eprintln!("sandpile2d, 10 frames on 1, 2, 3 threads: {reference}");
}

#[test]
fn bad_thread_counts_are_refused_by_name() {
    let scene = Path::new("scenes").join("chain2d.json");
    let scene = scene.to_str().expect("utf-8 path");
    let zero = hyperpbd(&["run", scene, "--backend", "cpu", "--threads", "0"], None);
    assert_eq!(zero.status.code(), Some(2), "{}", stderr(&zero));
    assert!(stderr(&zero).contains("--threads"), "{}", stderr(&zero));
    for bad in ["0", "many", "-3"] {
        let output = hyperpbd(&["run", scene, "--backend", "cpu"], Some(bad));
        assert_eq!(output.status.code(), Some(2), "{bad}: {}", stderr(&output));
        assert!(
            stderr(&output).contains("HYPERPBD_THREADS"),
            "{bad}: {}",
            stderr(&output)
        );
    }
}

#[test]
fn every_simulating_command_takes_threads() {
    // The accuracy report is its own binary (`hyperpbd-report`); its
    // `--threads` is checked in report/tests/cli_threads.rs.
    for command in ["run", "compare", "render", "demo", "sweep"] {
        let help = hyperpbd(&[command, "--help"], None);
        assert!(
            stdout(&help).contains("--threads <N>"),
            "`hyperpbd {command} --help` lists no --threads:\n{}",
            stdout(&help)
        );
    }
}
