#!/usr/bin/env python3
"""Experiment (issue 35): would a multiple-shooting (lifted) polish leave a
smaller second-order residual per step than today's single shooting?

Reads the LIFT lines that bench/experiments/lift-probe.patch prints for
every QP step of the polish (through polish_variants.py --log FILE with
BF_LIFT=1) and summarizes, by the size of the step's single-shooting
landing residual:
- single: Σ|R⁻¹·(y_f(p + Δp) − y_f(p) − ∂y_f/∂p·Δp)|, the landing residual
  that the step leaves beyond its linearization (today's polish);
- lifted: Σ_j Σ|R⁻¹·c_j|, the defects that the same step leaves at the 20-odd
  segment ends when each segment starts from its linear prediction (the
  lifted Newton step, Albersmeyer & Diehl 2010).

    git apply bench/experiments/lift-probe.patch && cargo build --release
    bench/reference/.venv/bin/python bench/experiments/polish_variants.py --fine /tmp/fine.json --all --env BF_LIFT=1 --log /tmp/lift.log
    python3 bench/experiments/lift_summary.py /tmp/lift.log
"""
import re
import statistics
import sys


def main():
    rows = []
    for line in open(sys.argv[1]):
        if " LIFT " not in line:
            continue
        v = dict(re.findall(r"(\w+)=([-\d.e+]+)", line))
        rows.append((float(v["single"]), float(v["lifted_sum"]), float(v["lifted_max"])))
    print(f"{len(rows)} QP steps")
    print("| single residual | steps | single / lifted sum: median (p10, p90) | single / largest defect: median |")
    print("|---|---|---|---|")
    for lo, hi in [(0, 1e-2), (1e-2, 0.2), (0.2, float("inf"))]:
        r = [x for x in rows if lo <= x[0] < hi]
        if not r:
            continue
        ratio = sorted(s / l for s, l, _ in r)
        worst = statistics.median(s / m for s, _, m in r)
        print(f"| [{lo:g}, {hi:g}) | {len(r)} | {statistics.median(ratio):.2f} "
              f"({ratio[len(r) // 10]:.2f}, {ratio[9 * len(r) // 10]:.2f}) | {worst:.1f} |")


if __name__ == "__main__":
    main()
