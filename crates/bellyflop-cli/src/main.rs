//! `bellyflop`: solve flip-and-land trajectories from the shell.

use std::path::PathBuf;
use std::process::ExitCode;

use bellyflop::method::direct::DirectIteration;
use bellyflop::solution::IterationRecord;
use bellyflop::{Case, Formulation, Method, Scenario, Solution, SolverSettings};
use clap::{Parser, Subcommand, ValueEnum};

mod campaign_plot;
mod init;
mod landing;
mod montecarlo;
mod output;
mod plot;
mod sample;
mod sim;
mod sweep;

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

#[derive(Clone, Copy, ValueEnum)]
enum FormulationArg {
    Exact,
    Paper,
    Vector,
}

#[derive(Clone, Copy, ValueEnum)]
enum MethodArg {
    Scvx,
    Direct,
}

#[derive(clap::Args, Default)]
struct SolveArgs {
    /// Scenario TOML file; the paper's case when omitted.
    #[arg(long)]
    scenario: Option<PathBuf>,
    /// Number of LGR collocation points N (4 to 200; at most 100 on the global mesh); overrides the scenario
    /// (a `[discretization.mesh]` of the file gives way to the uniform mesh).
    #[arg(long)]
    nodes: Option<usize>,
    /// Number of LGR mesh intervals M (1 to N/2; 1 is the paper's global
    /// mesh); overrides the scenario (and its `[discretization.mesh]`, as
    /// `--nodes` does).
    #[arg(long)]
    intervals: Option<usize>,
    /// Thrust-direction formulation; overrides the scenario.
    #[arg(long, value_enum)]
    formulation: Option<FormulationArg>,
    /// Solution method: `scvx` (successive convexification, the paper's) or
    /// `direct` (interior point on the nonlinear program); overrides the
    /// scenario's `solver.method`.
    #[arg(long, value_enum)]
    method: Option<MethodArg>,
    /// Refine the mesh (hp, with breaks at the control switches) until every
    /// interval's relative error is at most TOL; overrides the scenario's
    /// `solver.refinement.tolerance` (0: no refinement).
    #[arg(long, value_name = "TOL")]
    mesh_tolerance: Option<f64>,
    /// Print one JSON object on stdout instead of a summary.
    #[arg(long)]
    json: bool,
    /// Do not print per-iteration progress on stderr.
    #[arg(long)]
    quiet: bool,
    /// Interpolation of the controls when re-propagating for the landing error.
    #[arg(long, value_enum, default_value = "pchip")]
    interpolation: landing::InterpolationArg,
    /// Write trajectory.csv, solution.json and the plots (SVG and PNG) into DIR.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Solve R times in this process and report the median solve time (and
    /// its minimum and maximum), as the IPOPT reference's `--repeat` does;
    /// the solution is the last run's (every run gives the same one).
    #[arg(long, value_name = "R", default_value_t = 1,
          value_parser = clap::value_parser!(u32).range(1..=10_000))]
    repeat: u32,
}

/// Exit code for bad input (before any solve).
pub(crate) const EXIT_BAD_INPUT: u8 = 2;

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command.unwrap_or(Command::Solve(SolveArgs::default())) {
        Command::Solve(args) => solve(args),
        Command::Init(args) => init::run(&args),
        Command::Sweep(args) => sweep::run(&args),
        Command::Sim(args) => sim::run(&args),
        Command::Montecarlo(args) => montecarlo::run(&args),
    }
}

/// The scenario file (the paper's case by default) with the flags' overrides.
fn load(args: &SolveArgs) -> Result<Case, bellyflop::InputError> {
    let mut case = match &args.scenario {
        Some(path) => Case::from_file(path)?,
        None => Case::paper(),
    };
    let d = &mut case.scenario.discretization;
    if args.nodes.is_some() || args.intervals.is_some() {
        // The flags ask for the uniform mesh of their counts, in place of
        // the file's explicit `[discretization.mesh]`.
        d.mesh = None;
    }
    if let Some(n) = args.nodes {
        d.nodes = n;
    }
    if let Some(m) = args.intervals {
        d.intervals = m;
    }
    if let Some(f) = args.formulation {
        case.solver.formulation = match f {
            FormulationArg::Exact => Formulation::Exact,
            FormulationArg::Paper => Formulation::Paper,
            FormulationArg::Vector => Formulation::Vector,
        };
    }
    if let Some(m) = args.method {
        case.solver.method = match m {
            MethodArg::Scvx => Method::Scvx,
            MethodArg::Direct => Method::Direct,
        };
    }
    if let Some(tol) = args.mesh_tolerance {
        case.solver.refinement.tolerance = tol;
    }
    case.validate()?;
    Ok(case)
}

