//! What the fuzz target (`fuzz/fuzz_targets/scenario.rs`), the corpus replay
//! and the seeded mutation fuzzer (`tests/fuzz_corpus.rs`) run on every
//! input: raw scenario bytes through UTF-8 decoding, TOML parsing,
//! validation, transcription setup and a short solve with both methods,
//! checking the invariants every answer must keep.
//!
//! [`exercise`] panics if and only if bellyflop panicked or an invariant
//! broke; every other input, however malformed, returns an [`Outcome`]. The
//! invariants:
//!
//! - bad input is a typed [`InputError`] whose message is non-empty and
//!   names the field it is about (and, for TOML errors, a line and column);
//!   a valid 6-DoF scenario (`model = "6dof"`) is refused the same way,
//!   [`InputError::ModelUnavailable`], as the planar pipeline cannot take it;
//! - a scenario that validates writes back to TOML and reads back equal and
//!   valid (`bellyflop init` and `--out` write scenarios this way);
//! - every answer of [`crate::solve`] has a status whose exit code is 0 if
//!   and only if it is `solved`, a message exactly when it is not `solved`,
//!   and JSON that names its status and method;
//! - a `solved` answer has a finite trajectory, stays above the ground
//!   (within [`crate::solution::GROUND_TOLERANCE_M`]), keeps every reported
//!   thrust within [T_min, T_max] (within
//!   [`crate::method::scvx::THRUST_TOLERANCE_FRAC`] of T_max), and thrusts out of
//!   the nozzle.
//!
//! To keep each input cheap the iteration limits are capped ([`BUDGET`]): the
//! point is the code paths, validation, setup and the first subproblems, not
//! convergence.
//!
//! [`mutate`] is the seeded, structure-aware mutator of the bounded fuzz
//! that `cargo test` runs, so the fuzzing stays on the stable toolchain
//! without cargo-fuzz.

use rand::Rng;

use crate::input::error::{FileKind, InputError};
use crate::input::scenario::{Case, Scenario};
use crate::input::settings::Method;
use crate::solution::{Solution, Status};

/// Iteration caps of [`exercise`]'s solves.
#[derive(Debug, Clone, Copy)]
pub struct Budget {
    /// SCvx iterations (`solver.max_iterations`), at most.
    pub scvx_iterations: usize,
    /// Iterations of the relaxed first phase, at most.
    pub relaxed_first_iterations: usize,
    /// Direct-method iterations (`solver.direct.max_iterations`), at most.
    pub direct_iterations: usize,
}

/// The caps [`exercise`] uses: two SCvx subproblems (one relaxed) and 60
/// interior-point iterations.
pub const BUDGET: Budget = Budget {
    scvx_iterations: 2,
    relaxed_first_iterations: 1,
    direct_iterations: 60,
};

/// What became of one input.
#[derive(Debug)]
pub enum Outcome {
    /// Not a valid scenario: not UTF-8, not TOML of the right shape, or a
    /// field out of range or inconsistent; or a 6-DoF one, which the planar
    /// pipeline does not take.
    Rejected(InputError),
    /// A valid scenario, solved (within [`BUDGET`]) by each method in turn.
    Ran(Vec<(Method, Status)>),
}

/// Run one input through everything; see the module documentation for the
/// invariants. Panics if one breaks.
pub fn exercise(bytes: &[u8]) -> Outcome {
    exercise_with(bytes, BUDGET)
}

/// [`exercise`] with other iteration caps.
pub fn exercise_with(bytes: &[u8], budget: Budget) -> Outcome {
    let text = match crate::input::error::decode_text(FileKind::Scenario, "<input>", bytes.to_vec())
    {
        Ok(text) => text,
        Err(e) => return rejected(e),
    };
    let case = match Case::from_toml_str(&text) {
        Ok(s) => s,
        Err(e) => return rejected(e),
    };
    round_trip(&case);
    // The pipeline solves the planar model: a 6-DoF scenario (valid, and
    // round-tripped above) is refused as the CLI and the bindings refuse it.
    if let Err(e) = case.scenario.require_planar("the fuzzed planar solve") {
        return rejected(e);
    }
    let mut s = case;
    s.solver.max_iterations = s.solver.max_iterations.min(budget.scvx_iterations);
    s.solver.relaxed_first_iterations = s
        .solver
        .relaxed_first_iterations
        .min(budget.relaxed_first_iterations);
    s.solver.direct.max_iterations = s.solver.direct.max_iterations.min(budget.direct_iterations);
    assert!(
        s.validate().is_ok(),
        "capping the iterations broke validity"
    );
    let mut answers = Vec::with_capacity(2);
    for method in [Method::Direct, Method::Scvx] {
        s.solver.method = method;
        let sol = match s.solve(&mut crate::method::observer::Silent) {
            Ok(sol) => sol,
            Err(e) => return rejected(e),
        };
        check_answer(&s.scenario, method, &sol);
        answers.push((method, sol.status));
    }
    Outcome::Ran(answers)
}

