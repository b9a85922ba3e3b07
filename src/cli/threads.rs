//! `--threads N`: how many threads the f64 CPU golden path runs on.
//!
//! ```text
//! --threads N     every CPU backend the command loads runs on N threads
//! (absent)        HYPERPBD_THREADS if set, else every core
//! ```
//! The results are the same bytes for any N (the serial schedule is the
//! definition; see hyperpbd-cpu's parallel.rs). GPU backends ignore it.

use std::num::NonZeroUsize;

/// The `--threads` option, flattened into a subcommand's arguments.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct ThreadsArg {
    /// CPU threads of the f64 golden path (default: HYPERPBD_THREADS, else
    /// every core); results are bit-identical for any count.
    #[arg(long, value_name = "N")]
    threads: Option<NonZeroUsize>,
}

impl ThreadsArg {
    /// Makes `--threads` the thread count of every CPU backend loaded from
    /// now on (nothing without the option).
    pub fn apply(self) {
        if self.threads.is_some() {
            hyperpbd_cpu::set_default_threads(self.threads);
        }
    }
}
