//! lavapipe's worker threads (`LP_NUM_THREADS`): the rule that picks them
//! from a scene's size, and what a process runs with.
//!
//! ```text
//! measured (a standalone lavapipe micro-benchmark, docs/performance-log.md):
//!   lavapipe hands every dispatch to its worker threads: 35–63 µs each with
//!   its default (one per core), ~1 µs with LP_NUM_THREADS=0 (the work runs
//!   on the submitting thread); above ~10–15k items per dispatch the
//!   parallel workers win
//! rule:  the user's LP_NUM_THREADS, when set, is kept
//!        work < CROSSOVER  → LP_NUM_THREADS=0        (one thread)
//!        otherwise         → lavapipe's default
//! work = the largest dispatch of a step: particles, or elements of one
//!        colour ([`largest_dispatch`])
//! ```
//! Mesa reads the variable when an instance is created. This library never
//! writes the environment (`std::env::set_var` is unsound while another
//! thread may read it): a program applies [`Threads::wanted`] to its own
//! environment before its first wgpu instance — the `hyperpbd` command line
//! does, on its single thread — or the user sets `LP_NUM_THREADS`. Other
//! drivers never read it. The test suite keeps lavapipe's default, except
//! the dispatch-bound tests that run themselves again in a child process
//! on one thread (`tests/common/gpu.rs`, `on_one_lavapipe_thread`;
//! docs/performance-log.md).

use std::fmt;

use hyperpbd_core::Plan;

/// Largest dispatch (items) that runs faster on one lavapipe thread.
pub const CROSSOVER: usize = 16_384;

/// The environment variable lavapipe reads.
pub const VARIABLE: &str = "LP_NUM_THREADS";

/// lavapipe's threads for a scene: what the rule wants and what the
/// environment says.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Threads {
    /// Items of the scene's largest dispatch.
    pub work: usize,
    /// `LP_NUM_THREADS` as the environment has it now (`None`: unset).
    pub environment: Option<String>,
}

impl Threads {
    /// The rule applied to `plan` under the current environment.
    pub fn for_plan(plan: &Plan) -> Self {
        Threads {
            work: largest_dispatch(plan),
            environment: std::env::var_os(VARIABLE).map(|v| v.to_string_lossy().into_owned()),
        }
    }

    /// The value to set before the first instance: `Some("0")` (one
    /// thread) below [`CROSSOVER`] when the user set nothing, else `None`
    /// (keep the environment as it is).
    pub fn wanted(&self) -> Option<&'static str> {
        (self.environment.is_none() && self.work < CROSSOVER).then_some("0")
    }
}

impl fmt::Display for Threads {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let work = self.work;
        match &self.environment {
            Some(value) if value == "0" && work < CROSSOVER => write!(
                f,
                "{VARIABLE}=0, one thread (largest dispatch {work} items < {CROSSOVER})"
            ),
            Some(value) => write!(f, "{VARIABLE}={value} (from the environment)"),
            None if work < CROSSOVER => write!(
                f,
                "lavapipe's default threads; {VARIABLE}=0 (one thread) would suit this scene \
                 (largest dispatch {work} items < {CROSSOVER})"
            ),
            None => write!(
                f,
                "lavapipe's default threads (largest dispatch {work} items ≥ {CROSSOVER}); \
                 set {VARIABLE} to override"
            ),
        }
    }
}

/// Items of the largest dispatch of a step of `plan`: every particle (the
/// per-particle kernels) or the largest colour of a family.
pub fn largest_dispatch(plan: &Plan) -> usize {
    plan.families
        .iter()
        .flat_map(|f| (0..f.color_count()).map(|c| f.color(c).len()))
        .chain(std::iter::once(plan.particle_count()))
        .max()
        .unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_thread_only_below_the_crossover_and_never_over_the_user() {
        let t = |work, environment: Option<&str>| Threads {
            work,
            environment: environment.map(str::to_string),
        };
        assert_eq!(t(CROSSOVER - 1, None).wanted(), Some("0"));
        assert_eq!(t(CROSSOVER, None).wanted(), None);
        assert_eq!(t(10, Some("4")).wanted(), None);
        assert!(t(10, Some("4")).to_string().contains("LP_NUM_THREADS=4"));
    }
}
