#!/usr/bin/env python3
"""Issue 38: the raw 6-DoF collocation solve against CasADi + IPOPT on the
same 6-DoF transcription (bench/reference/nlp_6dof.py), side by side in one
run, on seeded 3-D states of the documented box (nlp_6dof.dispersed_starts:
cross-range +-200 m and +-15 m/s, yaw and roll +-20 deg, body rates +-5 deg/s).

Both solve from the reference's straight line (t_f guess 12 s, m_f guess
m_0 - 5 t) at the same global LGR mesh. Ours is the direct method
(`cargo run --release --example six_dof_states`); its time includes building
the transcription and the guess, IPOPT's only its solver call (CasADi's
symbolic build is left out). Each time is the median of --repeat solves,
ours and IPOPT's of one state one after the other.
Both answers' controls are flown by the reference's reintegrate6 (DOP853).

    cargo build --release -p bellyflop --example six_dof_states
    bench/reference/.venv/bin/python bench/six_dof_vs_ipopt.py --states 100 --repeat 3 --table
"""
import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench" / "reference"))
import nlp_6dof as six  # noqa: E402

EXAMPLE = ROOT / "target" / "release" / "examples" / "six_dof_states"


def percentile(values, q):
    v = sorted(values)
    return v[min(len(v) - 1, int(round(q * (len(v) - 1))))]


def ours(starts, nodes, repeat):
    """Our solves of (name, sc, start) from the example binary."""
    states = [dict(name=name, start=list(map(float, start)), tf_guess_s=float(sc.tf_guess),
                   mf_guess_kg=float(sc.mf_guess)) for name, sc, start, _ in starts]
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump(dict(nodes=nodes, repeat=repeat, states=states), f)
    out = subprocess.run([str(EXAMPLE), f.name], capture_output=True, text=True, check=True).stdout
    return {r["name"]: r for r in json.loads(out)["results"]}


