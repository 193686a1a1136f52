//! The exit codes of the commands, in one place (the solve's own codes come
//! from `Status::exit_code` of the library).

/// Output files not written (after the work was done).
pub const OUTPUT: u8 = 1;
/// Bad input, before any solve or flight.
pub const BAD_INPUT: u8 = 2;
/// `sim`: the run did not end in a touchdown.
pub const NO_TOUCHDOWN: u8 = 7;
/// `sim`: a touchdown beyond the survivable limits (`crash`).
pub const CRASH: u8 = 8;
