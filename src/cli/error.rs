//! How a command fails: [`CliError`] and its exit code.
//!
//! ```text
//! 2  bad input: scene file, options, a backend that cannot run the scene
//! 3  a failed simulation (a step error), or a compare frame over its bound
//! 4  an output file that could not be written
//! ```
//! (141, a closed stdout pipe, is `broken_pipe.rs`'s.)

/// A CLI failure with its exit code.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// Bad input: scene file, options.
    #[error("{0}")]
    Input(String),
    /// The simulation failed (a step error); nothing was written.
    #[error("{0}")]
    Simulation(String),
    /// Writing output failed.
    #[error("{0}")]
    Output(String),
}

impl CliError {
    /// 2 for bad input, 3 for a failed simulation, 4 for output errors.
    pub fn exit_code(&self) -> u8 {
        match self {
            CliError::Input(_) => 2,
            CliError::Simulation(_) => 3,
            CliError::Output(_) => 4,
        }
    }
}

/// An error and every source under it, `: `-separated (a failed rollback
/// names the step failure it could not undo).
pub fn with_sources(error: &dyn std::error::Error) -> String {
    let mut text = error.to_string();
    let mut source = error.source();
    while let Some(e) = source {
        text.push_str(&format!(": {e}"));
        source = e.source();
    }
    text
}
