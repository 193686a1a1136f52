//! A failed call: its C error code and its message, kept per thread for
//! `bf_last_error`.

use std::cell::RefCell;
use std::ffi::{CStr, CString};

use bellyflop::InputError;

use crate::types::bf_error;

/// A call's failure: the code it returns and the message `bf_last_error`
/// gives (naming the field, its value and the allowed range where there is
/// one, as the library's [`InputError`] does).
#[derive(Debug, Clone, PartialEq)]
pub struct Failure {
    pub code: bf_error,
    pub message: String,
}

impl Failure {
    /// A setting or argument out of range, described by `message`.
    pub fn invalid(message: String) -> Failure {
        Failure {
            code: bf_error::InvalidInput,
            message,
        }
    }

    /// A NULL pointer where `argument` was needed.
    pub fn null(argument: &str) -> Failure {
        Failure {
            code: bf_error::NullPointer,
            message: format!("{argument} is NULL"),
        }
    }

    /// A query of the plan before there is one.
    pub fn no_plan() -> Failure {
        Failure::invalid(
            "the solver has no plan: no bf_solve or bf_replan has solved yet".to_string(),
        )
    }

    /// The message prefixed with the argument it is about.
    pub fn context(mut self, argument: &str) -> Failure {
        self.message = format!("{argument}: {}", self.message);
        self
    }
}

impl From<InputError> for Failure {
    fn from(e: InputError) -> Failure {
        let code = match e {
            InputError::Toml { .. } => bf_error::Parse,
            InputError::Io { .. } | InputError::NotUtf8 { .. } => bf_error::Io,
            InputError::Empty { .. }
            | InputError::OutOfRange { .. }
            | InputError::Inconsistent { .. }
            | InputError::ModelUnavailable { .. }
            | InputError::NotApplicable { .. } => bf_error::InvalidInput,
        };
        Failure {
            code,
            message: e.to_string(),
        }
    }
}

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

/// Keep `message` as this thread's last error (interior NULs, which a C
/// string cannot hold, become spaces).
pub fn set_last_error(message: &str) {
    let bytes: Vec<u8> = message
        .bytes()
        .map(|b| if b == 0 { b' ' } else { b })
        .collect();
    let c = CString::new(bytes).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = c);
}

/// This thread's last error message, as a pointer that stays valid until
/// the thread's next failing call (empty before any).
pub fn last_error_ptr() -> *const std::ffi::c_char {
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

/// This thread's last error message, copied.
pub fn last_error() -> String {
    LAST_ERROR.with(|e| {
        let e = e.borrow();
        let c: &CStr = &e;
        c.to_string_lossy().into_owned()
    })
}
