//! The Rust answer the C test compares with: the paper's case solved cold
//! by the library's own [`Planner`] (what `bf_solve` wraps), its t_f and
//! m_f printed as the bits of the doubles, so that the C side can check
//! them bit for bit.
//!
//! `cargo run --release -p bellyflop-c --example reference`
//! prints `tf_bits=0x… mf_bits=0x… status=solved`.

use bellyflop::guidance::planner::Planner;
use bellyflop::method::observer::Silent;
use bellyflop::Case;

fn main() {
    let case = Case::paper();
    let mut planner = Planner::new(case.scenario, case.solver);
    let sol = planner.cold(&mut Silent);
    println!(
        "tf_bits=0x{:016x} mf_bits=0x{:016x} status={}",
        sol.tf_s.to_bits(),
        sol.final_mass_kg.to_bits(),
        sol.status.as_str()
    );
}
