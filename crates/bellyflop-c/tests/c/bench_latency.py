#!/usr/bin/env python3
"""Run the C API's latency bench (bench_latency.c) and its Rust counterpart
(examples/bench_latency.rs) alternately, PAIRS times each, on the re-plan
sequence in DIR (examples/sim_replans.rs), and print the tables of
BENCHMARKS.md. Fails if the two do not give the same answers bit for bit
(same status, iterations, adoption, t_f and m_f at every re-plan): then the
timings would not be of the same work. `make bench` runs it; run it under
`flock /tmp/bellyflop-bench.lock`."""
import argparse
import re
import shutil
import statistics
import subprocess
import sys


def run(cmd):
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    cold, replan, answers = [], {}, []
    for line in out.splitlines():
        w = line.split()
        if w[0] == "cold":
            cold.append(float(w[1]))
        elif w[0] == "replan":
            replan.setdefault(int(w[1]), []).append(float(w[3]))
        elif w[0] == "answer":
            answers.append(" ".join(w[1:]))
    return cold, replan, answers


def instructions(cmd, function):
    """Instructions executed inside `function` (inclusive), by callgrind."""
    err = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null",
                          f"--toggle-collect={function}"] + cmd,
                         check=True, capture_output=True, text=True).stderr
    return int(re.search(r"Collected : (\d+)", err).group(1))


def pct(xs, p):
    """Nearest-rank percentile."""
    s = sorted(xs)
    k = max(0, min(len(s) - 1, int(-(-p * len(s) // 100)) - 1))
    return s[k]


def main():
    a = argparse.ArgumentParser()
    a.add_argument("--c", required=True)
    a.add_argument("--rust", required=True)
    a.add_argument("--dir", required=True)
    a.add_argument("--pairs", type=int, default=7)
    a.add_argument("--cold-runs", type=int, default=50)
    a.add_argument("--rounds", type=int, default=50)
    o = a.parse_args()
    inputs = [f"{o.dir}/replans.txt", f"{o.dir}/planning.toml", str(o.cold_runs), str(o.rounds)]
    res = {"C": [], "Rust": []}
    for _ in range(o.pairs):
        res["C"].append(run([o.c] + inputs))
        res["Rust"].append(run([o.rust] + inputs))
    answers = {tuple(r[2]) for side in res.values() for r in side}
    if len(answers) != 1:
        print("error: the C and Rust benches gave different answers", file=sys.stderr)
        for side, rs in res.items():
            print(side, rs[0][2], file=sys.stderr)
        return 1
    (ans,) = answers
    its = [int(x.split()[2]) for x in ans]
    statuses = {}
    for x in ans:
        statuses[x.split()[1]] = statuses.get(x.split()[1], 0) + 1
    print(f"re-plan sequence: {len(ans)} re-plans, {o.rounds} rounds a run, {o.pairs} runs a side;"
          f" answers identical in C and Rust; statuses {statuses};"
          f" iterations p50 {statistics.median(its)}, max {max(its)}")
    print()
    print("| side | cold solve p50 [ms] | min | max | bf_replan p50 [ms] | p99 | max | calls |")
    print("|---|---|---|---|---|---|---|---|")
    for side, rs in res.items():
        cold = [c for r in rs for c in r[0]]
        rep = [t for r in rs for ts in r[1].values() for t in ts]
        print(f"| {side} | {pct(cold, 50):.3f} | {min(cold):.3f} | {max(cold):.3f} |"
              f" {pct(rep, 50):.3f} | {pct(rep, 99):.3f} | {max(rep):.3f} | {len(rep)} |")
    print()
    # Overhead: each run's C total over the Rust total of the run after it
    # (alternating, so slow drift of the machine cancels), then the median.
    cold_ratio = [statistics.median(c[0]) / statistics.median(r[0])
                  for c, r in zip(res["C"], res["Rust"])]
    rep_ratio = [sum(map(sum, c[1].values())) / sum(map(sum, r[1].values()))
                 for c, r in zip(res["C"], res["Rust"])]
    print("| C / Rust | median over runs | min | max |")
    print("|---|---|---|---|")
    for name, r in (("cold solve (p50 of a run)", cold_ratio),
                    ("re-plan sequence (total of a run)", rep_ratio)):
        print(f"| {name} | {statistics.median(r):.4f} | {min(r):.4f} | {max(r):.4f} |")
    if not shutil.which("valgrind"):
        print("error: valgrind is missing: no instruction counts", file=sys.stderr)
        return 1
    # The same calls counted in instructions (callgrind: the same count on
    # every run, whatever else the machine does): 1 + 5 cold solves, and
    # 2 rounds of the re-plan sequence. The Rust side counts the engine's
    # FlightSolver::solve and ::replan, the C side bf_solve and bf_replan
    # (which call them).
    files = inputs[:2]
    cases = (("cold solve", "5", "0", "bf_solve", "bellyflop_c::engine::FlightSolver::solve*", 6),
             ("bf_replan", "0", "2", "bf_replan", "bellyflop_c::engine::FlightSolver::replan*",
              2 * len(ans)))
    print()
    print("| instructions a call (callgrind) | C | Rust | C / Rust |")
    print("|---|---|---|---|")
    for name, cold, rounds, c_fn, rust_fn, calls in cases:
        ic = instructions([o.c] + files + [cold, rounds], c_fn)
        ir = instructions([o.rust] + files + [cold, rounds], rust_fn)
        print(f"| {name} | {ic / calls:.0f} | {ir / calls:.0f} | {ic / ir:.6f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
