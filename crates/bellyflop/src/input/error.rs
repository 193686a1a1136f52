//! Typed errors for bad input. Each message names the field, the value and the allowed range.

use thiserror::Error;

use crate::input::model_kind::ModelKind;

/// Which kind of input file an error is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileKind {
    /// A scenario (`Scenario`).
    Scenario,
    /// A closed-loop guidance configuration (`guidance::SimConfig`).
    GuidanceConfig,
}

impl std::fmt::Display for FileKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            FileKind::Scenario => "scenario",
            FileKind::GuidanceConfig => "guidance config",
        })
    }
}

/// Input that cannot describe a landing problem. Nothing is solved.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum InputError {
    /// The TOML text does not parse, or a field has the wrong type or is unknown.
    #[error("{kind} TOML, line {line}, column {column}: {message}")]
    Toml {
        kind: FileKind,
        line: usize,
        column: usize,
        message: String,
    },
    /// A file could not be read.
    #[error("cannot read {kind} file {path}: {message}")]
    Io {
        kind: FileKind,
        path: String,
        message: String,
    },
    /// A file is not UTF-8 text (TOML must be); `byte` is the 0-based offset
    /// of the first invalid byte, `line` and `column` (1-based, in
    /// characters) where it sits.
    #[error("{kind} file {path} is not UTF-8 text: invalid byte 0x{value:02x} at byte {byte} (line {line}, column {column})")]
    NotUtf8 {
        kind: FileKind,
        path: String,
        value: u8,
        byte: usize,
        line: usize,
        column: usize,
    },
    /// A text field is empty or blank.
    #[error("{field} must be non-empty (at least one non-blank character)")]
    Empty { field: String },
    /// A number is outside its allowed range (NaN and infinities included).
    #[error("{field} = {} is out of range: allowed {allowed}", number(*.value))]
    OutOfRange {
        field: String,
        value: f64,
        allowed: String,
    },
    /// Two fields contradict each other (e.g. T_min > T_max).
    #[error("{field} = {} is inconsistent: {reason}", number(*.value))]
    Inconsistent {
        field: String,
        value: f64,
        reason: String,
    },
    /// A valid scenario of a model that `operation` cannot take yet: a
    /// 6-DoF one (`model = "6dof"`) given to the planar solve
    /// ([`crate::pipeline::solve`], [`crate::Case::solve`]), the closed
    /// loop or a binding, refused rather than solved as planar.
    #[error("model = \"{model}\" is not yet available in {operation}: it solves and flies only the planar model (model = \"planar\"); the 6-DoF scenario is solved by the library's bellyflop::pipeline::six_dof::solve, from problem::six_dof::start_state of the scenario (`bellyflop solve` on the CLI)")]
    ModelUnavailable { model: ModelKind, operation: String },
    /// A setting that the 6-DoF solve ([`crate::pipeline::six_dof::solve`])
    /// does not read, given a value it would ignore: refused rather than
    /// ignored ([`crate::pipeline::six_dof::check_settings`] for a scenario
    /// file's, the CLI and the Python binding for their flags and
    /// arguments). `field` is the setting as given (a scenario key such as
    /// `solver.formulation`, a flag such as `--formulation`, a Python
    /// argument), `value` its value as given, `reason` why it does not apply
    /// and what does.
    #[error(
        "{} does not apply to a 6-DoF scenario (model = \"6dof\"): {reason}",
        setting(field, value)
    )]
    NotApplicable {
        field: String,
        value: String,
        reason: String,
    },
}

/// `field` given `value` as the user wrote it: `--flag value` on the
/// command line, else `key = value`.
fn setting(field: &str, value: &str) -> String {
    if field.starts_with("--") {
        format!("{field} {value}")
    } else {
        format!("{field} = {value}")
    }
}

