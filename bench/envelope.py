#!/usr/bin/env python3
"""Both methods against the CasADi + IPOPT P2 reference over the envelope.

Draws seeded initial states from the documented box (issue 15):
    x0 +-200 m, z0 500-800 m, Vx0 +-15 m/s, Vz0 -95 to -70 m/s,
    theta0 80-95 deg, m0 110-125 t
and from the wider box:
    x0 +-300 m, z0 450-900 m, Vx0 +-20 m/s, Vz0 -100 to -60 m/s,
    theta0 75-100 deg, m0 105-128 t.
The rest of each scenario is the paper's (final-mass guess m0 - 5 t). Every
solver starts from its straight-line guess on the same N-point global LGR mesh.

    bench/envelope.py                          # 100 + 50 states, N = 20 and 40
    bench/envelope.py --box 10 --wide 5 --nodes 20 --table
    bench/envelope.py --methods direct         # skip SCvx
    bench/envelope.py --methods direct --save /tmp/envelope{n}.csv   # then examples/envelope_direct.rs

The reference runs with --ground, bellyflop's ground bound z >= z_f, so that
both solve the same program (without it IPOPT's answer dips below the pad on
some states, which is not a landing).

Times are each solver's own solve time, timed the same way on both sides:
the median of --repeat solves in one process (ours: `solve_time_ms` of
`bellyflop solve --json --repeat R`; IPOPT: the reference's `--repeat R`,
build excluded), summed over the states.
Prints, per N and method: states converged (`solved` or `inaccurate`: see
CONVERGED; how many were inaccurate; and on how many IPOPT converged),
how far the final mass is below IPOPT's, the median iterations of both, the
summed times and their ratio, and every state where the method does worse.
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

BOX = [(-200, 200), (500, 800), (-15, 15), (-95, -70), (80, 95), (110000, 125000)]
WIDE = [(-300, 300), (450, 900), (-20, 20), (-100, -60), (75, 100), (105000, 128000)]


def states(box_count, wide_count, seed):
    rng = random.Random(seed)
    for name, box, count in (("box", BOX, box_count), ("wide", WIDE, wide_count)):
        for k in range(count):
            yield f"{name}{k}", tuple(rng.uniform(lo, hi) for lo, hi in box)


DIRECT_LINES = []
# Lines for the scenario's [solver] table (its last table in paper.toml).
SOLVER_LINES = []


def with_solver_lines(s):
    return s + "".join(f"{line}\n" for line in SOLVER_LINES)


def scenario_text(state, nodes):
    s = (ROOT / "scenarios" / "paper.toml").read_text()
    keys = ("x_m", "z_m", "vx_mps", "vz_mps", "theta_deg", "mass_kg")
    for key, val in zip(keys, state):
        s = re.sub(rf"(?m)^{key} = .*", f"{key} = {val:.3f}", s, count=1)
    s = re.sub(r"(?m)^final_mass_guess_kg = .*", f"final_mass_guess_kg = {state[5] - 5000.0:.1f}", s, count=1)
    s = re.sub(r"(?m)^nodes = .*", f"nodes = {nodes}", s, count=1)
    s = with_solver_lines(s)
    # [solver] is the file's last table, so a [solver.direct] table can follow.
    if DIRECT_LINES:
        s += "\n[solver.direct]\n" + "\n".join(DIRECT_LINES) + "\n"
    return s


def ours(path, method, repeat):
    """One process, `--repeat` solves: the median solve time, as the reference's `--repeat` gives."""
    out = subprocess.run([str(BIN), "solve", "--scenario", str(path), "--method", method, "--json", "--quiet",
                          "--repeat", str(repeat)], capture_output=True, text=True).stdout
    return json.loads(out)


