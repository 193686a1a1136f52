#!/usr/bin/env python3
"""Issue 25: the default (polished) answer against CasADi + IPOPT, state by state.

On the paper's case and issue 15's seeded envelope (bench/envelope.py's
states: 100 from the documented box, 50 from the wide box, seed 15), per
state, in one run:

- ours by default (`bellyflop solve --json --repeat R`: the direct method at
  N = 20, then the polish), its status and its landing error by our check;
- its `controls_flown` re-integrated independently here, by scipy's DOP853
  (rtol = atol = 1e-10), piece by piece from the initial state, with the
  dynamics of Eq. (1)-(3) written again below from the scenario's numbers;
- ours raw (`--fast`), the collocation answer the polish starts from;
- CasADi + IPOPT at N = 20 (bench/reference, --ground, --repeat R): the peer
  whose time we must beat (its answer is not accurate either);
- CasADi + IPOPT on 20 intervals x 8 points (160 points, cold, once): the
  fine-mesh reference for the final mass.

Times are each solver's own: the median of R solves in one process
(`solve_time_ms`, which for ours includes the polish).

    bench/reference/.venv/bin/python bench/accurate.py                 # all 151 states
    bench/reference/.venv/bin/python bench/accurate.py --box 5 --wide 2 --table
    bench/reference/.venv/bin/python bench/accurate.py --bin OTHER/bellyflop   # another build, same states

The fine-mesh reference is slow (seconds per state) and not timed: with
--fine FILE its masses are read from FILE when it exists, else computed and
written there, so that the timed run can be repeated on a quiet machine:

    bench/reference/.venv/bin/python bench/accurate.py --fine /tmp/fine.json --fine-only
    flock /tmp/bellyflop-bench.lock bench/reference/.venv/bin/python bench/accurate.py --fine /tmp/fine.json
"""
import argparse
import json
import math
import statistics
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

sys.path.insert(0, str(Path(__file__).resolve().parent))
from envelope import BIN, PY, REF, ROOT, SOLVER_LINES, scenario_text, states, with_solver_lines  # noqa: E402


def verdict(o):
    """The certificate's verdict, in words (None: no certificate)."""
    if not o:
        return None
    if o["holds"]:
        return "holds"
    if not o["evaluated"]:
        return "not evaluated"
    return "contradicted" if o["contradicted_arcs"] > 0 else "not converged"


def run_ours(path, repeat, fast=False, binary=BIN):
    cmd = [str(binary), "solve", "--scenario", str(path), "--json", "--quiet", "--repeat", str(repeat)]
    if fast:
        cmd.append("--fast")
    return json.loads(subprocess.run(cmd, capture_output=True, text=True).stdout)


def run_ipopt(path, repeat, nodes=20, intervals=1):
    cmd = [str(PY), str(REF), "--scenario", str(path), "--nodes", str(nodes), "--intervals", str(intervals),
           "--problem", "P2", "--repeat", str(repeat), "--json", "--ground"]
    out = subprocess.run(cmd, capture_output=True, text=True).stdout
    try:
        return json.loads(out)
    except json.JSONDecodeError:
        return {"success": False, "final_mass_kg": math.nan, "solve_time_ms": math.nan}


def legendre(s):
    x = 2.0 * s - 1.0
    return np.array([1.0, x, 0.5 * (3 * x * x - 1), 0.5 * (5 * x ** 3 - 3 * x)])


def signal(sig, s):
    if sig["kind"] == "bound":
        return sig["value"]
    assert sig["basis"] == "shifted_legendre", sig["basis"]
    return float(np.dot(sig["coefficients"], legendre(s)))


def rhs_factory(sc):
    """Eq. (1)-(3): state (x, z, Vx, Vz, theta, w, m), control (T, delta)."""
    v, env = sc["vehicle"], sc["environment"]
    g0 = env["g0_mps2"]
    wind = env.get("wind_x_mps", 0.0)
    c = v["drag_coefficient_kgpm"]
    isp, cg, cp = v["isp_s"], v["cg_m"], v["cp_m"]
    j_per_m = (6 * v["radius_m"] ** 2 + v["length_m"] ** 2) / 12.0

    def rhs(y, thrust, delta):
        _, _, vx, vz, th, w, m = y
        ax_rel = vx - wind
        speed = math.sqrt(ax_rel * ax_rel + vz * vz + 1e-12)
        dx, dz = -c * speed * ax_rel, -c * speed * vz
        moment = -thrust * math.sin(delta) * cg - (dx * math.cos(th) + dz * math.sin(th)) * (cp - cg)
        return [vx, vz, (-thrust * math.sin(th + delta) + dx) / m, (thrust * math.cos(th + delta) + dz) / m - g0,
                w, moment / (m * j_per_m), -thrust / (isp * g0)]
    return rhs


