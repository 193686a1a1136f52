//! stdout and stderr without a panic: `println!` panics when stdout is a
//! closed pipe (`bellyflop solve | head -c 1`) or a full disk
//! (`>/dev/full`), and `eprintln!` when stderr is. The macros of this module
//! take their place in every command.
//!
//! - stdout closed by its reader (EPIPE): the command ends quietly with
//!   [`exit::BROKEN_PIPE`] (141, what a shell reports for a process ended by
//!   SIGPIPE), as `head` expects of a writer;
//! - any other stdout error (ENOSPC, EIO, ...): `error: cannot write to
//!   stdout: ...` on stderr and [`exit::OUTPUT`];
//! - stderr errors are dropped: there is nowhere left to report them.

use std::fmt;
use std::io::{self, Write};

use crate::exit;

/// Write `args` to stdout; on failure end the process as the module says.
pub fn out(args: fmt::Arguments<'_>) {
    let mut stdout = io::stdout().lock();
    if let Err(e) = stdout.write_fmt(args) {
        fail(&e);
    }
}

/// Flush stdout (the last lines of a command that ends without a newline,
/// or held by a pipe's buffer); on failure end the process as [`out`] does.
pub fn flush() {
    if let Err(e) = io::stdout().lock().flush() {
        fail(&e);
    }
}

/// Write `args` to stderr, ignoring errors.
pub fn err(args: fmt::Arguments<'_>) {
    let _ = io::stderr().lock().write_fmt(args);
}

/// The exit code for a stdout error `e` (without ending the process).
pub fn exit_code(e: &io::Error) -> u8 {
    if e.kind() == io::ErrorKind::BrokenPipe {
        exit::BROKEN_PIPE
    } else {
        exit::OUTPUT
    }
}

fn fail(e: &io::Error) -> ! {
    let code = exit_code(e);
    if code != exit::BROKEN_PIPE {
        err(format_args!("error: cannot write to stdout: {e}\n"));
    }
    std::process::exit(i32::from(code))
}

/// `println!` that never panics (see the module).
macro_rules! outln {
    () => {
        $crate::console::out(format_args!("\n"))
    };
    ($($arg:tt)*) => {
        $crate::console::out(format_args!("{}\n", format_args!($($arg)*)))
    };
}

/// `print!` that never panics (see the module).
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::console::out(format_args!($($arg)*))
    };
}

/// `eprintln!` that never panics (see the module).
macro_rules! errln {
    ($($arg:tt)*) => {
        $crate::console::err(format_args!("{}\n", format_args!($($arg)*)))
    };
}
