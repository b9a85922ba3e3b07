//! A closed stdout (`hyperpbd scene cloth | head -1`) ends the program
//! quietly.
//!
//! Rust ignores SIGPIPE, so writing to a pipe whose reader has gone makes
//! `println!` panic with "failed printing to stdout: Broken pipe". The
//! reader has everything it wanted; the conventional answer (what a C tool
//! killed by SIGPIPE amounts to) is to stop without a message. This hook
//! turns exactly that panic into a silent exit with status 0 and leaves
//! every other panic to the default hook. Output files are unaffected:
//! they are written to a temporary name and renamed only on success.

use std::io::ErrorKind;

/// Installs the hook; call once at the start of `main`.
pub fn exit_quietly_on_broken_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let message = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if is_broken_pipe(message) {
            std::process::exit(0);
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
