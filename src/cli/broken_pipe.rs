//! A closed stdout (`hyperpbd scene cloth | head -1`) ends the program
//! quietly, with the status a shell expects of a broken pipe.
//!
//! Rust ignores SIGPIPE, so writing to a pipe whose reader has gone makes
//! `println!` panic with "failed printing to stdout: Broken pipe". A C tool
//! would be killed by SIGPIPE, which a shell reports as 128 + 13 = 141.
//! This hook turns exactly that panic into a silent exit with status 141
//! (so `hyperpbd compare … | head` under `set -o pipefail` still fails:
//! the verdict was never printed in full) and leaves every other panic to
//! the default hook. Output files are unaffected: they are written to a
//! temporary name and renamed only on success.

use std::io::ErrorKind;

/// Exit status of a process killed by SIGPIPE, as shells report it.
pub const BROKEN_PIPE_STATUS: i32 = 128 + 13;

/// Installs the hook; call once at the start of `main`.
pub fn exit_141_on_broken_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let message = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if is_broken_pipe(message) {
            std::process::exit(BROKEN_PIPE_STATUS);
        }
        default(info);
    }));
}

/// True for the panic message of a print to a closed pipe.
fn is_broken_pipe(message: &str) -> bool {
    let broken = std::io::Error::from(ErrorKind::BrokenPipe)
        .to_string()
        .to_lowercase();
    message.starts_with("failed printing to std") && message.to_lowercase().contains(&broken)
}

#[cfg(test)]
mod tests {
    use super::is_broken_pipe;

    #[test]
    fn only_print_failures_on_a_broken_pipe_match() {
        assert!(is_broken_pipe(
            "failed printing to stdout: Broken pipe (os error 32)"
        ));
        assert!(!is_broken_pipe(
            "failed printing to stdout: No space left on device (os error 28)"
        ));
        assert!(!is_broken_pipe("index out of bounds"));
    }
}
