#!/usr/bin/env python3
"""hp mesh refinement on the paper's case and on seeded dispersed states
(issue 16's "Must show"), with bellyflop's CLI on every side:

- single: the scenario's own mesh (N = 20, global), as `bellyflop solve`;
- refined: the same with `--mesh-tolerance TOL` (refinement from that mesh);
- reference: a much finer uniform mesh (default 20 intervals x 8 points).

The states are issue 15's (bench/envelope.py's `states`, seed 15: the first
--box of the documented box); the paper's case comes first. Per state it
prints the refined answer's landing error (its controls re-integrated,
interpolated per interval: the CLI's `landing_error`), its points, passes
and largest interval error, its final mass against the reference's, and
its solve time against the single solve's (each the median of --repeat
solves in one process, `solve --repeat`). Then a summary against the
issue's targets.

    bench/refinement.py --box 100 --tolerance 1e-6 [--save /tmp/refine.csv]
"""
import argparse
import csv
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from envelope import BIN, ROOT, scenario_text, states  # noqa: E402


def solve(path, args):
    out = subprocess.run([str(BIN), "solve", "--scenario", str(path), "--json", *args],
                         capture_output=True, text=True)
    try:
        return json.loads(out.stdout)
    except json.JSONDecodeError:
        return {"status": "error", "message": out.stderr.strip()[-300:]}


def landing(v):
    e = v.get("landing_error") or {}
    return e.get("position_m", float("nan")), e.get("velocity_mps", float("nan"))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--box", type=int, default=100, help="states from the documented box")
    ap.add_argument("--seed", type=int, default=15)
    ap.add_argument("--tolerance", type=float, default=1e-6)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--reference", default="20x8", help="INTERVALSxPOINTS of the reference mesh")
    ap.add_argument("--no-paper", action="store_true", help="skip the paper's case")
    ap.add_argument("--save", help="write the rows to this CSV")
    args = ap.parse_args()
    ref_m, ref_p = (int(x) for x in args.reference.split("x"))
    subprocess.run(["cargo", "build", "--release", "-q", "-p", "bellyflop-cli"], cwd=ROOT, check=True)
    cases = [] if args.no_paper else [("paper", None)]
    cases += list(states(args.box, 0, args.seed))
    rows = []
    print(f"tolerance {args.tolerance:g}, reference {ref_m} x {ref_p}, repeat {args.repeat}, seed {args.seed}")
    print(f"{'state':8} {'status':10} {'N':>3} {'M':>2} {'passes':>6} {'max e_k':>8} "
          f"{'land m':>8} {'land m/s':>8} {'m_f - ref':>9} {'refined ms':>10} {'single ms':>9} {'ratio':>6}")
    with tempfile.TemporaryDirectory() as tmp:
        for name, state in cases:
            path = Path(tmp) / f"{name}.toml"
            if state is None:
                path.write_text((ROOT / "scenarios" / "paper.toml").read_text())
            else:
                path.write_text(scenario_text(state, 20))
            rep = ["--repeat", str(args.repeat)]
            single = solve(path, rep)
            refined = solve(path, rep + ["--mesh-tolerance", str(args.tolerance)])
            ref = solve(path, ["--intervals", str(ref_m), "--nodes", str(ref_m * ref_p)])
            pos, vel = landing(refined)
            passes = (refined.get("refinement") or {}).get("passes", [])
            row = {
                "state": name,
                "status": refined.get("status"),
                "stop": (refined.get("refinement") or {}).get("stop"),
                "nodes": refined.get("nodes"),
                "intervals": refined.get("intervals"),
                "passes": len(passes),
                "pass_ms": ";".join(f"{p['solve_time_ms']:.2f}" for p in passes),
                "pass_nodes": ";".join(str(p["nodes"]) for p in passes),
                "max_error": passes[-1]["max_relative_error"] if passes else float("nan"),
                "landing_m": pos,
                "landing_mps": vel,
                "mass_error_kg": (refined.get("propagation") or {}).get("mass_error_kg", float("nan")),
                "pass_iterations": ";".join(str(p["iterations"]) for p in passes),
                "mf_kg": refined.get("final_mass_kg", float("nan")),
                "ref_status": ref.get("status"),
                "ref_mf_kg": ref.get("final_mass_kg", float("nan")),
                "refined_ms": refined.get("solve_time_ms", float("nan")),
                "single_ms": single.get("solve_time_ms", float("nan")),
                "single_status": single.get("status"),
                "single_landing_m": landing(single)[0],
            }
            row["gap_kg"] = row["mf_kg"] - row["ref_mf_kg"]
            row["ratio"] = row["refined_ms"] / row["single_ms"]
            rows.append(row)
            print(f"{name:8} {row['status']!s:10} {row['nodes']!s:>3} {row['intervals']!s:>2} {row['passes']:>6} "
                  f"{row['max_error']:8.1e} {pos:8.4f} {vel:8.4f} {row['gap_kg']:9.3f} "
                  f"{row['refined_ms']:10.2f} {row['single_ms']:9.2f} {row['ratio']:6.2f}", flush=True)
    if args.save:
        with open(args.save, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    summarize(rows, args.tolerance)


def summarize(rows, tol):
    n = len(rows)
    met = [r for r in rows if r["max_error"] <= tol]
    lands = [r for r in rows if r["landing_m"] <= 0.1 and r["landing_mps"] <= 0.05]
    within = [r for r in rows if abs(r["gap_kg"]) <= 1.0]
    ratios = [r["ratio"] for r in rows]
    print()
    print(f"tolerance met: {len(met)}/{n}; stops: "
          + ", ".join(f"{s} {sum(r['stop'] == s for r in rows)}" for s in sorted({str(r['stop']) for r in rows})))
    print(f"landing <= 0.1 m and <= 0.05 m/s: {len(lands)}/{n}; worst {max(r['landing_m'] for r in rows):.4f} m, "
          f"{max(r['landing_mps'] for r in rows):.4f} m/s (single N = 20: worst {max(r['single_landing_m'] for r in rows):.2f} m)")
    me = sorted(abs(r["mass_error_kg"]) for r in rows)
    print(f"re-integrated minus optimized final mass: median |.| {statistics.median(me):.3f} kg, worst {me[-1]:.3f} kg")
    warm = [int(x) for r in rows for x in r["pass_iterations"].split(";")[1:] if x]
    if warm:
        print(f"interior-point iterations per warm pass: median {statistics.median(warm)}, max {max(warm)}")
    print(f"points: max {max(r['nodes'] or 0 for r in rows)}, median {statistics.median(r['nodes'] or 0 for r in rows)}; "
          f"passes: median {statistics.median(r['passes'] for r in rows)}, max {max(r['passes'] for r in rows)}")
    print(f"final mass within 1 kg of the reference: {len(within)}/{n}; worst {max(abs(r['gap_kg']) for r in rows):.3f} kg "
          f"(reference solved on {sum(r['ref_status'] in ('solved', 'inaccurate') for r in rows)}/{n})")
    total_r, total_s = sum(r["refined_ms"] for r in rows), sum(r["single_ms"] for r in rows)
    print(f"time: refined {total_r / 1e3:.2f} s against single {total_s / 1e3:.2f} s in all ({total_r / total_s:.2f}x); "
          f"per state median {statistics.median(ratios):.2f}x, max {max(ratios):.2f}x; "
          f"<= 3x on {sum(x <= 3.0 for x in ratios)}/{n}")


if __name__ == "__main__":
    main()