def integrate_pieces(sc, flown, dense=False):
    """`controls_flown` flown by scipy's DOP853 (rtol = atol = 1e-10), piece by piece
    from the initial state: yields (piece, solve_ivp's result) for each piece."""
    rhs = rhs_factory(sc)
    i = sc["initial"]
    y = [i["x_m"], i["z_m"], i["vx_mps"], i["vz_mps"], math.radians(i["theta_deg"]),
         math.radians(i["pitch_rate_degps"]), i["mass_kg"]]
    for p in flown["pieces"]:
        t0, t1 = p["t_start_s"], p["t_end_s"]
        if t1 <= t0:
            continue
        d = t1 - t0

        def f(t, y, p=p, t0=t0, d=d):
            s = min(max((t - t0) / d, 0.0), 1.0)
            return rhs(y, signal(p["thrust_n"], s), signal(p["delta_rad"], s))
        r = solve_ivp(f, (t0, t1), y, method="DOP853", rtol=1e-10, atol=1e-10, dense_output=dense)
        y = list(r.y[:, -1])
        yield p, r


def scipy_landing(sc, flown):
    """Landing error of `controls_flown` by scipy's DOP853, piece by piece."""
    i = sc["initial"]
    y = [i["x_m"], i["z_m"], i["vx_mps"], i["vz_mps"]] + [0.0, 0.0, i["mass_kg"]]
    for _, r in integrate_pieces(sc, flown):
        y = list(r.y[:, -1])
    t = sc["terminal"]
    return math.hypot(y[0] - t["x_m"], y[1] - t["z_m"]), math.hypot(y[2] - t["vx_mps"], y[3] - t["vz_mps"]), y[6]


def pct(xs, q):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(math.ceil(q * len(xs))) - 1)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--box", type=int, default=100)
    ap.add_argument("--wide", type=int, default=50)
    ap.add_argument("--seed", type=int, default=15)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--no-paper", action="store_true")
    ap.add_argument("--table", action="store_true", help="one line per state")
    ap.add_argument("--save", metavar="JSON", help="write every state's numbers")
    ap.add_argument("--fine", metavar="JSON", help="cache of the fine-mesh reference's answers")
    ap.add_argument("--bin", default=str(BIN), help="the bellyflop binary to time (another build, same states)")
    ap.add_argument("--fine-only", action="store_true", help="compute the fine reference (into --fine) and stop")
    ap.add_argument("--solver", action="append", default=[], metavar="KEY=VALUE",
                    help="a line for the scenarios' [solver] table, e.g. --solver 'polish_hessian = true'")
    args = ap.parse_args()
    SOLVER_LINES.extend(args.solver)
    if not BIN.exists():
        subprocess.run(["cargo", "build", "--release"], cwd=ROOT, check=True)
    cases = [] if args.no_paper else [("paper", None)]
    cases += list(states(args.box, args.wide, args.seed))
    rows = []
    cache = json.loads(Path(args.fine).read_text()) if args.fine and Path(args.fine).exists() else {}
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "state.toml"
        for name, state in cases:
            text = with_solver_lines((ROOT / "scenarios" / "paper.toml").read_text()) if state is None else scenario_text(state, 20)
            path.write_text(text)
            sc = tomllib.loads(text)
            # Keyed by the state itself: box and wide states share one seeded
            # stream, so a name means another state at other --box counts.
            key = name if state is None else f"{name}:" + ",".join(f"{v:.12g}" for v in state)
            if key not in cache:
                f = run_ipopt(path, 1, nodes=160, intervals=20)
                cache[key] = {"success": f["success"], "final_mass_kg": f["final_mass_kg"]}
                if args.fine:
                    Path(args.fine).write_text(json.dumps(cache))
            fine = cache[key]
            if args.fine_only:
                continue
            ours = run_ours(path, args.repeat, binary=args.bin)
            fast = run_ours(path, args.repeat, fast=True, binary=args.bin)
            ipopt = run_ipopt(path, args.repeat)
            flown = ours.get("controls_flown")
            sp = scipy_landing(sc, flown) if flown else (math.nan, math.nan, math.nan)
            le = ours.get("landing_error") or {}
            row = dict(name=name, status=ours["status"], message=ours.get("message", ""),
                       ms=ours["solve_time_ms"], fast_ms=fast["solve_time_ms"], fast_status=fast["status"],
                       mf=ours["final_mass_kg"], fast_mf=fast["final_mass_kg"],
                       pos=le.get("position_m", math.nan), vel=le.get("velocity_mps", math.nan),
                       sp_pos=sp[0], sp_vel=sp[1], sp_mf=sp[2],
                       ipopt_ok=ipopt["success"], ipopt_ms=ipopt["solve_time_ms"], ipopt_mf=ipopt["final_mass_kg"],
                       fine_ok=fine["success"], fine_mf=fine["final_mass_kg"],
                       polish_iterations=(ours.get("polish") or {}).get("iterations"),
                       repairs=(ours.get("polish") or {}).get("repairs"),
                       certificate=verdict(ours.get("optimality")))
            rows.append(row)
            if args.table:
                print(f"{name:7s} {row['status']:12s} {row['ms']:6.1f} ms (raw {row['fast_ms']:5.1f}, IPOPT "
                      f"{row['ipopt_ms']:6.1f}) land {row['pos']:.1e} m {row['vel']:.1e} m/s, scipy {row['sp_pos']:.1e} m "
                      f"{row['sp_vel']:.1e} m/s; m_f - fine {row['mf'] - row['fine_mf']:+8.2f} kg "
                      f"(fine {'ok' if row['fine_ok'] else 'FAILED'}), raw - fine {row['fast_mf'] - row['fine_mf']:+8.2f}",
                      flush=True)
    if args.fine_only:
        return
    if args.save:
        Path(args.save).write_text(json.dumps(rows, indent=1))
    summarize(rows)


