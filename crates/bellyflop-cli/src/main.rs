//! `bellyflop`: solve flip-and-land trajectories from the shell.
//!
//! The modules, in dependency order (each uses only those above it):
//! `exit` (exit codes), `console` (stdout and stderr without a panic: its
//! macros `outln!`, `out!` and `errln!` replace `println!`, `print!` and
//! `eprintln!`), `error` (why writing failed), `files` (files
//! written whole or not at all), `landing` (the landing
//! check), `args` and `load` (the flags and the scenario they select),
//! `sample` (the dense trajectory), `plot` (every figure), `output` (the
//! files of `solve --out`), `repeat` (`solve --repeat`), then one module
//! per command.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod exit;
#[macro_use]
mod console;
mod args;
mod error;
mod files;
mod init;
mod landing;
mod load;
mod montecarlo;
mod output;
mod plot;
mod repeat;
mod sample;
mod sim;
mod solve;
mod solve_six_dof;
mod sweep;

use args::SolveArgs;

#[derive(Parser)]
#[command(
    name = "bellyflop",
    version,
    about = "Fuel-optimal flip-and-land trajectories (LGR collocation + successive convexification)"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Solve one landing problem (the paper's case by default).
    Solve(SolveArgs),
    /// Write a commented scenario TOML (the paper's case) with every
    /// parameter, its unit and its allowed range.
    Init(init::InitArgs),
    /// Solve at several N and tabulate t_f, final mass, landing precision,
    /// iterations and solve time (the paper's Tables 3-5).
    Sweep(sweep::SweepArgs),
    /// Fly one closed-loop landing with dispersions: navigation noise,
    /// re-planning at 2 Hz, tracking and terminal descent, to touchdown.
    ///
    /// The outcome is `landed` (within the [touchdown] landing spec, by
    /// default 1 m, 1 m/s, 2 deg), `hard_landing`, `crash` (beyond the
    /// survivable limits, by default 5 m/s vertical, 3 m/s horizontal,
    /// 10 deg), or no touchdown (propellant_exhausted, time_limit,
    /// non_finite). Exit codes: 0 landed or hard landing, 8 crash, 7 no
    /// touchdown, 2 bad input, 1 output files not written.
    Sim(sim::SimArgs),
    /// Fly many dispersed closed-loop landings in parallel and summarize
    /// the touchdown errors, fuel and re-plan times.
    Montecarlo(montecarlo::MonteCarloArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let code = match cli.command.unwrap_or(Command::Solve(SolveArgs::default())) {
        Command::Solve(args) => solve::run(args),
        Command::Init(args) => init::run(&args),
        Command::Sweep(args) => sweep::run(&args),
        Command::Sim(args) => sim::run(&args),
        Command::Montecarlo(args) => montecarlo::run(&args),
    };
    // What stdout still holds, written now so that a failure is reported
    // (the flush at exit would drop it silently).
    console::flush();
    code
}