/// The invariants of a rejection.
fn rejected(e: InputError) -> Outcome {
    let msg = e.to_string();
    assert!(!msg.trim().is_empty(), "an empty message for {e:?}");
    match &e {
        InputError::Toml { line, column, .. } => {
            // A position, when the TOML error has one, is 1-based.
            assert!(
                (*line == 0) == (*column == 0),
                "line {line}, column {column}: {msg}"
            );
        }
        InputError::NotUtf8 { line, column, .. } => {
            assert!(*line >= 1 && *column >= 1, "{msg}");
        }
        InputError::Empty { field }
        | InputError::OutOfRange { field, .. }
        | InputError::Inconsistent { field, .. }
        | InputError::NotApplicable { field, .. } => {
            assert!(!field.is_empty() && msg.contains(field.as_str()), "{msg}");
        }
        InputError::ModelUnavailable { model, .. } => {
            assert!(msg.contains(&format!("model = \"{model}\"")), "{msg}");
        }
        InputError::Io { .. } => panic!("no file was read, yet: {msg}"),
    }
    Outcome::Rejected(e)
}

/// A valid scenario file writes to TOML and reads back, valid and equal.
fn round_trip(s: &Case) {
    let text =
        toml::to_string(s).unwrap_or_else(|e| panic!("a valid scenario must serialize: {e}"));
    match Case::from_toml_str(&text) {
        Ok(back) => assert!(
            back == *s,
            "the scenario read back differs:\n{text}\n{back:?}\n{s:?}"
        ),
        Err(e) => panic!("a valid scenario, written out, no longer reads: {e}\n{text}"),
    }
}

/// The invariants of one answer of [`crate::solve`].
fn check_answer(s: &Scenario, method: Method, sol: &Solution) {
    let status = sol.status;
    assert_eq!(sol.method, method);
    assert_eq!(
        status.exit_code() == 0,
        status == Status::Solved,
        "{status:?}"
    );
    assert_eq!(
        sol.message.is_empty(),
        status == Status::Solved,
        "{status:?} with message {:?}",
        sol.message
    );
    let v = sol.to_json();
    assert_eq!(v["status"].as_str(), Some(status.as_str()));
    assert_eq!(v["method"].as_str(), Some(method.as_str()));
    serde_json::to_string(&v).expect("the JSON answer prints");
    if status == Status::Solved {
        let c = &sol.checks;
        assert!(sol.trajectory.is_finite(), "solved, but not finite");
        assert!(
            c.min_altitude_margin_m >= -crate::solution::GROUND_TOLERANCE_M,
            "solved {} m below the ground",
            -c.min_altitude_margin_m
        );
        assert!(
            c.thrust_bound_violation_n
                <= crate::method::scvx::THRUST_TOLERANCE_FRAC * s.vehicle.max_thrust_n,
            "solved with the thrust {} N outside its bounds",
            c.thrust_bound_violation_n
        );
        assert!(
            !c.thrust_backwards(),
            "solved with the thrust backwards ({})",
            c.thrust_alignment_min
        );
    }
}

/// Values that sit on, just inside or just outside some range, or break
/// arithmetic: the mutator writes them in place of numbers.
const INTERESTING: &[&str] = &[
    "0",
    "-0.0",
    "1",
    "-1",
    "4",
    "3",
    "100",
    "101",
    "50",
    "2",
    "0.1",
    "0.099",
    "90",
    "89.999",
    "5e-324",
    "2.2e-308",
    "1e-300",
    "1e-12",
    "1e-3",
    "1e12",
    "1e5",
    "1e6",
    "1e7",
    "1e9",
    "1e300",
    "1.7976931348623157e308",
    "nan",
    "inf",
    "-inf",
    "18446744073709551615",
    "9223372036854775807",
    "-9223372036854775808",
    "4294967296",
    "1e-6",
    "0.5",
    "0.49999",
    "360",
    "-180",
    "1000",
    "120000.0",
    "85000.0",
    "2210000.0",
    "\"\"",
    "\" \"",
    "true",
    "[]",
    "{}",
];

