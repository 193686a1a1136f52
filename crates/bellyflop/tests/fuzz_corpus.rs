//! Issue 18, "fuzzing that stays", on the stable toolchain and in CI:
//!
//! 1. the committed corpus `fuzz/corpus/scenario/` (the fuzz target's, see
//!    `fuzz/`) is replayed through [`bellyflop::fuzzing::exercise`], the
//!    function the fuzz target runs: no panic, every invariant kept, and
//!    the issue's failures rejected or answered as they must be;
//! 2. a bounded, seeded mutation fuzz: [`bellyflop::fuzzing::mutate`] on the
//!    corpus, 2,000 mutants by default. `BELLYFLOP_FUZZ_MUTANTS` and
//!    `BELLYFLOP_FUZZ_SEED` set the count and the seed (the local campaign
//!    of docs/reliability.md runs more).

use std::path::PathBuf;

use bellyflop::fuzzing::{exercise, mutate, Outcome};
use bellyflop::{InputError, Method, Status};
use rand::SeedableRng;

fn corpus_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/corpus/scenario")
}

/// Every corpus file, sorted by name (so the mutation fuzz is reproducible).
fn corpus() -> Vec<(String, Vec<u8>)> {
    let mut files: Vec<(String, Vec<u8>)> = std::fs::read_dir(corpus_dir())
        .expect("the corpus directory fuzz/corpus/scenario exists")
        .map(|e| {
            let path = e.unwrap().path();
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&path).unwrap())
        })
        .collect();
    files.sort();
    files
}

/// Run `exercise`, turning a panic into an error that shows the input.
fn run(label: &str, bytes: &[u8]) -> Result<Outcome, String> {
    std::panic::catch_unwind(|| exercise(bytes)).map_err(|e| {
        let what = e
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default();
        format!(
            "{label} panicked: {what}\n--- input ---\n{}\n---",
            String::from_utf8_lossy(bytes)
        )
    })
}

fn field_of(e: &InputError) -> Option<&str> {
    match e {
        InputError::Empty { field }
        | InputError::OutOfRange { field, .. }
        | InputError::Inconsistent { field, .. } => Some(field),
        _ => None,
    }
}

