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
/// `montecarlo`: interrupted by SIGINT (Ctrl-C) after writing the runs that
/// finished (128 + SIGINT, as a shell reports it).
pub const INTERRUPTED: u8 = 130;
/// stdout closed by its reader (128 + SIGPIPE, as a shell reports a writer
/// ended by the signal); nothing is printed.
pub const BROKEN_PIPE: u8 = 141;
