//! `bellyflop solve`: one landing problem, its summary or JSON, and its files.

use std::process::ExitCode;

use bellyflop::input::scenario::ModelKind;
use bellyflop::method::observer::Iteration;
use bellyflop::output::report;
use bellyflop::solution::{DirectIteration, IterationRecord};
use bellyflop::{Case, Scenario, Solution, SolverSettings};

use crate::args::SolveArgs;
use crate::{exit, landing, load, output, repeat};

pub fn run(args: SolveArgs) -> ExitCode {
    let Case {
        scenario,
        solver: settings,
        warnings,
    } = match load::case(&args, load::SOLVE) {
        Ok(c) => c,
        Err(e) => {
            errln!("error: {e}");
            return ExitCode::from(exit::BAD_INPUT);
        }
    };
    if scenario.model == ModelKind::SixDof {
        return crate::solve_six_dof::run(&args, &scenario, &settings, &warnings);
    }
    if let Err(code) = output::prepare_or_exit(&args.out) {
        return code;
    }
    let quiet = args.quiet || args.json;
    let mut progress = Progress { quiet };
    // The planar pipeline refuses a 6-DoF scenario (dispatched above).
    let (solution, times_ms) =
        match solve_repeated(&scenario, &settings, &mut progress, args.repeat) {
            Ok(solved) => solved,
            Err(e) => {
                errln!("error: {e}");
                return ExitCode::from(exit::BAD_INPUT);
            }
        };
    let interpolation = args.interpolation.unwrap_or_default();
    let propagation = landing::propagate(&scenario, &solution, interpolation);
    // One JSON object: printed by --json, and written as solution.json by
    // --out; the library builds it, as for Python's `Solution.to_dict()`.
    let mut v = report::solve_json(&scenario, &solution, &propagation, &warnings);
    repeat::add_json(&mut v, args.repeat, &times_ms);
    if args.json {
        outln!("{v}");
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

/// Solve `repeat` times ([`repeat::repeated`]; progress shown for the
/// first run only): the last solution with the median solve time, and the
/// sorted times.
fn solve_repeated(
    scenario: &Scenario,
    settings: &SolverSettings,
    progress: &mut Progress,
    repeat: u32,
) -> Result<(Solution, Vec<f64>), bellyflop::InputError> {
    let (mut solution, times_ms) = repeat::repeated(
        repeat,
        |first| {
            let quiet = &mut Progress { quiet: true };
            bellyflop::solve(
                scenario,
                settings,
                if first { &mut *progress } else { quiet },
            )
        },
        |s| (s.status, s.final_mass_kg, s.solve_time_ms),
    )?;
    solution.solve_time_ms = repeat::median(&times_ms);
    Ok((solution, times_ms))
}

/// Per-iteration progress on stderr.
struct Progress {
    quiet: bool,
}

impl bellyflop::Observer for Progress {
    fn iteration(&mut self, record: Iteration<'_>) {
        match record {
            Iteration::Scvx(r) => self.scvx(r),
            Iteration::Direct(r) => self.direct(r),
        }
    }

    fn pass(&mut self, p: &bellyflop::solution::Pass) {
        if !self.quiet {
            errln!(
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
}

impl Progress {
    fn scvx(&mut self, r: &IterationRecord) {
        if !self.quiet {
            errln!(
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

    fn direct(&mut self, r: &DirectIteration) {
        if !self.quiet {
            errln!(
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
                outln!(
                    "mesh error    {:.1e} relative (largest on interval {} of {}, in {}; integration of the dynamics with the mesh's controls)",
                    w["relative_error"].as_f64().unwrap_or(f64::NAN),
                    w["interval"],
                    intervals.len(),
                    w["worst_state"].as_str().unwrap_or("?")
                );
            }
        }
        None => outln!(
            "mesh error    not estimated: {}",
            mesh["error"].as_str().unwrap_or("?")
        ),
    }
}

/// The human summary; `times_ms` are the sorted solve times of `--repeat`.
fn print_summary(scenario: &Scenario, settings: &SolverSettings, s: &Solution, times_ms: &[f64]) {
    outln!("scenario      {}", scenario.name);
    outln!("status        {}", s.status.as_str());
    if !s.message.is_empty() {
        outln!("reason        {}", s.message);
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
    let names = s.method.names();
    outln!(
        "method        {}, {} formulation, N = {}, {mesh}",
        names.title,
        s.formulation_label(settings.formulation),
        s.nodes
    );
    if let Some(r) = &s.refinement {
        let stop = r.stop.describe();
        let last = r.passes.last().map_or(f64::NAN, |p| p.max_relative_error);
        outln!(
            "refinement    {} passes to a tolerance of {:.0e}, max error {last:.1e}: {stop}",
            r.passes.len(),
            r.tolerance
        );
    }
    outln!("t_f           {:.4} s", s.tf_s);
    outln!(
        "final mass    {:.1} kg (fuel {:.1} kg)",
        s.final_mass_kg,
        s.fuel_kg
    );
    // SCvx's iterations each solve a cone program by interior point.
    let inner: u32 = s.history.scvx.iter().map(|h| h.ipm_iterations).sum();
    if s.history.scvx.is_empty() {
        outln!("iterations    {} {}", s.iterations, names.iteration);
    } else {
        outln!(
            "iterations    {} {}, {inner} interior-point in all",
            s.iterations,
            names.iteration
        );
    }
    outln!(
        "solve time    {}",
        repeat::time_text(s.solve_time_ms, times_ms)
    );
    outln!(
        "checks        defect {:.1e}, virtual control {:.1e}, relaxation gap {:.1e}, thrust alignment {:.6}",
        s.checks.max_defect, s.checks.virtual_control, s.checks.relaxation_gap, s.checks.thrust_alignment_min
    );
}