/// The corpus replays without a panic, and the files that reproduce the
/// issue's failures get the answer the issue asks for.
#[test]
fn the_corpus_replays_and_the_issues_failures_stay_fixed() {
    let files = corpus();
    assert!(files.len() >= 30, "only {} corpus files", files.len());
    let mut failures = Vec::new();
    let (mut rejected, mut ran) = (0, 0);
    for (name, bytes) in &files {
        let outcome = match run(name, bytes) {
            Ok(o) => o,
            Err(e) => {
                failures.push(e);
                continue;
            }
        };
        match &outcome {
            Outcome::Rejected(_) => rejected += 1,
            Outcome::Ran(_) => ran += 1,
        }
        // Files named for a failure of issue 18 (or for a boundary).
        let expect_field = |field: &str| match &outcome {
            Outcome::Rejected(e) => assert_eq!(field_of(e), Some(field), "{name}: {e}"),
            other => panic!("{name}: {other:?}, expected a rejection of {field}"),
        };
        match name.as_str() {
            "max_gimbal_subnormal.toml" => expect_field("vehicle.max_gimbal_deg"),
            "max_gimbal_rate_subnormal.toml" => expect_field("vehicle.max_gimbal_rate_degps"),
            "vc_weight_1e12.toml" => expect_field("solver.virtual_control_weight"),
            "empty_name.toml" | "blank_name.toml" => {
                expect_field("name");
                let Outcome::Rejected(e) = &outcome else {
                    unreachable!()
                };
                assert!(matches!(e, InputError::Empty { .. }), "{name}: {e}");
            }
            "cg_at_length.toml" => expect_field("vehicle.cg_m"),
            "nodes_3.toml" => expect_field("discretization.nodes"),
            "intervals_too_many.toml" => expect_field("discretization.intervals"),
            "not_utf8.toml" | "not_utf8_in_comment.toml" => match &outcome {
                Outcome::Rejected(InputError::NotUtf8 { line, .. }) => {
                    assert!(*line > 1, "{name}: line {line}")
                }
                other => panic!("{name}: {other:?}"),
            },
            "paper.toml"
            | "min_thrust_eq_max.toml"
            | "nodes_4.toml"
            | "vector_formulation.toml"
            | "scvx_paper_formulation.toml" => match &outcome {
                Outcome::Ran(answers) => {
                    let methods: Vec<Method> = answers.iter().map(|a| a.0).collect();
                    assert_eq!(methods, [Method::Direct, Method::Scvx], "{name}");
                }
                other => panic!("{name}: {other:?}, expected a valid scenario"),
            },
            _ => {}
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
    // The corpus covers both sides of validation.
    assert!(rejected >= 15 && ran >= 8, "{rejected} rejected, {ran} ran");
}

/// The paper's case within the fuzz budget: the direct method solves it in
/// 60 iterations, so `solved` answers (and their invariants) are exercised.
#[test]
fn the_fuzz_budget_still_solves_the_paper_case() {
    let bytes = std::fs::read(corpus_dir().join("paper.toml")).unwrap();
    match exercise(&bytes) {
        Outcome::Ran(answers) => {
            assert_eq!(answers[0], (Method::Direct, Status::Solved), "{answers:?}");
        }
        other => panic!("{other:?}"),
    }
}

fn env_or(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .map(|v| {
            v.parse()
                .unwrap_or_else(|_| panic!("{name}={v} is not a count"))
        })
        .unwrap_or(default)
}

/// The bounded fuzz of `.ci/run`: seeded mutants of the corpus, no panic.
#[test]
fn seeded_mutants_of_the_corpus_never_panic() {
    let count = env_or("BELLYFLOP_FUZZ_MUTANTS", 2000);
    let seed = env_or("BELLYFLOP_FUZZ_SEED", 18);
    let files = corpus();
    let all: Vec<&[u8]> = files.iter().map(|(_, b)| b.as_slice()).collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let start = std::time::Instant::now();
    let mut failures = Vec::new();
    let (mut rejected, mut ran, mut solved) = (0u64, 0u64, 0u64);
    // Half the mutants start from a valid scenario, so that mutants reach
    // the solvers, not only the parser and validation.
    let valid: Vec<usize> = (0..files.len())
        .filter(|&i| {
            std::str::from_utf8(all[i]).is_ok_and(|t| bellyflop::Case::from_toml_str(t).is_ok())
        })
        .collect();
    assert!(valid.len() >= 8, "{} valid corpus files", valid.len());
    for k in 0..count {
        let k = k as usize;
        let base = if k.is_multiple_of(2) {
            valid[(k / 2) % valid.len()]
        } else {
            (k / 2) % files.len()
        };
        let mutant = mutate(all[base], &all, &mut rng);
        let label = format!("mutant {k} (seed {seed}) of {}", files[base].0);
        match run(&label, &mutant) {
            Ok(Outcome::Rejected(_)) => rejected += 1,
            Ok(Outcome::Ran(answers)) => {
                ran += 1;
                solved += answers.iter().filter(|a| a.1 == Status::Solved).count() as u64;
            }
            Err(e) => failures.push(e),
        }
    }
    eprintln!(
        "fuzz: {count} mutants (seed {seed}) in {:.1} s: {rejected} rejected, {ran} ran both methods ({solved} solved answers), {} panics",
        start.elapsed().as_secs_f64(),
        failures.len()
    );
    assert!(
        failures.is_empty(),
        "{} of {count} mutants broke an invariant:\n{}",
        failures.len(),
        failures.join("\n\n")
    );
    // A mutator that only produced garbage, or only valid files, would test
    // half of the pipeline.
    assert!(
        rejected >= count / 10 && ran >= count / 10,
        "{rejected} rejected, {ran} ran"
    );
}