/// Lines that the mutator inserts, each after the header of its section
/// (`""`: at a random place): keys that exist, enum values, and text that
/// TOML must reject.
const LINES: &[(&str, &str)] = &[
    ("solver", "method = \"scvx\""),
    ("solver", "method = \"direct\""),
    ("solver", "formulation = \"paper\""),
    ("solver", "formulation = \"vector\""),
    ("solver", "second_order_correction = false"),
    ("solver", "thrust_margin_frac = 0.1"),
    ("solver", "terminal_lateral_weight = 1e3"),
    ("solver", "relaxed_first_iterations = 0"),
    ("solver", "proximal_weight = 1.0"),
    ("solver", "landing_position_tolerance_m = 1e-3"),
    ("solver.direct", "mu_strategy = \"adaptive\""),
    ("solver.direct", "coarse_nodes = 0"),
    ("solver.direct", "coarse_nodes = 4"),
    ("solver.direct", "tolerance = 0.5"),
    ("discretization", "intervals = 2"),
    ("discretization", "intervals = 10"),
    ("environment", "wind_x_mps = 30.0"),
    ("", "name = \"\""),
    ("", "name = \"\u{e9}\u{0}\""),
    ("", "[[vehicle]]"),
    ("", "x = "),
    ("", "\"unterminated"),
    ("", "a.b.c = 1"),
];

/// One seeded mutation of `input`, structure-aware where it pays: numbers
/// become `INTERESTING` values or another field's value (e.g.
/// `cg_m = length_m`), lines are dropped, duplicated, swapped or taken from
/// `others` (the rest of the corpus), and raw bytes are flipped, inserted
/// (invalid UTF-8 too) or cut. Several mutations may stack.
pub fn mutate<R: Rng>(input: &[u8], others: &[&[u8]], rng: &mut R) -> Vec<u8> {
    let mut out = input.to_vec();
    let rounds = [1, 1, 1, 1, 1, 1, 2, 2, 3, 4][rng.gen_range(0..10)];
    for _ in 0..rounds {
        out = mutate_once(&out, others, rng);
    }
    out.truncate(64 * 1024);
    out
}

