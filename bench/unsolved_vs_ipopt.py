#!/usr/bin/env python3
"""Issue 37: are the states that a limit leaves unsolved feasible at all?

For each state of bench/envelope.py (issue 15's box, seed 15), solves the
default (`bellyflop solve --json`) with one `init` default limit of
bench/constraints.py; for every answer that is not `solved`, runs the
CasADi + IPOPT reference (bench/reference/nlp_reference.py) on the same
constrained transcription at N = 20, at N = 20 with the ground at every
node (--ground), and at N = 40, and reports how many of them IPOPT also
finds (locally) infeasible. IPOPT's verdict is local too: it is evidence,
not a proof.

    bench/reference/.venv/bin/python bench/unsolved_vs_ipopt.py --limit cone
"""
import argparse
import json
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from constraints import LIMITS, solve, with_limits  # noqa: E402
from envelope import BIN, PY, REF, scenario_text, states  # noqa: E402

RUNS = {"N = 20": [], "N = 20, ground": ["--ground"], "N = 40": ["--nodes", "40"]}


def ipopt(path, extra):
    out = subprocess.run([str(PY), str(REF), "--scenario", str(path), "--json"] + extra,
                         capture_output=True, text=True).stdout
    j = json.loads(out)
    return j["status"], j.get("final_mass_kg")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--limit", choices=sorted(LIMITS), default="cone")
    ap.add_argument("--box", type=int, default=150)
    ap.add_argument("--seed", type=int, default=15)
    ap.add_argument("--bin", default=str(BIN))
    args = ap.parse_args()
    ours = Counter()
    verdicts = []
    with tempfile.TemporaryDirectory() as d:
        for name, state in states(args.box, 0, args.seed):
            path = Path(d) / f"{name}.toml"
            text = with_limits(scenario_text(state, 20), LIMITS[args.limit])
            sol = solve(args.bin, path, text)
            ours[sol["status"]] += 1
            if sol["status"] == "solved":
                continue
            path.write_text(text)
            v = {run: ipopt(path, extra) for run, extra in RUNS.items()}
            verdicts.append((name, sol["status"], sol["solve_time_ms"], v))
            print(name, sol["status"], f"{sol['solve_time_ms']:.0f} ms",
                  {run: s for run, (s, _) in v.items()}, flush=True)
    print(f"\nlimit {args.limit}, {args.box} states (seed {args.seed}): ours {dict(ours)}")
    for run in RUNS:
        inf = sum(v[run][0] == "Infeasible_Problem_Detected" for _, _, _, v in verdicts)
        ok = sum(v[run][0] == "Solve_Succeeded" for _, _, _, v in verdicts)
        print(f"IPOPT {run} on our {len(verdicts)} unsolved: {inf} infeasible, {ok} solved, "
              f"{len(verdicts) - inf - ok} other")
    feasible = [n for n, _, _, v in verdicts if any(s == "Solve_Succeeded" for s, _ in v.values())]
    print("feasible for IPOPT in some run:", ", ".join(feasible) or "none")


if __name__ == "__main__":
    main()
