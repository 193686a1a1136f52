//! `solve --repeat R`, planar and 6-DoF alike: the same solve R times in
//! this process, reported by the median solve time (and its minimum and
//! maximum), as the IPOPT reference's `--repeat` does. Every run must give
//! the same answer: the solvers are deterministic, and a difference is
//! reported on stderr.

use bellyflop::solution::Status;

/// Solve `repeat` times (at least once) by `solve`, whose argument is true
/// on the first run only (the one that may show progress); `outcome` reads
/// an answer's status, final mass and solve time. The last answer, with
/// its own solve time, and the sorted times.
pub fn repeated<T, E>(
    repeat: u32,
    mut solve: impl FnMut(bool) -> Result<T, E>,
    outcome: impl Fn(&T) -> (Status, f64, f64),
) -> Result<(T, Vec<f64>), E> {
    let mut answer = solve(true)?;
    let (mut status, mut mass_kg, time_ms) = outcome(&answer);
    let mut times_ms = vec![time_ms];
    for _ in 1..repeat {
        let again = solve(false)?;
        let (again_status, again_mass_kg, time_ms) = outcome(&again);
        if again_status != status || again_mass_kg != mass_kg {
            errln!(
                "warning: a repeated solve differed: {} at {} kg, then {} at {} kg",
                status.as_str(),
                mass_kg,
                again_status.as_str(),
                again_mass_kg
            );
        }
        times_ms.push(time_ms);
        (answer, status, mass_kg) = (again, again_status, again_mass_kg);
    }
    times_ms.sort_by(f64::total_cmp);
    Ok((answer, times_ms))
}

/// The median of the sorted `times_ms` (NaN for none).
pub fn median(times_ms: &[f64]) -> f64 {
    match times_ms.len() {
        0 => f64::NAN,
        k => 0.5 * (times_ms[(k - 1) / 2] + times_ms[k / 2]),
    }
}

/// With more than one run, `repeat` and the least and largest of the
/// sorted `times_ms` in the JSON (`solve_time_ms` is their median).
pub fn add_json(v: &mut serde_json::Value, repeat: u32, times_ms: &[f64]) {
    if let (true, Some(min), Some(max)) = (repeat > 1, times_ms.first(), times_ms.last()) {
        v["repeat"] = repeat.into();
        v["solve_time_min_ms"] = (*min).into();
        v["solve_time_max_ms"] = (*max).into();
    }
}

/// The summary's solve time: `median_ms`, and with more than one run of
/// the sorted `times_ms` their count, least and largest.
pub fn time_text(median_ms: f64, times_ms: &[f64]) -> String {
    match (times_ms.first(), times_ms.last()) {
        (Some(min), Some(max)) if times_ms.len() > 1 => format!(
            "{median_ms:.1} ms (median of {} runs; min {min:.1} ms, max {max:.1} ms)",
            times_ms.len()
        ),
        _ => format!("{median_ms:.1} ms"),
    }
}
