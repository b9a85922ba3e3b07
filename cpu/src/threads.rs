//! How many threads a CPU backend runs on.
//!
//! ```text
//! CpuBackend::with_threads(plan, state, n)      n, as asked
//! CpuBackend::new(plan, state)                  default_threads():
//!   1. set_default_threads(n)                   (the CLI's --threads N)
//!   2. HYPERPBD_THREADS=n                       (environment; a positive integer)
//!   3. every core                               (std::thread::available_parallelism)
//! ```
//! The thread count changes who computes, never what: results are
//! bit-identical for every count (see `parallel.rs`).

use std::sync::atomic::{AtomicUsize, Ordering};

use hyperpbd_core::BackendError;

/// The environment variable naming the default thread count.
pub const THREADS_VARIABLE: &str = "HYPERPBD_THREADS";

/// The process-wide default set by [`set_default_threads`]; 0 when unset.
static DEFAULT_THREADS: AtomicUsize = AtomicUsize::new(0);

/// Sets the thread count of every later [`CpuBackend::new`] in this
/// process (the CLI's `--threads N`); `None` returns to the environment /
/// all-cores default. Backends already loaded keep theirs.
///
/// [`CpuBackend::new`]: crate::CpuBackend::new
pub fn set_default_threads(threads: Option<std::num::NonZeroUsize>) {
    DEFAULT_THREADS.store(threads.map_or(0, |n| n.get()), Ordering::Relaxed);
}

/// The thread count [`CpuBackend::new`](crate::CpuBackend::new) uses:
/// [`set_default_threads`], else `HYPERPBD_THREADS`, else every core.
/// A `HYPERPBD_THREADS` that is not a positive integer is an error naming
/// the variable.
pub fn default_threads() -> Result<usize, BackendError> {
    let set = DEFAULT_THREADS.load(Ordering::Relaxed);
    if set > 0 {
        return Ok(set);
    }
    match std::env::var(THREADS_VARIABLE) {
        Ok(text) => parse_threads(&text).map_err(|why| {
            BackendError::InvalidCall(format!("{THREADS_VARIABLE}={text:?}: {why}"))
        }),
        Err(std::env::VarError::NotPresent) => Ok(all_cores()),
        Err(std::env::VarError::NotUnicode(_)) => Err(BackendError::InvalidCall(format!(
            "{THREADS_VARIABLE}: not valid Unicode; expected a positive integer"
        ))),
    }
}

/// Every core this process may use (1 when unknown).
pub fn all_cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// A thread count from text: a positive integer.
pub fn parse_threads(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(0) => Err("expected a positive integer, got 0".into()),
        Ok(n) => Ok(n),
        Err(e) => Err(format!("expected a positive integer ({e})")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thread_counts_parse_as_positive_integers() {
        assert_eq!(parse_threads("8"), Ok(8));
        assert_eq!(parse_threads(" 2 "), Ok(2));
        assert!(parse_threads("0").is_err());
        assert!(parse_threads("-1").is_err());
        assert!(parse_threads("two").is_err());
        assert!(parse_threads("").is_err());
    }
}
