#!/usr/bin/env python3
"""Issue 35, step 0: is every `solved` default answer safe along its whole flight?

Draws seeded states from the documented box and from the wider one
(bench/envelope.py's boxes; seed 35 by default, not issue 15's), solves
each with the default (`bellyflop solve --json`: the direct method at
N = 20, then the polish), and for every `solved` answer re-integrates its
`controls_flown` independently here: scipy's DOP853 (rtol = atol = 1e-10),
piece by piece, with the dynamics of Eq. (1)-(3) written again
(bench/accurate.py), with dense output. On a 1 ms grid of [0, t_f]
(and at every piece's ends) it checks:

- the ground: z(t) >= z_f - 1 mm for t < t_f (no contact before the
  touchdown), and reports the lowest clearance before the last second;
- T within [T_min, T_max], |delta| <= delta_max, |chi| <= chi_max, each
  to 1e-9 of its bound's scale (T_max - T_min, delta_max, chi_max);
- m(t_f) >= m_dry;
- the landing: within 1e-3 m and 1e-3 m/s.

    bench/reference/.venv/bin/python bench/safety.py                  # 150 + 150 states
    bench/reference/.venv/bin/python bench/safety.py --box 10 --wide 10 --table
    bench/reference/.venv/bin/python bench/safety.py --bin OTHER/bellyflop   # another build, same states
    bench/reference/.venv/bin/python bench/safety.py --box 0 --wide 0 --table --scenario FILE.toml
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
from accurate import integrate_pieces, signal  # noqa: E402
from envelope import BIN, scenario_text, states  # noqa: E402

GROUND_TOLERANCE_M = 1e-3
CONTROL_TOLERANCE = 1e-9


def slope(sig, s):
    if sig["kind"] == "bound":
        return 0.0
    x = 2.0 * s - 1.0
    c = sig["coefficients"]
    return c[1] * 2.0 + c[2] * 6.0 * x + c[3] * (15.0 * x * x - 3.0)


def fly(sc, flown):
    """The flight of `controls_flown` on a 1 ms grid: t, z, T, delta, chi, and the final state."""
    ts, zs, thrust, delta, chi = [], [], [], [], []
    y = None
    for p, r in integrate_pieces(sc, flown, dense=True):
        t0, t1 = p["t_start_s"], p["t_end_s"]
        d = t1 - t0
        grid = np.unique(np.concatenate([np.arange(math.ceil(t0 * 1e3), math.floor(t1 * 1e3) + 1) * 1e-3,
                                         [t0, t1]]))
        grid = grid[(grid >= t0) & (grid <= t1)]
        ys = r.sol(grid)
        for t, z in zip(grid, ys[1]):
            s = (t - t0) / d
            ts.append(t)
            zs.append(z)
            thrust.append(signal(p["thrust_n"], s))
            delta.append(signal(p["delta_rad"], s))
            chi.append(slope(p["delta_rad"], s) / d)
        y = list(r.y[:, -1])
    return np.array(ts), np.array(zs), np.array(thrust), np.array(delta), np.array(chi), y


def judge(sc, flown):
    v, t = sc["vehicle"], sc["terminal"]
    ts, zs, thrust, delta, chi, end = fly(sc, flown)
    tf = ts[-1]
    z_f = t["z_m"]
    before = ts < tf - 1e-9
    floor = min(z_f, end[1]) - GROUND_TOLERANCE_M
    contact = before & (zs < floor)
    t_range = v["max_thrust_n"] - v["min_thrust_n"]
    dmax, chimax = math.radians(v["max_gimbal_deg"]), math.radians(v["max_gimbal_rate_degps"])
    out = dict(
        tf=tf,
        contact=bool(contact.any()),
        contact_t=float(ts[contact][0]) if contact.any() else None,
        lowest=float(zs[before].min() - z_f),
        lowest_before_last_second=float(zs[ts <= tf - 1.0].min() - z_f) if (ts <= tf - 1.0).any() else math.nan,
        t_low=float((v["min_thrust_n"] - thrust.min()) / t_range),
        t_high=float((thrust.max() - v["max_thrust_n"]) / t_range),
        delta_over=float((np.abs(delta).max() - dmax) / dmax),
        chi_over=float((np.abs(chi).max() - chimax) / chimax),
        dry=bool(end[6] >= v["dry_mass_kg"]),
        pos=math.hypot(end[0] - t["x_m"], end[1] - t["z_m"]),
        vel=math.hypot(end[2] - t["vx_mps"], end[3] - t["vz_mps"]),
    )
    out["thrust_ok"] = out["t_low"] <= CONTROL_TOLERANCE and out["t_high"] <= CONTROL_TOLERANCE
    out["delta_ok"] = out["delta_over"] <= CONTROL_TOLERANCE
    out["chi_ok"] = out["chi_over"] <= CONTROL_TOLERANCE
    out["landed"] = out["pos"] <= 1e-3 and out["vel"] <= 1e-3
    out["safe"] = (not out["contact"] and out["thrust_ok"] and out["delta_ok"] and out["chi_ok"]
                   and out["dry"] and out["landed"])
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--box", type=int, default=150)
    ap.add_argument("--wide", type=int, default=150)
    ap.add_argument("--seed", type=int, default=35)
    ap.add_argument("--bin", default=str(BIN))
    ap.add_argument("--table", action="store_true", help="one line per state")
    ap.add_argument("--save", metavar="JSON")
    ap.add_argument("--scenario", action="append", default=[], metavar="FILE",
                    help="a scenario file to check too, as it is (named file:STEM)")
    args = ap.parse_args()
    cases = [(name, state, scenario_text(state, 20)) for name, state in states(args.box, args.wide, args.seed)]
    cases += [(f"file:{Path(f).stem}", None, Path(f).read_text()) for f in args.scenario]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "state.toml"
        for name, state, text in cases:
            path.write_text(text)
            sc = tomllib.loads(text)
            out = subprocess.run([args.bin, "solve", "--scenario", str(path), "--json", "--quiet"],
                                 capture_output=True, text=True).stdout
            sol = json.loads(out)
            row = dict(name=name, state=state, status=sol["status"], message=sol.get("message", ""),
                       ms=sol["solve_time_ms"], mf=sol["final_mass_kg"],
                       polish_iterations=(sol.get("polish") or {}).get("iterations"))
            if sol["status"] == "solved":
                row.update(judge(sc, sol["controls_flown"]))
            rows.append(row)
            if args.table:
                if sol["status"] == "solved":
                    print(f"{name:8s} solved {row['ms']:7.1f} ms  low {row['lowest']:+.2e} m (before last s "
                          f"{row['lowest_before_last_second']:+8.3f})  T {row['t_low']:+.1e}/{row['t_high']:+.1e}  "
                          f"delta {row['delta_over']:+.1e}  chi {row['chi_over']:+.1e}  land {row['pos']:.1e} m "
                          f"{row['vel']:.1e} m/s  {'SAFE' if row['safe'] else 'UNSAFE'}", flush=True)
                else:
                    print(f"{name:8s} {row['status']}: {row['message'][:160]}", flush=True)
    if args.save:
        Path(args.save).write_text(json.dumps(rows, indent=1, default=float))
    for kind in ("box", "wide", "file"):
        rs = [r for r in rows if r["name"].startswith(kind)]
        if not rs:
            continue
        solved = [r for r in rs if r["status"] == "solved"]
        other = {}
        for r in rs:
            if r["status"] != "solved":
                other[r["status"]] = other.get(r["status"], 0) + 1
        print(f"{kind}: {len(rs)} states, solved {len(solved)} ({', '.join(f'{k} {v}' for k, v in other.items()) or 'all'}); "
              f"of the solved: through the ground {sum(r['contact'] for r in solved)}, T out of bounds "
              f"{sum(not r['thrust_ok'] for r in solved)}, delta {sum(not r['delta_ok'] for r in solved)}, chi "
              f"{sum(not r['chi_ok'] for r in solved)}, below dry mass {sum(not r['dry'] for r in solved)}, "
              f"landing beyond 1e-3 m or m/s {sum(not r['landed'] for r in solved)}; safe "
              f"{sum(r['safe'] for r in solved)}/{len(solved)}")
        if solved:
            print(f"    worst: T {max(max(r['t_low'], r['t_high']) for r in solved):+.2e} of its range, delta "
                  f"{max(r['delta_over'] for r in solved):+.2e}, chi {max(r['chi_over'] for r in solved):+.2e} of "
                  f"its bound; lowest z - z_f before t_f {min(r['lowest'] for r in solved):+.3e} m; landing "
                  f"{max(r['pos'] for r in solved):.1e} m, {max(r['vel'] for r in solved):.1e} m/s")
    ms = sorted(r["ms"] for r in rows)
    print(f"solve time: median {ms[len(ms) // 2]:.1f} ms, max {ms[-1]:.1f} ms")


if __name__ == "__main__":
    main()
