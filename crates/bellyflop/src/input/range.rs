//! The allowed interval of a validated field, and the check that names the
//! field, its value and the interval when it fails. Every input of the crate
//! is checked through it: the scenario and the solver settings
//! (`input::validate`), guidance's configuration, the plant and the
//! dispersions.

use crate::input::error::InputError;

/// An allowed interval for one floating-point field.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Range {
    lo: f64,
    hi: f64,
    lo_open: bool,
    hi_open: bool,
    unit: &'static str,
}

impl Range {
    /// `(lo, hi]`
    pub(crate) const fn open_closed(lo: f64, hi: f64, unit: &'static str) -> Self {
        Self {
            lo,
            hi,
            lo_open: true,
            hi_open: false,
            unit,
        }
    }
    /// `[lo, hi]`
    pub(crate) const fn closed(lo: f64, hi: f64, unit: &'static str) -> Self {
        Self {
            lo,
            hi,
            lo_open: false,
            hi_open: false,
            unit,
        }
    }
    /// `(lo, hi)`
    pub(crate) const fn open(lo: f64, hi: f64, unit: &'static str) -> Self {
        Self {
            lo,
            hi,
            lo_open: true,
            hi_open: true,
            unit,
        }
    }
    /// `[lo, hi)`
    pub(crate) const fn closed_open(lo: f64, hi: f64, unit: &'static str) -> Self {
        Self {
            lo,
            hi,
            lo_open: false,
            hi_open: true,
            unit,
        }
    }

    pub(crate) fn check(&self, field: &str, value: f64) -> Result<(), InputError> {
        in_range(
            field,
            value,
            self.lo,
            self.hi,
            self.lo_open,
            self.hi_open,
            self.unit,
        )
    }
}

/// Check a table of (field, value, range) rows in order; the first failure wins.
pub(crate) fn check_all(rows: &[(&str, f64, Range)]) -> Result<(), InputError> {
    rows.iter()
        .try_for_each(|(field, value, range)| range.check(field, *value))
}

/// Check that a finite `value` lies between `lo` and `hi`, each end open or
/// closed. NaN and ±inf are always out of range. The error names the field,
/// the value and the range (shared by every validated input of the crate).
pub(crate) fn in_range(
    field: &str,
    value: f64,
    lo: f64,
    hi: f64,
    lo_open: bool,
    hi_open: bool,
    unit: &str,
) -> Result<(), InputError> {
    let above_lo = if lo_open { value > lo } else { value >= lo };
    let below_hi = if hi_open { value < hi } else { value <= hi };
    if value.is_finite() && above_lo && below_hi {
        return Ok(());
    }
    let mut allowed = format!(
        "{}{}, {}{}",
        if lo_open { '(' } else { '[' },
        fmt_bound(lo),
        fmt_bound(hi),
        if hi_open { ')' } else { ']' },
    );
    if !unit.is_empty() {
        allowed.push(' ');
        allowed.push_str(unit);
    }
    Err(InputError::OutOfRange {
        field: field.into(),
        value,
        allowed,
    })
}

/// Check an integer count against an inclusive range.
pub(crate) fn count_in_range(
    field: &str,
    value: usize,
    (lo, hi): (usize, usize),
) -> Result<(), InputError> {
    if (lo..=hi).contains(&value) {
        return Ok(());
    }
    Err(InputError::OutOfRange {
        field: field.into(),
        value: value as f64,
        allowed: format!("{lo} to {hi}"),
    })
}

/// Print a range bound readably: `1e7` rather than `10000000`, `100` as is.
pub(crate) fn fmt_bound(x: f64) -> String {
    if x != 0.0 && (x.abs() >= 1e4 || x.abs() < 1e-3) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}
