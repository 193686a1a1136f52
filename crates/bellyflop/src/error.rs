//! Typed errors for bad input. Each message names the field, the value and the allowed range.

use thiserror::Error;

/// Input that cannot describe a landing problem. Nothing is solved.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum InputError {
    /// The TOML text does not parse, or a field has the wrong type or is unknown.
    #[error("scenario TOML, line {line}, column {column}: {message}")]
    Toml {
        line: usize,
        column: usize,
        message: String,
    },
    /// A scenario file could not be read.
    #[error("cannot read scenario file {path}: {message}")]
    Io { path: String, message: String },
    /// A number is outside its allowed range (NaN and infinities included).
    #[error("{field} = {value} is out of range: allowed {allowed}")]
    OutOfRange {
        field: String,
        value: f64,
        allowed: String,
    },
    /// Two fields contradict each other (e.g. T_min > T_max).
    #[error("{field} = {value} is inconsistent: {reason}")]
    Inconsistent {
        field: String,
        value: f64,
        reason: String,
    },
}

impl InputError {
    /// Wrap a TOML error with the 1-based line and column it points at.
    pub fn toml(text: &str, err: toml::de::Error) -> Self {
        let (line, column) = match err.span() {
            Some(span) => {
                let before = &text[..span.start.min(text.len())];
                let line = before.matches('\n').count() + 1;
                let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
                (line, column)
            }
            None => (0, 0),
        };
        InputError::Toml {
            line,
            column,
            message: err.message().to_string(),
        }
    }
}

/// Parse TOML text into `T`; a syntax or type error gives its line and column.
pub(crate) fn parse_toml<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, InputError> {
    toml::from_str(text).map_err(|e| InputError::toml(text, e))
}

/// Read a text file; a failure names the path.
pub(crate) fn read_text(path: &std::path::Path) -> Result<String, InputError> {
    std::fs::read_to_string(path).map_err(|e| InputError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })
}
