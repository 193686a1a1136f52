//! The operational limits' certificate ([`feasibility::certify_limits`],
//! the approach cone's reachability bound) on scenario files, alone: which
//! it certifies, and its time. `solve` runs it only after the methods find
//! no trajectory; this runs it on every file, so that a solved state that
//! it certified would show.
//!
//!     bench/reference/.venv/bin/python bench/constraints.py --write /tmp/lim
//!     cargo run --release -p bellyflop --example limit_certificates -- /tmp/lim/*_cone.toml

use bellyflop::input::scenario::Case;
use bellyflop::problem::feasibility;

fn main() {
    let mut times = Vec::new();
    let mut certified = 0;
    let files: Vec<String> = std::env::args().skip(1).collect();
    for f in &files {
        let case = match Case::from_file(std::path::Path::new(f)) {
            Ok(c) => c,
            Err(e) => {
                eprintln!("{f}: {e}");
                continue;
            }
        };
        let clock = std::time::Instant::now();
        let c = feasibility::certify_limits(&case.scenario);
        times.push(clock.elapsed().as_secs_f64() * 1e3);
        if let Some(c) = c {
            certified += 1;
            println!("{f}: {c}");
        }
    }
    times.sort_by(f64::total_cmp);
    if let (Some(mid), Some(max)) = (times.get(times.len() / 2), times.last()) {
        println!(
            "{certified} of {} certified; time median {mid:.1} ms, max {max:.1} ms",
            times.len()
        );
    }
}
