#!/usr/bin/env python3
"""Issue 38: the polished 6-DoF default (`pipeline::six_dof::solve`: the raw
direct solve, the 6-DoF polish, the flown check) on the seeded 3-D states of
bench/six_dof_vs_ipopt.py (nlp_6dof.dispersed_starts), one solve each; with
--ipopt, IPOPT's raw solve of each state at the same N beside it, for the
final masses.

    cargo build --release -p bellyflop --example six_dof_states
    bench/reference/.venv/bin/python bench/six_dof_polish.py --states 100 --ipopt
"""
import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench" / "reference"))
import nlp_6dof as six  # noqa: E402

EXAMPLE = ROOT / "target" / "release" / "examples" / "six_dof_states"


def percentile(values, q):
    v = sorted(values)
    return v[min(len(v) - 1, int(round(q * (len(v) - 1))))]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default=str(ROOT / "scenarios" / "paper.toml"))
    ap.add_argument("--states", type=int, default=100)
    ap.add_argument("--seed", type=int, default=38)
    ap.add_argument("--nodes", type=int, default=20)
    ap.add_argument("--ipopt", action="store_true", help="IPOPT's raw final mass beside ours")
    a = ap.parse_args(argv)
    if not EXAMPLE.exists():
        sys.exit(f"build it first: cargo build --release -p bellyflop --example six_dof_states ({EXAMPLE})")
    starts = list(six.dispersed_starts(a.scenario, a.states, a.seed))
    states = [dict(name=name, start=list(map(float, start)), tf_guess_s=float(sc.tf_guess),
                   mf_guess_kg=float(sc.mf_guess)) for name, sc, start, _ in starts]
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump(dict(nodes=a.nodes, repeat=1, pipeline=True, states=states), f)
    out = subprocess.run([str(EXAMPLE), f.name], capture_output=True, text=True, check=True).stdout
    rows = json.loads(out)["results"]
    solved = [r for r in rows if r["status"] == "solved"]
    times = [r["time_ms"] for r in rows]
    reasons = {}
    for r in rows:
        if r["status"] != "solved":
            m = r["message"]
            key = m[m.rfind("(") + 1:m.rfind(")")] if "did not converge" in m else m[-100:]
            reasons[key] = reasons.get(key, 0) + 1
    summary = dict(
        states=len(rows), solved=len(solved),
        worst_miss_m=max((r["flown"]["landing_miss_m"] for r in solved), default=None),
        worst_miss_mps=max((r["flown"]["landing_miss_mps"] for r in solved), default=None),
        lowest_m=min((r["flown"]["lowest_altitude_m"] for r in solved), default=None),
        time_ms_median=statistics.median(times), time_ms_p95=percentile(times, 0.95), time_ms_worst=max(times),
        solved_time_ms_median=statistics.median(r["time_ms"] for r in solved) if solved else None,
        solved_time_ms_p95=percentile([r["time_ms"] for r in solved], 0.95) if solved else None,
        solved_time_ms_worst=max(r["time_ms"] for r in solved) if solved else None,
        polish_iterations_median=statistics.median(r["polish_iterations"] or 0 for r in rows),
        polish_iterations_worst=max(r["polish_iterations"] or 0 for r in rows),
        not_solved=reasons,
    )
    if a.ipopt:
        ref = {name: six.Nlp6(sc, a.nodes).solve(start, upright, 1)["mf_kg"] for name, sc, start, upright in starts}
        dm = sorted(r["mf_kg"] - ref[r["name"]] for r in solved)
        summary.update(polished_minus_ipopt_raw_kg_median=statistics.median(dm), worst_below=dm[0], most_above=dm[-1])
    print(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
