//! Why writing the output files failed: shared by the writers and the plots.

use std::path::Path;

/// Why writing the output failed.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{path}: {message}")]
    Io { path: String, message: String },
    #[error("plot {path}: {message}")]
    Plot { path: String, message: String },
}

impl OutputError {
    pub fn io(path: &Path, e: impl std::fmt::Display) -> Self {
        OutputError::Io {
            path: path.display().to_string(),
            message: e.to_string(),
        }
    }

    pub fn plot(path: &Path, e: impl std::fmt::Display) -> Self {
        OutputError::Plot {
            path: path.display().to_string(),
            message: e.to_string(),
        }
    }
}
