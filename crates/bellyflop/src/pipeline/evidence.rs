//! Where the operational limits cut (issue 37), when the pipeline found no
//! trajectory that holds them.
//!
//! A proof that no trajectory exists is known only when the initial state
//! already breaks a limit ([`crate::problem::feasibility`]). Otherwise a
//! method that stops locally infeasible has found none, which is not a
//! proof (IPOPT's "infeasible" is local too). What the solve can give
//! instead is which limit cuts, and where:
//!
//! - the same state without its limits, solved by the same method on the
//!   same mesh (the method alone: its raw answer, without the polish and
//!   the checks, ~10 ms), and each limit
//!   that this answer breaks, at its worst along its nodes and between
//!   them ([`path::limit_reports`]), and when: the optimum that the limit
//!   cuts away;
//! - with several limits, each one alone: whether the state with that limit
//!   alone is solved (raw answer). A limit that alone leaves it unsolved is
//!   the one to look at; if each alone is solved, it is their combination.
//!
//! The status stays `not_converged`; the evidence joins the message and the
//! JSON (`limit_evidence`), and its solves join `solve_time_ms`.

use crate::input::scenario::{Constraints, Scenario};
use crate::input::settings::SolverSettings;
use crate::method::observer::Silent;
use crate::method::{self, Start};
use crate::problem::constraints;
use crate::solution::{LimitAlone, LimitEvidence, Solution, Status};
use crate::verify::path;

/// The evidence for `scenario`, whose solve with `settings` found no
/// trajectory, and the time its solves took \[ms\].
pub fn gather(scenario: &Scenario, settings: &SolverSettings) -> (LimitEvidence, f64) {
    let clock = std::time::Instant::now();
    let mut solver = method::solver(settings.method);
    let mut with = |c: Constraints| {
        let s = Scenario {
            constraints: c,
            ..scenario.clone()
        };
        solver.solve(&s, settings, Start::StraightLine, &mut Silent)
    };
    let free = with(Constraints::default());
    let solved = free.status == Status::Solved;
    let broken = if solved {
        let states = node_states(&free);
        let mut reports = path::limit_reports(&constraints::rows(scenario), &free.t_s, &states);
        reports.retain(|r| r.worst > path::LIMIT_TOLERANCE * r.scale);
        reports
    } else {
        Vec::new()
    };
    let limits = constraints::limits(&scenario.constraints);
    let alone = if limits.len() > 1 {
        limits
            .iter()
            .map(|&limit| LimitAlone {
                limit,
                solved: with(constraints::only(&scenario.constraints, limit)).status
                    == Status::Solved,
            })
            .collect()
    } else {
        Vec::new()
    };
    let evidence = LimitEvidence {
        unconstrained_solved: solved,
        unconstrained_final_mass_kg: solved.then_some(free.final_mass_kg),
        broken,
        alone,
    };
    (evidence, clock.elapsed().as_secs_f64() * 1e3)
}

/// The answer's published node states (x, z, Vx, Vz, θ, w, m: the rows'
/// arguments).
fn node_states(sol: &Solution) -> Vec<[f64; 7]> {
    let columns = sol.state_columns();
    (0..sol.t_s.len())
        .map(|k| std::array::from_fn(|i| columns[i][k]))
        .collect()
}

/// A sentence for the message: which limit cuts, where.
pub fn describe(e: &LimitEvidence) -> String {
    let Some(mass) = e.unconstrained_final_mass_kg else {
        return "without its limits no trajectory was found from this state either, so they are not shown to be the cause".to_string();
    };
    let mut out = format!("without its limits this state is solved (final mass {mass:.1} kg)");
    if e.broken.is_empty() {
        out.push_str(", and that answer holds every limit at its nodes");
    } else {
        let each: Vec<String> = e
            .broken
            .iter()
            .map(|r| {
                format!(
                    "{} by {:.3} {} at t = {:.2} s",
                    r.limit.describe(),
                    r.worst,
                    r.limit.unit(),
                    r.t_s
                )
            })
            .collect();
        out.push_str(&format!(", and that answer breaks {}", each.join(", ")));
    }
    if !e.alone.is_empty() {
        let unsolved: Vec<&str> = e
            .alone
            .iter()
            .filter(|a| !a.solved)
            .map(|a| a.limit.describe())
            .collect();
        if unsolved.is_empty() {
            out.push_str("; each limit alone is solved, so it is their combination that no trajectory found here meets");
        } else {
            out.push_str(&format!(
                "; alone, {} leave{} it unsolved too",
                unsolved.join(" and "),
                if unsolved.len() == 1 { "s" } else { "" }
            ));
        }
    }
    out
}

/// Whether a solve's answer calls for the evidence: no trajectory was
/// found, and the scenario has limits.
pub fn wanted(scenario: &Scenario, sol: &Solution) -> bool {
    sol.status == Status::NotConverged && !constraints::limits(&scenario.constraints).is_empty()
}