fn solve(args: SolveArgs) -> ExitCode {
    let Case {
        scenario,
        solver: settings,
    } = match load(&args) {
        Ok(c) => c,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    if let Err(code) = output::prepare_or_exit(&args.out) {
        return code;
    }
    let quiet = args.quiet || args.json;
    let mut progress = Progress { quiet };
    let (solution, times_ms) = solve_repeated(&scenario, &settings, &mut progress, args.repeat);
    let propagation = landing::propagate(&scenario, &solution, args.interpolation);
    // One JSON object: printed by --json, and written as solution.json by --out.
    let mut v = solution.to_json();
    if args.repeat > 1 {
        v["repeat"] = args.repeat.into();
        v["solve_time_min_ms"] = times_ms[0].into();
        v["solve_time_max_ms"] = times_ms[times_ms.len() - 1].into();
    }
    landing::add_to_json(&mut v, &propagation);
    bellyflop::output::report::add_mesh_json(&mut v, &scenario, &solution);
    if args.json {
        println!("{v}");
    } else {
        print_summary(&scenario, &settings, &solution, &times_ms);
        landing::print_summary(&propagation, solution.final_mass_kg);
        print_mesh_summary(&v["mesh"]);
    }
    if let Some(dir) = &args.out {
        let propagated = propagation.as_ref().ok();
        if let Err(code) =
            output::write_and_report(dir, &scenario, &settings, &solution, &v, propagated, quiet)
        {
            return code;
        }
    }
    ExitCode::from(solution.status.exit_code() as u8)
}

/// Solve `repeat` times (progress shown for the first run only); the last
/// solution with the median solve time, and the sorted times. Every run must
/// give the same answer: the solvers are deterministic, and a difference is
/// reported on stderr.
fn solve_repeated(
    scenario: &Scenario,
    settings: &SolverSettings,
    progress: &mut Progress,
    repeat: u32,
) -> (Solution, Vec<f64>) {
    let mut solution = bellyflop::solve(scenario, settings, progress);
    let mut times_ms = vec![solution.solve_time_ms];
    for _ in 1..repeat {
        let again = bellyflop::solve(scenario, settings, &mut Progress { quiet: true });
        if again.status != solution.status || again.final_mass_kg != solution.final_mass_kg {
            eprintln!(
                "warning: a repeated solve differed: {} at {} kg, then {} at {} kg",
                solution.status.as_str(),
                solution.final_mass_kg,
                again.status.as_str(),
                again.final_mass_kg
            );
        }
        times_ms.push(again.solve_time_ms);
        solution = again;
    }
    times_ms.sort_by(f64::total_cmp);
    let k = times_ms.len();
    solution.solve_time_ms = 0.5 * (times_ms[(k - 1) / 2] + times_ms[k / 2]);
    (solution, times_ms)
}

/// Per-iteration progress on stderr.
struct Progress {
    quiet: bool,
}

impl bellyflop::Observer for Progress {
    fn on_iteration(&mut self, r: &IterationRecord) {
        if !self.quiet {
            eprintln!(
                "iter {:>3}  J {:>+12.6e}  m_f {:>10.1} kg  step {:>9.2e}  vc {:>9.2e}  radius {:>8.2e}  rho {:>+7.3}  {}{}  ipm {:>2}  {:>7.2} ms",
                r.iteration,
                r.cost,
                r.final_mass_kg,
                r.step,
                r.virtual_control,
                r.trust_radius,
                r.rho,
                if r.accepted { "acc" } else { "rej" },
                // The candidate was judged after its second-order correction.
                if r.corrected { "+soc" } else { "    " },
                r.ipm_iterations,
                r.ms
            );
        }
    }

    fn pass(&mut self, p: &bellyflop::refine::Pass) {
        if !self.quiet {
            eprintln!(
                "pass {:>2}  N {:>3} over {:>2} intervals  {:<9}  {:>3} iterations  {:>7.2} ms  m_f {:>10.2} kg  max error {:>8.1e}  events at {}",
                p.pass,
                p.nodes,
                p.mesh.points.len(),
                p.status.as_str(),
                p.iterations,
                p.solve_time_ms,
                p.final_mass_kg,
                p.max_relative_error,
                if p.events_s.is_empty() {
                    "none".to_string()
                } else {
                    p.events_s
                        .iter()
                        .map(|t| format!("{t:.3} s"))
                        .collect::<Vec<_>>()
                        .join(", ")
                }
            );
        }
    }

    fn on_direct_iteration(&mut self, r: &DirectIteration) {
        if !self.quiet {
            eprintln!(
                "iter {:>3}  m_f {:>10.2} kg  inf_pr {:>9.2e}  inf_du {:>9.2e}  mu {:>8.1e}  alpha {:>8.2e}  reg {:>8.1e}  ls {:>2}{}  {:>6.3} ms",
                r.iteration,
                r.final_mass_kg,
                r.primal_infeasibility,
                r.dual_infeasibility,
                r.mu,
                r.step,
                r.inertia_correction,
                r.line_search_trials,
                if r.restoration { " restoration" } else { "" },
                r.ms
            );
        }
    }
}

/// The mesh error line of the summary, from the JSON's `mesh` field.
fn print_mesh_summary(mesh: &serde_json::Value) {
    match mesh["intervals"].as_array() {
        Some(intervals) => {
            let worst = intervals.iter().max_by(|a, b| {
                let e = |v: &serde_json::Value| v["relative_error"].as_f64().unwrap_or(f64::NAN);
                e(a).total_cmp(&e(b))
            });
            if let Some(w) = worst {
                println!(
                    "mesh error    {:.1e} relative (largest on interval {} of {}, in {}; integration of the dynamics with the mesh's controls)",
                    w["relative_error"].as_f64().unwrap_or(f64::NAN),
                    w["interval"],
                    intervals.len(),
                    w["worst_state"].as_str().unwrap_or("?")
                );
            }
        }
        None => println!(
            "mesh error    not estimated: {}",
            mesh["error"].as_str().unwrap_or("?")
        ),
    }
}

/// The human summary; `times_ms` are the sorted solve times of `--repeat`.
fn print_summary(scenario: &Scenario, settings: &SolverSettings, s: &Solution, times_ms: &[f64]) {
    println!("scenario      {}", scenario.name);
    println!("status        {}", s.status.as_str());
    if !s.message.is_empty() {
        println!("reason        {}", s.message);
    }
    let mesh = match s.intervals {
        1 => "global mesh".to_string(),
        m => format!(
            "{m} intervals ({} points)",
            s.mesh
                .points
                .iter()
                .map(|p| p.to_string())
                .collect::<Vec<_>>()
                .join("+")
        ),
    };
    match s.method {
        Method::Direct => println!(
            "method        direct (interior point on P2), N = {}, {mesh}",
            s.nodes
        ),
        Method::Scvx => println!(
            "formulation   {}, N = {}, {mesh}",
            s.formulation_label(settings.formulation),
            s.nodes
        ),
    }
    if let Some(r) = &s.refinement {
        let stop = r.stop.describe();
        let last = r.passes.last().map_or(f64::NAN, |p| p.max_relative_error);
        println!(
            "refinement    {} passes to a tolerance of {:.0e}, max error {last:.1e}: {stop}",
            r.passes.len(),
            r.tolerance
        );
    }
    println!("t_f           {:.4} s", s.tf_s);
    println!(
        "final mass    {:.1} kg (fuel {:.1} kg)",
        s.final_mass_kg, s.fuel_kg
    );
    match s.method {
        Method::Scvx => println!(
            "iterations    {} SCvx, {} interior-point in all",
            s.iterations,
            s.history.iter().map(|h| h.ipm_iterations).sum::<u32>()
        ),
        Method::Direct => println!(
            "iterations    {} interior-point (direct method)",
            s.iterations
        ),
    }
    if times_ms.len() > 1 {
        println!(
            "solve time    {:.1} ms (median of {} runs; min {:.1} ms, max {:.1} ms)",
            s.solve_time_ms,
            times_ms.len(),
            times_ms[0],
            times_ms[times_ms.len() - 1]
        );
    } else {
        println!("solve time    {:.1} ms", s.solve_time_ms);
    }
    println!(
        "checks        defect {:.1e}, virtual control {:.1e}, relaxation gap {:.1e}, thrust alignment {:.6}",
        s.checks.max_defect, s.checks.virtual_control, s.checks.relaxation_gap, s.checks.thrust_alignment_min
    );
}
