//! The report binary takes `--threads N` like every simulating command of
//! `hyperpbd`, and refuses a zero count as a usage error (exit 2).

use std::process::{Command, Output};

fn report(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hyperpbd-report"))
        .args(args)
        .output()
        .expect("hyperpbd-report runs")
}

#[test]
fn help_lists_threads() {
    let help = report(&["--help"]);
    assert!(help.status.success());
    let text = String::from_utf8_lossy(&help.stdout);
    assert!(text.contains("--threads <N>"), "{text}");
}

#[test]
fn zero_threads_is_a_usage_error_naming_the_option() {
    let zero = report(&["--threads", "0", "--quick"]);
    assert_eq!(zero.status.code(), Some(2));
    let text = String::from_utf8_lossy(&zero.stderr);
    assert!(text.contains("--threads"), "{text}");
}