def flown(sc, nodes, start, X, U, tf):
    end, lowest = six.reintegrate6(sc, nodes, start, X, U, tf)
    pad = np.array([sc.xf[0], 0.0, sc.xf[1]])
    return float(np.linalg.norm(end[0:3] - pad)), float(lowest - sc.xf[1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default=str(ROOT / "scenarios" / "paper.toml"))
    ap.add_argument("--states", type=int, default=100)
    ap.add_argument("--seed", type=int, default=38)
    ap.add_argument("--nodes", type=int, default=20)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--table", action="store_true", help="a Markdown summary for BENCHMARKS.md")
    a = ap.parse_args(argv)
    if not EXAMPLE.exists():
        sys.exit(f"build it first: cargo build --release -p bellyflop --example six_dof_states ({EXAMPLE})")
    rows = []
    for name, sc, start, upright in six.dispersed_starts(a.scenario, a.states, a.seed):
        # One state at a time, ours then IPOPT's, so that both see the
        # machine in the same state.
        me = ours([(name, sc, start, upright)], a.nodes, a.repeat)[name]
        ref = six.Nlp6(sc, a.nodes).solve(start, upright, a.repeat)
        n = a.nodes
        X = np.array(me["states"]).reshape(n + 1, six.NX)
        U = np.array(me["controls"]).reshape(n, six.NU)
        miss, lowest = flown(sc, n, start, X, U, me["tf_s"])
        row = dict(name=name, ipopt_converged=ref["converged"], ipopt_status=ref["status"],
                   ipopt_iterations=ref["iterations"], ipopt_mf_kg=ref["mf_kg"], ipopt_tf_s=ref["tf_s"],
                   ipopt_ms=ref["time_ms"], ours_status=me["status"], ours_iterations=me["iterations"],
                   ours_mf_kg=me["mf_kg"], ours_tf_s=me["tf_s"], ours_ms=me["time_ms"],
                   dm_kg=me["mf_kg"] - ref["mf_kg"], ours_flown_miss_m=miss, ours_flown_lowest_m=lowest)
        rows.append(row)
        print(f"{name:9s} IPOPT {ref['status'][:20]:20s} {ref['iterations']:4d} it {ref['mf_kg']:10.2f} kg "
              f"{ref['time_ms']:7.1f} ms | ours {me['status']:14s} {me['iterations']:3d} it "
              f"{me['mf_kg']:10.2f} kg {me['time_ms']:6.1f} ms | dm {row['dm_kg']:+8.3f} kg "
              f"x{ref['time_ms'] / me['time_ms']:5.1f}", file=sys.stderr)
    both = [r for r in rows if r["ipopt_converged"] and r["ours_status"] == "solved"]
    only_ipopt = [r["name"] for r in rows if r["ipopt_converged"] and r["ours_status"] != "solved"]
    only_ours = [r["name"] for r in rows if not r["ipopt_converged"] and r["ours_status"] == "solved"]
    ratio = [r["ipopt_ms"] / r["ours_ms"] for r in both]
    dm = [r["dm_kg"] for r in both]
    summary = dict(
        states=len(rows), nodes=a.nodes, seed=a.seed, repeat=a.repeat,
        ipopt_converged=sum(r["ipopt_converged"] for r in rows),
        ours_solved=sum(r["ours_status"] == "solved" for r in rows),
        both=len(both), only_ipopt=only_ipopt, only_ours=only_ours,
        ours_ms_median=statistics.median(r["ours_ms"] for r in both) if both else None,
        ours_ms_p95=percentile([r["ours_ms"] for r in both], 0.95) if both else None,
        ours_ms_worst=max(r["ours_ms"] for r in both) if both else None,
        ipopt_ms_median=statistics.median(r["ipopt_ms"] for r in both) if both else None,
        ipopt_ms_p95=percentile([r["ipopt_ms"] for r in both], 0.95) if both else None,
        ratio_median=statistics.median(ratio) if ratio else None,
        ratio_p5=percentile(ratio, 0.05) if ratio else None,
        ratio_worst=min(ratio) if ratio else None,
        dm_worst_kg=min(dm) if dm else None,
        below_ipopt_by_more_than_half_kg=[r["name"] for r in both if r["dm_kg"] < -0.5],
        above_ipopt_by_more_than_half_kg=[(r["name"], round(r["dm_kg"], 1)) for r in both if r["dm_kg"] > 0.5],
        ours_iterations_median=statistics.median(r["ours_iterations"] for r in both) if both else None,
        ipopt_iterations_median=statistics.median(r["ipopt_iterations"] for r in both) if both else None,
        ours_flown_miss_m_median=statistics.median(r["ours_flown_miss_m"] for r in both) if both else None,
        ours_flown_below_ground=sum(r["ours_flown_lowest_m"] < -1e-3 for r in both),
    )
    if a.table:
        s = summary
        print(f"| states | both solve | only IPOPT | only ours | ours median (p95, worst) | IPOPT median (p95) "
              f"| ratio median (p5, worst) | m_f: worst below IPOPT | above IPOPT by > 0.5 kg |")
        print("|---|---|---|---|---|---|---|---|---|")
        print(f"| {s['states']} | {s['both']} | {len(s['only_ipopt'])} | {len(s['only_ours'])} | "
              f"{s['ours_ms_median']:.1f} ms ({s['ours_ms_p95']:.1f}, {s['ours_ms_worst']:.1f}) | "
              f"{s['ipopt_ms_median']:.1f} ms ({s['ipopt_ms_p95']:.1f}) | {s['ratio_median']:.1f}× "
              f"({s['ratio_p5']:.1f}×, {s['ratio_worst']:.1f}×) | {-s['dm_worst_kg']:.3f} kg | "
              f"{len(s['above_ipopt_by_more_than_half_kg'])} |")
    print(json.dumps(dict(summary=summary), indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