/// A number as Rust prints it, but with an exponent when tiny or huge
/// (`5e-324`, not 324 digits).
fn number(x: f64) -> String {
    if x != 0.0 && x.is_finite() && (x.abs() < 1e-5 || x.abs() >= 1e16) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// 1-based line and column (in characters) of the end of `before`.
fn line_column(before: &str) -> (usize, usize) {
    let line = before.matches('\n').count() + 1;
    let start = before.rfind('\n').map_or(0, |i| i + 1);
    (line, before[start..].chars().count() + 1)
}

impl InputError {
    /// Wrap a TOML error with the 1-based line and column it points at.
    pub fn toml(kind: FileKind, text: &str, err: toml::de::Error) -> Self {
        let (line, column) = match err.span() {
            Some(span) => {
                let mut end = span.start.min(text.len());
                while !text.is_char_boundary(end) {
                    end -= 1;
                }
                line_column(&text[..end])
            }
            None => (0, 0),
        };
        InputError::Toml {
            kind,
            line,
            column,
            message: err.message().to_string(),
        }
    }
}

/// Parse TOML text into `T`; a syntax or type error gives its line and column.
pub(crate) fn parse_toml<T: serde::de::DeserializeOwned>(
    kind: FileKind,
    text: &str,
) -> Result<T, InputError> {
    toml::from_str(text).map_err(|e| InputError::toml(kind, text, e))
}

/// Read a UTF-8 text file; a failure names the path (and, for bytes that are
/// not UTF-8, where the first one is).
pub(crate) fn read_text(kind: FileKind, path: &std::path::Path) -> Result<String, InputError> {
    let bytes = std::fs::read(path).map_err(|e| InputError::Io {
        kind,
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    decode_text(kind, &path.display().to_string(), bytes)
}

/// Bytes as UTF-8 text; bytes that are not UTF-8 give [`InputError::NotUtf8`]
/// naming `path` and where the first invalid byte is. [`read_text`] after
/// reading the file, and `bellyflop::fuzzing::exercise` (with the `fuzzing` feature) on raw fuzz input.
pub(crate) fn decode_text(
    kind: FileKind,
    path: &str,
    bytes: Vec<u8>,
) -> Result<String, InputError> {
    String::from_utf8(bytes).map_err(|e| {
        let byte = e.utf8_error().valid_up_to();
        let bytes = e.as_bytes();
        // The prefix up to `byte` is valid UTF-8 by definition.
        let before = std::str::from_utf8(&bytes[..byte]).unwrap_or_default();
        let (line, column) = line_column(before);
        InputError::NotUtf8 {
            kind,
            path: path.to_string(),
            value: bytes[byte],
            byte,
            line,
            column,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiny_and_huge_values_print_with_an_exponent() {
        let e = |value| InputError::OutOfRange {
            field: "f".into(),
            value,
            allowed: "[1, 2]".into(),
        };
        assert_eq!(
            e(5e-324).to_string(),
            "f = 5e-324 is out of range: allowed [1, 2]"
        );
        assert_eq!(
            e(1e300).to_string(),
            "f = 1e300 is out of range: allowed [1, 2]"
        );
        assert_eq!(
            e(-85000.0).to_string(),
            "f = -85000 is out of range: allowed [1, 2]"
        );
        assert_eq!(e(0.0).to_string(), "f = 0 is out of range: allowed [1, 2]");
        assert_eq!(
            e(f64::NAN).to_string(),
            "f = NaN is out of range: allowed [1, 2]"
        );
    }

    /// A setting that does not apply names itself as it was given: a flag
    /// as on the command line, a key as in the file.
    #[test]
    fn not_applicable_names_the_setting_as_given() {
        let e = |field: &str, value: &str| {
            InputError::NotApplicable {
                field: field.into(),
                value: value.into(),
                reason: "why".into(),
            }
            .to_string()
        };
        assert_eq!(
            e("--formulation", "paper"),
            "--formulation paper does not apply to a 6-DoF scenario (model = \"6dof\"): why"
        );
        assert_eq!(
            e("solver.formulation", "\"paper\""),
            "solver.formulation = \"paper\" does not apply to a 6-DoF scenario (model = \"6dof\"): why"
        );
    }

    /// A non-UTF-8 file names the file, the byte and its line and column.
    #[test]
    fn non_utf8_file_names_the_position() {
        let path =
            std::env::temp_dir().join(format!("bellyflop-not-utf8-{}.toml", std::process::id()));
        std::fs::write(&path, b"name = \"a\"\n[vehicle]\nx = \"\xc3\xa9\xff\"\n").unwrap();
        let e = read_text(FileKind::Scenario, &path).unwrap_err();
        let _ = std::fs::remove_file(&path);
        match &e {
            InputError::NotUtf8 {
                value,
                byte,
                line,
                column,
                ..
            } => {
                assert_eq!((*value, *byte, *line, *column), (0xff, 28, 3, 7), "{e}");
            }
            other => panic!("{other:?}"),
        }
        let msg = e.to_string();
        assert!(msg.contains(&path.display().to_string()), "{msg}");
        assert!(
            msg.contains("scenario file") && msg.contains("line 3, column 7"),
            "{msg}"
        );
    }
}