def summarize(rows):
    n = len(rows)
    ipopt_ok = [r for r in rows if r["ipopt_ok"]]
    solved = [r for r in rows if r["status"] == "solved"]
    missed = [r["name"] for r in ipopt_ok if r["status"] != "solved"]
    print(f"{n} states: solved {len(solved)}/{n}; IPOPT N = 20 converged on {len(ipopt_ok)}, "
          f"we are not solved on {len(missed)} of those{': ' + ' '.join(missed) if missed else ''}")
    for r in rows:
        if r["status"] != "solved":
            print(f"    {r['name']}: {r['status']}: {r['message'][:300]}")
    if solved:
        print(f"landing error of the solved, our check: max {max(r['pos'] for r in solved):.2e} m, "
              f"{max(r['vel'] for r in solved):.2e} m/s; scipy DOP853 (rtol 1e-10): max "
              f"{max(r['sp_pos'] for r in solved):.2e} m, {max(r['sp_vel'] for r in solved):.2e} m/s; "
              f"within 0.1 m and 0.05 m/s by scipy: {sum(1 for r in solved if r['sp_pos'] <= 0.1 and r['sp_vel'] <= 0.05)}/{len(solved)}")
        both = [r for r in solved if r["fine_ok"]]
        gaps = [r["mf"] - r["fine_mf"] for r in both]
        raw = [r["fast_mf"] - r["fine_mf"] for r in both]
        if gaps:
            print(f"final mass against IPOPT 20 x 8 (converged on {len(both)} of the solved): ours - fine median "
                  f"{statistics.median(gaps):+.2f} kg, min {min(gaps):+.2f}, max {max(gaps):+.2f}; within 1 kg on "
                  f"{sum(1 for g in gaps if abs(g) <= 1)}/{len(gaps)}, more than 1 kg above on "
                  f"{sum(1 for g in gaps if g > 1)}; raw N = 20 - fine: median {statistics.median(raw):+.2f} kg, "
                  f"min {min(raw):+.2f}, max {max(raw):+.2f}")
            for verdict in ("holds", "contradicted", "not converged", "not evaluated"):
                g = [r["mf"] - r["fine_mf"] for r in both if r.get("certificate") == verdict and r["mf"] - r["fine_mf"] < 1]
                if g:
                    print(f"    certificate {verdict}: {len(g)} states (sound reference), ours - fine median "
                          f"{statistics.median(g):+.2f} kg, within 0.5 kg on {sum(1 for v in g if v >= -0.5)}")
            for r, g in zip(both, gaps):
                if abs(g) > 1:
                    print(f"    {r['name']}: ours - fine {g:+.2f} kg (raw - fine {r['fast_mf'] - r['fine_mf']:+.2f}; "
                          f"certificate {r.get('certificate')}, repairs {r.get('repairs')})")
    ms = [r["ms"] for r in rows]
    fast = [r["fast_ms"] for r in rows]
    ip = [r["ipopt_ms"] for r in rows if not math.isnan(r["ipopt_ms"])]
    print(f"time per state, ours (accurate default): median {statistics.median(ms):.1f} ms, p95 {pct(ms, 0.95):.1f}, "
          f"total {sum(ms) / 1e3:.2f} s; ours raw (--fast): median {statistics.median(fast):.1f} ms, total "
          f"{sum(fast) / 1e3:.2f} s; IPOPT N = 20: median {statistics.median(ip):.1f} ms, p95 {pct(ip, 0.95):.1f}, "
          f"total {sum(ip) / 1e3:.2f} s")
    print(f"IPOPT N = 20 total / ours accurate total: {sum(ip) / sum(ms):.2f}x; ours accurate / ours raw: "
          f"{sum(ms) / sum(fast):.2f}x")
    ratios = [r["ipopt_ms"] / r["ms"] for r in rows if not math.isnan(r["ipopt_ms"]) and r["ms"] > 0]
    if ratios:
        print(f"IPOPT N = 20 / ours accurate, state by state: median {statistics.median(ratios):.2f}x, "
              f"min {min(ratios):.2f}x, at least 1.5x on {sum(1 for x in ratios if x >= 1.5)}/{len(ratios)}")
    its = [r["polish_iterations"] for r in rows if r.get("polish_iterations") is not None]
    if its:
        print(f"polish iterations: median {statistics.median(its):g}, max {max(its)}, at the cap (30) on "
              f"{sum(1 for i in its if i >= 30)}/{len(its)}")


if __name__ == "__main__":
    main()
