//! Shared by the CLI test files: run the `bellyflop` binary.

use std::process::Command;

/// Run `bellyflop args…`; return (exit code, stdout, stderr).
pub fn bellyflop(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_bellyflop"))
        .args(args)
        .output()
        .expect("the binary runs");
    (
        out.status.code().expect("exited normally, not by a signal"),
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
    )
}