def reference(path, nodes, repeat):
    out = subprocess.run([str(PY), str(REF), "--scenario", str(path), "--nodes", str(nodes), "--problem", "P2",
                          "--repeat", str(repeat), "--json", "--ground"], capture_output=True, text=True).stdout
    return json.loads(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--box", type=int, default=100, help="states from the documented box")
    ap.add_argument("--wide", type=int, default=50, help="states from the wider box")
    ap.add_argument("--seed", type=int, default=15)
    ap.add_argument("--nodes", type=int, action="append", help="N (repeatable; default 20 and 40)")
    ap.add_argument("--methods", default="direct,scvx")
    ap.add_argument("--repeat", type=int, default=3, help="timing runs of IPOPT and the direct method")
    ap.add_argument("--scvx-repeat", type=int, default=1, help="timing runs of SCvx (10x slower)")
    ap.add_argument("--table", action="store_true", help="one line per state")
    ap.add_argument("--save", metavar="CSV", help="write each state and IPOPT's answer (for examples/envelope_direct.rs)")
    ap.add_argument("--direct", action="append", default=[],
                    help="a line for the scenario's [solver.direct] table (repeatable)")
    args = ap.parse_args()
    DIRECT_LINES.extend(args.direct)
    nodes = args.nodes or [20, 40]
    methods = args.methods.split(",")
    if not BIN.exists():
        subprocess.run(["cargo", "build", "--release"], cwd=ROOT, check=True)
    if not PY.exists():
        sys.exit("bench/reference/.venv is missing: run bench/compare.sh once to create it")
    print(f"seed {args.seed}: {args.box} box + {args.wide} wide states; repeat {args.repeat} (SCvx {args.scvx_repeat})"
          + "".join(f" [{line}]" for line in args.direct))
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "state.toml"
        for n in nodes:
            rows = []
            for name, state in states(args.box, args.wide, args.seed):
                path.write_text(scenario_text(state, n))
                ref = reference(path, n, args.repeat)
                got = {m: ours(path, m, args.scvx_repeat if m == "scvx" else args.repeat) for m in methods}
                rows.append((name, state, ref, got))
                if args.table:
                    cols = " | ".join("%s %-13s %3d its %7.1f ms %10.1f" % (
                        m, o["status"], o["iterations"], o["solve_time_ms"], o["final_mass_kg"])
                        for m, o in got.items())
                    print("N=%d %-7s %s | IPOPT %-6s %3d its %6.1f ms %10.1f" % (
                        n, name, cols, "ok" if ref["success"] else "FAILED", ref["ipopt_iterations"],
                        ref["solve_time_ms"], ref["final_mass_kg"]), flush=True)
            summarize(n, methods, rows)
            if args.save:
                save(Path(args.save.replace("{n}", str(n))), rows)


def save(path, rows):
    """One line per state: its name, its six values and IPOPT's answer."""
    with path.open("w") as f:
        f.write("name,x_m,z_m,vx_mps,vz_mps,theta_deg,mass_kg,ipopt_success,ipopt_final_mass_kg,ipopt_iterations,ipopt_ms\n")
        for name, state, ref, _ in rows:
            f.write(",".join([name] + [f"{v:.3f}" for v in state]
                             + [str(int(ref["success"])), f"{ref['final_mass_kg']:.4f}", str(ref["ipopt_iterations"]),
                                f"{ref['solve_time_ms']:.3f}"]) + "\n")


# A converged NLP: `solved`, or `inaccurate` (solved, but its controls,
# re-integrated, miss the pad by more than the scenario's tolerance: a
# property of the mesh, which IPOPT's answer on the same mesh shares).
CONVERGED = ("solved", "inaccurate")


def summarize(n, methods, rows):
    ipopt_ok = [r for r in rows if r[2]["success"]]
    ipopt_ms = sum(r[2]["solve_time_ms"] for r in rows)
    ipopt_its = statistics.median(r[2]["ipopt_iterations"] for r in rows)
    for m in methods:
        solved = [r for r in rows if r[3][m]["status"] in CONVERGED]
        inaccurate = sum(1 for r in rows if r[3][m]["status"] == "inaccurate")
        both = [r for r in ipopt_ok if r[3][m]["status"] in CONVERGED]
        missed = [r[0] for r in ipopt_ok if r[3][m]["status"] not in CONVERGED]
        gaps = [r[3][m]["final_mass_kg"] - r[2]["final_mass_kg"] for r in both]  # ours - IPOPT
        ms = sum(r[3][m]["solve_time_ms"] for r in rows)
        its = statistics.median(r[3][m]["iterations"] for r in rows)
        within = sum(1 for g in gaps if g >= -0.5)
        print(f"N = {n}, {m}: converged {len(solved)}/{len(rows)} ({inaccurate} of them inaccurate) (IPOPT converged on {len(ipopt_ok)}, "
              f"ours missed {len(missed)} of those{': ' + ' '.join(missed) if missed else ''}); "
              f"m_f >= IPOPT - 0.5 kg on {within}/{len(both)}"
              + (f", min(ours - IPOPT) {min(gaps):.1f} kg, max {max(gaps):.1f} kg" if gaps else "")
              + f"; median iterations {its:.0f} (IPOPT {ipopt_its:.0f}); "
              f"time {ms / 1e3:.2f} s against IPOPT {ipopt_ms / 1e3:.2f} s: {ipopt_ms / max(ms, 1e-9):.1f}x faster")
        worse = [(r[0], g) for r, g in zip(both, gaps) if g < -0.5]
        for name, g in worse:
            print(f"    {name}: {g:.1f} kg below IPOPT")
        failed = [(r[0], r[3][m]["status"], r[3][m]["message"]) for r in rows if r[3][m]["status"] not in CONVERGED]
        for name, status, msg in failed:
            print(f"    {name}: {status}: {msg}")


if __name__ == "__main__":
    main()
