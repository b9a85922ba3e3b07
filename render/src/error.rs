//! Render errors.

/// Why a picture could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// A rendering option does not fit the scene (bad axis, dimension too
    /// small, zero size, …). `option` is the command-line spelling.
    #[error("{option}: {message}")]
    Option {
        /// The option, e.g. `--axes`.
        option: &'static str,
        /// What is wrong and what would work.
        message: String,
    },
    /// A snapshot does not match the scene (dimension or particle count).
    #[error("snapshot of frame {frame}: {message}")]
    Snapshot {
        /// Frame number of the snapshot.
        frame: u64,
        /// What is wrong.
        message: String,
    },
    /// The scene itself is invalid.
    #[error("scene: {0}")]
    Scene(String),
    /// PNG or GIF encoding failed.
    #[error("encoding {format}: {message}")]
    Encode {
        /// `png` or `gif`.
        format: &'static str,
        /// The encoder's message.
        message: String,
    },
}

impl RenderError {
    pub(crate) fn option(option: &'static str, message: impl Into<String>) -> Self {
        RenderError::Option {
            option,
            message: message.into(),
        }
    }
}
