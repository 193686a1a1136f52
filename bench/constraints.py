#!/usr/bin/env python3
"""Issue 37: the operational constraints on issue 15's seeded states.

For each state of bench/envelope.py (the documented box, seed 15 by default:
issue 15's states), solves the default (`bellyflop solve --json`, the direct
method then the polish) unconstrained, with each `init` default limit alone
(the approach cone, the pitch-rate limit, the tilt limit below an altitude,
the vertical final descent) and with all four, one after the other in the
same run. For every `solved` constrained answer it re-integrates its
`controls_flown` independently here (scipy DOP853 at rtol = atol = 1e-10,
piece by piece, bench/accurate.py's dynamics) and evaluates every row of
the limits, written again from the README of bench/reference, on a 1 ms
grid: a row above 1e-3 of its scale (the flight check's tolerance, 1 mm in
the cone) is a violation. It also checks the landing (1e-3 m, 1e-3 m/s)
and the ground, and reports per limit: how many answers it changes (final
mass moved by more than 0.05 kg), their fuel cost (median, worst), the
statuses, and the solve time against the unconstrained default; and on the
states left `not_converged`, where the answer's `limit_evidence` says the
limits cut.

    bench/reference/.venv/bin/python bench/constraints.py              # 150 states
    bench/reference/.venv/bin/python bench/constraints.py --box 20 --table
    bench/reference/.venv/bin/python bench/constraints.py --write /tmp/limits   # the scenario files only
"""
import argparse
import json
import math
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from accurate import integrate_pieces  # noqa: E402
from envelope import BIN, scenario_text, states  # noqa: E402

# The `init` defaults (bellyflop::problem::constraints::Constraints::recommended).
LIMITS = {
    "cone": {"cone_half_angle_deg": 30.0},
    "pitch_rate": {"max_pitch_rate_degps": 30.0},
    "tilt": {"max_tilt_deg": 10.0, "tilt_below_m": 50.0},
    "final_descent": {"final_descent_m": 20.0, "final_descent_lateral_mps": 2.0},
}
LIMITS["all"] = {k: v for table in LIMITS.values() for k, v in table.items()}
TOLERANCE = 1e-3
SIGMA = 1.0


def softplus(u):
    return np.maximum(u, 0.0) + SIGMA * np.log1p(np.exp(-np.abs(u) / SIGMA))


def rows(c, sc, y):
    """{limit: (largest row value over the states y (7 x n), its scale)}."""
    xf, zf = sc["terminal"]["x_m"], sc["terminal"]["z_m"]
    x, z, vx, th, w = y[0], y[1], y[2], y[4], y[5]
    dz = z - zf
    out = {}
    if "cone_half_angle_deg" in c:
        g = np.abs(x - xf) - math.tan(math.radians(c["cone_half_angle_deg"])) * dz
        out["cone"] = (g.max(), 1.0)
    if "max_pitch_rate_degps" in c:
        wm = math.radians(c["max_pitch_rate_degps"])
        out["pitch_rate"] = ((np.abs(w) - wm).max(), max(wm, 0.1))
    if "max_tilt_deg" in c:
        tm = math.radians(c["max_tilt_deg"])
        g = np.abs(th) - tm - math.radians(1.0) * softplus(dz - c["tilt_below_m"])
        out["tilt"] = (g.max(), max(tm, math.radians(1.0)))
    if "final_descent_m" in c:
        v = c["final_descent_lateral_mps"]
        g = np.abs(vx) - v - 1.0 * softplus(dz - c["final_descent_m"])
        out["final_descent"] = (g.max(), max(v, 0.1))
    return out


def judge(c, sc, flown):
    """The flight of `controls_flown` on a 1 ms grid: each limit's worst row over its scale, the landing."""
    ys = []
    end = None
    for p, r in integrate_pieces(sc, flown, dense=True):
        t0, t1 = p["t_start_s"], p["t_end_s"]
        grid = np.unique(np.concatenate([np.arange(math.ceil(t0 * 1e3), math.floor(t1 * 1e3) + 1) * 1e-3,
                                         [t0, t1]]))
        grid = grid[(grid >= t0) & (grid <= t1)]
        ys.append(r.sol(grid))
        end = r.y[:, -1]
    y = np.concatenate(ys, axis=1)
    t = sc["terminal"]
    worst = {k: g / s for k, (g, s) in rows(c, sc, y).items()}
    pos = math.hypot(end[0] - t["x_m"], end[1] - t["z_m"])
    vel = math.hypot(end[2] - t["vx_mps"], end[3] - t["vz_mps"])
    # The ground before the last 10 ms (the touchdown itself is z_f).
    ground = float((y[1][:-10] - t["z_m"]).min())
    return dict(worst=worst, pos=pos, vel=vel, ground=ground,
                ok=all(v <= TOLERANCE for v in worst.values()) and pos <= 1e-3 and vel <= 1e-3
                and ground >= -1e-3)


def solve(binary, path, text):
    path.write_text(text)
    out = subprocess.run([binary, "solve", "--scenario", str(path), "--json", "--quiet"],
                         capture_output=True, text=True).stdout
    return json.loads(out)


