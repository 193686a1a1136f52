#!/usr/bin/env python3
"""Simulate an early exit from the relaxed first phase on seeded dispersed states.

The rule: abandon the relaxed phase once an accepted iterate at iteration K or
later still needs virtual control >= V (scaled). The exact phase starts from the
straight line either way, so the rule only removes relaxed iterations; it is
harmful when it would abandon a relaxed phase that goes on to succeed. This
reads the progress lines of today's `bellyflop solve` (not built into it).

    bench/relaxed_exit_sim.py                          # 40 states, seed 7, N = 20, K = 3, V = 0.1
    bench/relaxed_exit_sim.py --seed 8 --k 5
    bench/relaxed_exit_sim.py --paper-tf 6 7 8         # the paper's case with these t_f guesses

States are bench/dispersed_sweep.py's. Prints the relaxed successes, the SCvx
iterations in all, the relaxed iterations the rule would save and the states it
would lose.
"""
import argparse
import importlib.util
import re
import subprocess
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BIN = ROOT / "target" / "release" / "bellyflop"
_spec = importlib.util.spec_from_file_location("ds", ROOT / "bench" / "dispersed_sweep.py")
ds = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(ds)


def phases(scenario_text):
    """(status, [[(virtual control, accepted), ...] per phase]) of one solve."""
    with tempfile.NamedTemporaryFile("w", suffix=".toml") as f:
        f.write(scenario_text)
        f.flush()
        p = subprocess.run([str(BIN), "solve", "--scenario", f.name],
                           capture_output=True, text=True, check=False)
    status = re.search(r"(?m)^status +(\S+)", p.stdout)
    runs, cur = [], []
    for line in p.stderr.splitlines():
        m = re.match(r"iter +(\d+) .*vc +(\S+) .*rho +\S+ +(\w+)", line)
        if not m:
            continue
        if int(m.group(1)) == 1 and cur:
            runs.append(cur)
            cur = []
        cur.append((float(m.group(2)), m.group(3).startswith("acc")))
    runs.append(cur)
    return (status.group(1) if status else "error"), runs


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--states", type=int, default=40)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--nodes", type=int, default=20)
    ap.add_argument("--k", type=int, default=3)
    ap.add_argument("--v", type=float, default=0.1)
    ap.add_argument("--paper-tf", type=float, nargs="*",
                    help="the paper's case with these t_f guesses instead of dispersed states")
    args = ap.parse_args()
    subprocess.run(["cargo", "build", "--release", "--quiet", "-p", "bellyflop-cli"],
                   cwd=ROOT, check=True)
    if args.paper_tf:
        base = (ROOT / "scenarios" / "paper.toml").read_text()
        base = re.sub(r"(?m)^nodes = .*", f"nodes = {args.nodes}", base, count=1)
        cases = [(f"t_f guess {tf}", re.sub(r"(?m)^tf_guess_s = .*", f"tf_guess_s = {tf}", base, count=1))
                 for tf in args.paper_tf]
    else:
        cases = [(f"state {k}", ds.scenario_text(st, args.nodes, []))
                 for k, st in enumerate(ds.states(args.states, args.seed))]
    successes = total = saved = 0
    lost = []
    for name, text in cases:
        status, runs = phases(text)
        relaxed = runs[0]
        ok = len(runs) == 1 and status == "solved"
        successes += ok
        total += sum(len(r) for r in runs)
        stop = next((i + 1 for i, (vc, acc) in enumerate(relaxed)
                     if i + 1 >= args.k and acc and vc >= args.v), None)
        if stop is not None:
            if ok:
                lost.append(name)
            else:
                saved += len(relaxed) - stop
    print(f"{len(cases)} cases, N = {args.nodes}: relaxed successes {successes}, SCvx iterations {total}; "
          f"rule K = {args.k}, V = {args.v}: saves {saved}, would lose {lost or 'none'}")


if __name__ == "__main__":
    main()
