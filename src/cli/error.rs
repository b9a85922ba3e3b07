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