def with_limits(text, table):
    return text + "\n[constraints]\n" + "".join(f"{k} = {v!r}\n" for k, v in table.items())


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--box", type=int, default=150)
    ap.add_argument("--wide", type=int, default=0)
    ap.add_argument("--seed", type=int, default=15)
    ap.add_argument("--bin", default=str(BIN))
    ap.add_argument("--table", action="store_true", help="one line per state and limit")
    ap.add_argument("--save", metavar="JSON")
    ap.add_argument("--write", metavar="DIR",
                    help="only write each state's scenario with each limit, DIR/<state>_<limit>.toml, and stop "
                         "(the inputs of a fine reference: bench/reference/nlp_reference.py --scenario ...)")
    args = ap.parse_args()
    if args.write:
        out = Path(args.write)
        out.mkdir(parents=True, exist_ok=True)
        for name, state in states(args.box, args.wide, args.seed):
            base = scenario_text(state, 20)
            (out / f"{name}_free.toml").write_text(base)
            for limit, table in LIMITS.items():
                (out / f"{name}_{limit}.toml").write_text(with_limits(base, table))
        return
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "state.toml"
        for name, state in states(args.box, args.wide, args.seed):
            base = scenario_text(state, 20)
            free = solve(args.bin, path, base)
            row = dict(name=name, state=state, free=dict(status=free["status"], mf=free["final_mass_kg"],
                                                         ms=free["solve_time_ms"]))
            for limit, table in LIMITS.items():
                text = with_limits(base, table)
                sol = solve(args.bin, path, text)
                r = dict(status=sol["status"], method=sol["method"], mf=sol["final_mass_kg"],
                         ms=sol["solve_time_ms"], message=sol.get("message", "")[:300],
                         evidence=sol.get("limit_evidence"))
                if sol["status"] == "solved":
                    r.update(judge(table, tomllib.loads(text), sol["controls_flown"]))
                row[limit] = r
                if args.table:
                    extra = (f"worst {max(r['worst'].values()):+.1e}  land {r['pos']:.0e} m  "
                             f"{'OK' if r['ok'] else 'VIOLATED'}" if "ok" in r else r["message"][:90])
                    print(f"{name:7s} {limit:13s} {r['status']:12s} {r['mf'] - free['final_mass_kg']:+9.2f} kg "
                          f"{r['ms']:7.1f} ms (free {free['solve_time_ms']:6.1f})  {extra}", flush=True)
            results.append(row)
    if args.save:
        Path(args.save).write_text(json.dumps(results, indent=1, default=float))
    n = len(results)
    print(f"{n} states (seed {args.seed}); the unconstrained default: "
          f"solved {sum(r['free']['status'] == 'solved' for r in results)}")
    print("| limit | solved | other statuses | changed (> 0.05 kg) | fuel cost median / worst [kg] "
          "| violations (scipy, 1 ms) | time median / p95 [ms] | unconstrained median / p95 [ms] |")
    print("|---|---|---|---|---|---|---|---|")
    free_ms = sorted(r["free"]["ms"] for r in results)
    for limit in LIMITS:
        rs = [r[limit] for r in results]
        solved = [(r, x) for r, x in zip(results, rs) if x["status"] == "solved"]
        other = {}
        for x in rs:
            if x["status"] != "solved":
                other[x["status"]] = other.get(x["status"], 0) + 1
        both = [(r["free"]["mf"] - x["mf"]) for r, x in solved if r["free"]["status"] == "solved"]
        changed = [c for c in both if abs(c) > 0.05]
        cost = sorted(changed)
        ms = sorted(x["ms"] for x in rs)
        print(f"| {limit} | {len(solved)}/{n} | {', '.join(f'{k} {v}' for k, v in other.items()) or '-'} "
              f"| {len(changed)} | {np.median(cost) if cost else 0:.2f} / {max(cost) if cost else 0:.2f} "
              f"| {sum(not x['ok'] for _, x in solved)} | {ms[n // 2]:.1f} / {ms[int(0.95 * (n - 1))]:.1f} "
              f"| {free_ms[n // 2]:.1f} / {free_ms[int(0.95 * (n - 1))]:.1f} |")
    print()
    print("Where the limits cut, on the states left not_converged (`limit_evidence`):")
    print("| limit | not_converged | unconstrained solved | its answer breaks (states per limit) "
          "| alone unsolved (states per limit) |")
    print("|---|---|---|---|---|")
    for limit in LIMITS:
        es = [r[limit].get("evidence") for r in results if r[limit]["status"] == "not_converged"]
        if not es:
            continue
        broken, alone = {}, {}
        for e in es:
            for b in (e or {}).get("broken", []):
                broken[b["limit"]] = broken.get(b["limit"], 0) + 1
            for a in (e or {}).get("alone", []):
                if not a["solved"]:
                    alone[a["limit"]] = alone.get(a["limit"], 0) + 1
        fmt = lambda d: ", ".join(f"{k} {v}" for k, v in sorted(d.items())) or "-"
        print(f"| {limit} | {len(es)} | {sum(bool(e and e['unconstrained_solved']) for e in es)} "
              f"| {fmt(broken)} | {fmt(alone) if limit == 'all' else 'n/a'} |")


if __name__ == "__main__":
    main()
