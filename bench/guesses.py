#!/usr/bin/env python3
"""Issue 29: the direct method on issue 15's seeded states with the
straight-line guess derived from the state (guess fields left out) against
the guesses given as the benchmark gives them today (t_f 12 s, m_f = m0 - 5 t).

    cargo build --release -p bellyflop-cli
    bench/guesses.py                  # 100 box + 50 wide states, seed 15, N = 20
    bench/guesses.py --nodes 40 --table

The states are bench/envelope.py's (same boxes, seed and order). Prints the
states converged (`solved` or `inaccurate`) each way, the largest optimum
difference on the states both converge, and the median iterations.
"""
import argparse
import json
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import envelope  # noqa: E402  (states() and scenario_text(): the benchmark's own)

CONVERGED = {"solved", "inaccurate"}


def solve(text, path):
    path.write_text(text)
    out = subprocess.run([str(envelope.BIN), "solve", "--scenario", str(path), "--method", "direct",
                          "--json", "--quiet"], capture_output=True, text=True)
    if out.returncode == 2:
        raise SystemExit(f"bad input: {out.stderr}")
    return json.loads(out.stdout)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--box", type=int, default=100)
    ap.add_argument("--wide", type=int, default=50)
    ap.add_argument("--seed", type=int, default=15)
    ap.add_argument("--nodes", type=int, default=20)
    ap.add_argument("--table", action="store_true", help="one line per state")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "case.toml"
        for name, state in envelope.states(args.box, args.wide, args.seed):
            given = envelope.scenario_text(state, args.nodes)
            derived = re.sub(r"(?m)^(tf_guess_s|final_mass_guess_kg) = .*\n", "", given)
            assert derived.count("guess") < given.count("guess")
            a, b = solve(given, path), solve(derived, path)
            rows.append((name, a, b))
            if args.table:
                print(f"{name:7} given {a['status']:13} {a['iterations']:3} its {a['final_mass_kg']:10.2f} kg | "
                      f"derived {b['status']:13} {b['iterations']:3} its {b['final_mass_kg']:10.2f} kg")
    ok = lambda v: v["status"] in CONVERGED  # noqa: E731
    both = [(a, b) for _, a, b in rows if ok(a) and ok(b)]
    gap = max((abs(a["final_mass_kg"] - b["final_mass_kg"]) for a, b in both), default=float("nan"))
    over = sum(abs(a["final_mass_kg"] - b["final_mass_kg"]) > 0.1 for a, b in both)
    med = lambda k: statistics.median(r[k]["iterations"] for r in rows)  # noqa: E731
    n = len(rows)
    print(f"seed {args.seed}, {args.box} box + {args.wide} wide states, N = {args.nodes}, direct method")
    print(f"| guesses | converged | median iterations |")
    print(f"|---|---|---|")
    print(f"| given (t_f 12 s, m_f = m0 - 5 t) | {sum(ok(a) for _, a, _ in rows)}/{n} | {med(1)} |")
    print(f"| derived from the state | {sum(ok(b) for _, _, b in rows)}/{n} | {med(2)} |")
    print(f"both converged: {len(both)}; largest |m_f difference| {gap:.4f} kg; over 0.1 kg on {over}")
    print(f"median iterations change {100 * (med(2) - med(1)) / med(1):+.1f} %")


if __name__ == "__main__":
    main()
