#!/usr/bin/env python3
"""Issue 38: the polished 6-DoF default (`pipeline::six_dof::solve`: the raw
direct solve, the 6-DoF polish, the flown check) on the seeded 3-D states of
bench/six_dof_vs_ipopt.py (nlp_6dof.dispersed_starts), one solve each; with
--ipopt, IPOPT's raw solve of each state at the same N beside it, for the
final masses; with --fine K, IPOPT on a fine mesh (40 intervals of 8 LGR
points, the issue's "40 x 8") on the first K states, the reference for the
polished final mass (about a minute per state).

    cargo build --release -p bellyflop --example six_dof_states
    bench/reference/.venv/bin/python bench/six_dof_polish.py --states 100 --ipopt
    bench/reference/.venv/bin/python bench/six_dof_polish.py --states 20 --fine 20
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

sys.path.insert(0, str(ROOT / "bench"))
from six_dof_vs_ipopt import EXAMPLE, percentile  # noqa: E402

# The fine reference mesh: intervals x points per interval.
FINE_INTERVALS, FINE_POINTS = 40, 8


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default=str(ROOT / "scenarios" / "paper.toml"))
    ap.add_argument("--states", type=int, default=100)
    ap.add_argument("--seed", type=int, default=38)
    ap.add_argument("--nodes", type=int, default=20)
    ap.add_argument("--ipopt", action="store_true", help="IPOPT's raw final mass beside ours")
    ap.add_argument("--fine", type=int, default=0, metavar="K",
                    help="IPOPT on the 40 x 8 mesh on the first K states, against the polished final mass")
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
    if a.fine:
        summary.update(fine_reference(starts[:a.fine], {r["name"]: r for r in rows}))
    print(json.dumps(summary, indent=1))
    return 0


def fine_reference(starts, ours):
    """IPOPT on the fine mesh from the reference's straight line, and the
    polished final mass against it where both are trustworthy (IPOPT
    converged, ours solved)."""
    per_state, gaps = [], []
    for name, sc, start, upright in starts:
        ref = six.Nlp6(sc, FINE_INTERVALS * FINE_POINTS, intervals=FINE_INTERVALS).solve(start, upright, 1)
        mine = ours[name]
        row = dict(name=name, ipopt_status=ref["status"], ipopt_converged=ref["converged"], fine_mf_kg=ref["mf_kg"],
                   ours_status=mine["status"], ours_mf_kg=mine["mf_kg"])
        if ref["converged"] and mine["status"] == "solved":
            row["polished_minus_fine_kg"] = mine["mf_kg"] - ref["mf_kg"]
            gaps.append(row["polished_minus_fine_kg"])
        per_state.append(row)
        print(json.dumps(row), file=sys.stderr, flush=True)
    gaps.sort()
    return dict(fine_states=len(starts), fine_compared=len(gaps),
                fine_ipopt_converged=sum(1 for r in per_state if r["ipopt_converged"]),
                polished_minus_fine_kg_median=statistics.median(gaps) if gaps else None,
                polished_minus_fine_kg_worst_below=gaps[0] if gaps else None,
                polished_minus_fine_kg_most_above=gaps[-1] if gaps else None,
                within_half_kg=sum(1 for g in gaps if g >= -0.5))


if __name__ == "__main__":
    sys.exit(main())