fn mutate_once<R: Rng>(input: &[u8], others: &[&[u8]], rng: &mut R) -> Vec<u8> {
    let mut lines: Vec<Vec<u8>> = input.split(|&b| b == b'\n').map(<[u8]>::to_vec).collect();
    let pick = |rng: &mut R, n: usize| if n == 0 { 0 } else { rng.gen_range(0..n) };
    match rng.gen_range(0..20) {
        // A number becomes an interesting value.
        0..=8 => {
            let spots = number_spots(&lines);
            if let Some(&(l, a, b)) = spots.get(pick(rng, spots.len())) {
                let v = INTERESTING[rng.gen_range(0..INTERESTING.len())].as_bytes();
                lines[l].splice(a..b, v.iter().copied());
            }
        }
        // A number becomes another field's number, or is scaled.
        9..=12 => {
            let spots = number_spots(&lines);
            if spots.len() >= 2 {
                let (l, a, b) = spots[pick(rng, spots.len())];
                let (l2, a2, b2) = spots[pick(rng, spots.len())];
                let v = if rng.gen_bool(0.3) {
                    lines[l2][a2..b2].to_vec()
                } else {
                    let x: f64 = std::str::from_utf8(&lines[l][a..b])
                        .ok()
                        .and_then(|t| t.replace('_', "").parse().ok())
                        .unwrap_or(1.0);
                    let f = [
                        0.5,
                        2.0,
                        -1.0,
                        1.0 + 1e-12,
                        1.0 - 1e-12,
                        10.0,
                        0.1,
                        0.9,
                        1.1,
                    ];
                    let y = x * f[pick(rng, f.len())];
                    if lines[l][a..b].contains(&b'.') || y.fract() != 0.0 {
                        format!("{y:?}").into_bytes()
                    } else {
                        format!("{}", y as i64).into_bytes()
                    }
                };
                lines[l].splice(a..b, v);
            }
        }
        // Drop, duplicate or swap lines.
        13 => {
            if !lines.is_empty() {
                let i = pick(rng, lines.len());
                match rng.gen_range(0..3) {
                    0 => {
                        lines.remove(i);
                    }
                    1 => {
                        let l = lines[i].clone();
                        lines.insert(pick(rng, lines.len() + 1), l);
                    }
                    _ => {
                        let j = pick(rng, lines.len());
                        lines.swap(i, j);
                    }
                }
            }
        }
        // Insert a known line after its section's header (adding the
        // header at the end when there is none).
        14..=16 => {
            let (section, line) = LINES[pick(rng, LINES.len())];
            let header = format!("[{section}]").into_bytes();
            if section.is_empty() {
                let at = pick(rng, lines.len() + 1);
                lines.insert(at, line.as_bytes().to_vec());
            } else if let Some(h) = lines.iter().position(|l| l.starts_with(&header)) {
                lines.insert(h + 1, line.as_bytes().to_vec());
            } else {
                lines.push(header);
                lines.push(line.as_bytes().to_vec());
            }
        }
        // A line of another corpus file.
        17 => {
            if !others.is_empty() {
                let other: Vec<&[u8]> = others[pick(rng, others.len())]
                    .split(|&b| b == b'\n')
                    .collect();
                let line = other[pick(rng, other.len())].to_vec();
                let at = pick(rng, lines.len() + 1);
                lines.insert(at, line);
            }
        }
        // Raw bytes.
        _ => {
            let mut bytes = lines.join(&b'\n');
            let n = bytes.len();
            match rng.gen_range(0..4) {
                0 if n > 0 => {
                    let i = pick(rng, n);
                    bytes[i] ^= 1 << rng.gen_range(0..8);
                }
                1 => {
                    let b =
                        [0xff, 0xc3, 0x80, 0x00, b'"', b'=', b'[', b'.', b'e', b'#'][pick(rng, 10)];
                    bytes.insert(pick(rng, n + 1), b);
                }
                2 if n > 0 => {
                    let i = pick(rng, n);
                    let j = (i + 1 + pick(rng, 16)).min(n);
                    bytes.drain(i..j);
                }
                _ if n > 0 => {
                    bytes.truncate(pick(rng, n));
                }
                _ => {}
            }
            return bytes;
        }
    }
    lines.join(&b'\n')
}

/// (line, start, end) of each number-like value after an `=`.
fn number_spots(lines: &[Vec<u8>]) -> Vec<(usize, usize, usize)> {
    let mut spots = Vec::new();
    for (l, line) in lines.iter().enumerate() {
        let Some(eq) = line.iter().position(|&b| b == b'=') else {
            continue;
        };
        let mut a = eq + 1;
        while a < line.len() && line[a] == b' ' {
            a += 1;
        }
        let mut b = a;
        while b < line.len() && (line[b].is_ascii_alphanumeric() || b"+-._".contains(&line[b])) {
            b += 1;
        }
        if b > a && (line[a].is_ascii_digit() || line[a] == b'-' || line[a] == b'+') {
            spots.push((l, a, b));
        }
    }
    spots
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn the_paper_case_runs_both_methods() {
        match exercise(crate::input::scenario::PAPER_TOML.as_bytes()) {
            Outcome::Ran(answers) => {
                let methods: Vec<Method> = answers.iter().map(|a| a.0).collect();
                assert_eq!(methods, [Method::Direct, Method::Scvx]);
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn bad_bytes_are_rejected_with_a_position() {
        match exercise(b"name = \"a\xff\"\n") {
            Outcome::Rejected(InputError::NotUtf8 { byte, line, .. }) => {
                assert_eq!((byte, line), (9, 1));
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn mutations_are_seeded_and_change_the_input() {
        let paper = crate::input::scenario::PAPER_TOML.as_bytes();
        let run = |seed| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            (0..50)
                .map(|_| mutate(paper, &[], &mut rng))
                .collect::<Vec<_>>()
        };
        let a = run(7);
        assert_eq!(a, run(7));
        assert!(a.iter().filter(|m| m.as_slice() != paper).count() >= 40);
    }
}
