#!/usr/bin/env python3
"""Ours against the CasADi + IPOPT P2 reference on seeded random initial states.

Each state is drawn uniformly from the ranges of examples/convergence.rs's six
dispersed states (x0 in [-200, 200] m, z0 in [500, 800] m, Vx0 in [-15, 15] m/s,
Vz0 in [-95, -70] m/s, theta0 in [80, 95] deg, m0 in [110, 125] t), the rest of
the scenario is the paper's; both sides start from their straight-line guess on
the same N-point global LGR mesh.

    bench/dispersed_sweep.py                       # 40 states, seed 7, N = 20
    bench/dispersed_sweep.py --states 10 --table   # one line per state too
    bench/dispersed_sweep.py --solver "second_order_correction = false"

--solver appends a line to the scenario's [solver] table (repeatable), to
compare settings on the same states. Prints one summary line: how many ours
solved, our SCvx iterations and solve time, and how far our final mass is below
IPOPT's (reference minus ours, over the states both solved).
"""
import argparse
import json
import random
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BIN = ROOT / "target" / "release" / "bellyflop"
PY = ROOT / "bench" / "reference" / ".venv" / "bin" / "python"
REF = ROOT / "bench" / "reference" / "nlp_reference.py"


def states(count, seed):
    rng = random.Random(seed)
    for _ in range(count):
        yield (rng.uniform(-200, 200), rng.uniform(500, 800), rng.uniform(-15, 15),
               rng.uniform(-95, -70), rng.uniform(80, 95), rng.uniform(110000, 125000))


def scenario_text(state, nodes, solver_lines):
    s = (ROOT / "scenarios" / "paper.toml").read_text()
    keys = ("x_m", "z_m", "vx_mps", "vz_mps", "theta_deg", "mass_kg")
    for key, val in zip(keys, state):
        s = re.sub(rf"(?m)^{key} = .*", f"{key} = {val:.3f}", s, count=1)
    s = re.sub(r"(?m)^final_mass_guess_kg = .*", f"final_mass_guess_kg = {state[5] - 5000.0:.1f}", s, count=1)
    s = re.sub(r"(?m)^nodes = .*", f"nodes = {nodes}", s, count=1)
    # [solver] is the file's last table, so appended lines land in it.
    return s + "\n" + "\n".join(solver_lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--states", type=int, default=40)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--nodes", type=int, default=20)
    ap.add_argument("--solver", action="append", default=[], help="extra [solver] line")
    ap.add_argument("--table", action="store_true", help="one line per state")
    args = ap.parse_args()
    if not BIN.exists():
        subprocess.run(["cargo", "build", "--release"], cwd=ROOT, check=True)
    if not PY.exists():
        sys.exit("bench/reference/.venv is missing: run bench/compare.sh once to create it")

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "state.toml"
        for k, state in enumerate(states(args.states, args.seed)):
            path.write_text(scenario_text(state, args.nodes, args.solver))
            ours = json.loads(subprocess.run([str(BIN), "solve", "--scenario", str(path), "--json", "--quiet"],
                                             capture_output=True, text=True).stdout)
            ref = json.loads(subprocess.run([str(PY), str(REF), "--scenario", str(path), "--nodes",
                                             str(args.nodes), "--problem", "P2", "--json"],
                                            capture_output=True, text=True, check=True).stdout)
            rows.append((k, ours, ref))
            if args.table:
                print("%3d %-14s %3d its %7.1f ms  m_f %10.1f | IPOPT %s %3d its %6.1f ms m_f %10.1f | ref-ours %7.1f kg" % (
                    k, ours["status"], ours["iterations"], ours["solve_time_ms"], ours["final_mass_kg"],
                    "ok" if ref["success"] else "FAILED", ref["ipopt_iterations"], ref["solve_time_ms"],
                    ref["final_mass_kg"], ref["final_mass_kg"] - ours["final_mass_kg"]), flush=True)

    both = [(o, r) for _, o, r in rows if o["status"] == "solved" and r["success"]]
    gaps = [r["final_mass_kg"] - o["final_mass_kg"] for o, r in both]
    its = [o["iterations"] for _, o, _ in rows]
    print("N = %d, %d states (seed %d)%s: ours solved %d; SCvx iterations sum %d, median %.0f; "
          "solve time sum %.1f s; IPOPT sum %.1f s; IPOPT m_f - ours m_f over %d: median %.1f kg, "
          "max %.1f kg, sum %.0f kg, ours heavier by > 1 kg on %d" % (
              args.nodes, args.states, args.seed,
              "".join(f" [{line}]" for line in args.solver),
              sum(1 for _, o, _ in rows if o["status"] == "solved"), sum(its), statistics.median(its),
              sum(o["solve_time_ms"] for _, o, _ in rows) / 1e3,
              sum(r["solve_time_ms"] for _, _, r in rows) / 1e3,
              len(both), statistics.median(gaps), max(gaps), sum(gaps), sum(1 for g in gaps if g < -1.0)))


if __name__ == "__main__":
    main()
