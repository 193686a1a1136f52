#!/usr/bin/env python3
"""Experiment (issue 16): the arc structure fixed and the switch times free
(after Agamawi, Hager & Rao 2019), solved by CasADi + IPOPT, as evidence for
what bellyflop's refinement would gain from it before building it.

1. The structure is read off bellyflop's 20 x 8 answer of the state
   (`--source fine`; or its refined answer, `refined`, or the N = 20 one,
   `single`): runs
   of the collocation points on a bound of T and of chi, and of the nodes on
   a limit of delta. A single point off the bounds between runs on opposite
   bounds is a switch, not an arc. The runs' ends, merged within MERGE_S,
   are the events.
2. Between consecutive events a segment gets, per signal, a type: T on
   T_min or T_max or free; delta on a limit (chi = 0 there, delta fixed at
   the segment's nodes) or chi on a bound or free. Its duration is a
   decision variable (t_f is their sum), and its intervals stretch with it.
3. Points: a segment whose controls are all fixed gets FIXED_POINTS per
   interval, any other FREE_POINTS, with intervals of at most MAX_SPAN_S.

The answer's layout (breaks in tau) is solved by bellyflop on fixed breaks
with one pass's error estimate ([solver.refinement] tolerance 1e-12,
max_passes 1), which reports its largest interval error and its landing.

    bench/experiments/structured_arcs.py --state 15
    bench/experiments/structured_arcs.py --states 0-9

Needs bench/reference/.venv and the release CLI. Nothing here is built into
bellyflop.
"""
import argparse
import json
import math
import re
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
sys.path.insert(0, str(HERE.parent / "reference"))
from envelope import BIN, scenario_text, states  # noqa: E402

import casadi as ca  # noqa: E402
import numpy as np  # noqa: E402
import nlp_reference as R  # noqa: E402

MERGE_S = 0.03
FIXED_POINTS = 4
FREE_POINTS = 6
MAX_SPAN_S = 2.0


def cli(args):
    out = subprocess.run([str(BIN), "solve", "--json", *args], capture_output=True, text=True)
    if not out.stdout.strip():
        raise SystemExit(f"bellyflop solve {' '.join(args)}: {out.stderr.strip()[-400:]}")
    return json.loads(out.stdout)


def runs(act, times):
    """(value, first time, last time, count) of each run of equal activity."""
    out, s = [], 0
    for i in range(1, len(act) + 1):
        if i == len(act) or act[i] != act[s]:
            out.append((int(act[s]), times[s], times[i - 1], i - s))
            s = i
    return out


def run_ends(rs):
    """Times between consecutive runs; a one-point interior run between runs
    on opposite bounds is a switch at that point."""
    ends, j = [], 0
    while j < len(rs) - 1:
        a, b = rs[j], rs[j + 1]
        if b[0] == 0 and b[3] == 1 and j + 2 < len(rs) and rs[j + 2][0] == -a[0] and a[0] != 0:
            ends.append(b[1])
            j += 2
            continue
        ends.append(0.5 * (a[2] + b[1]))
        j += 1
    return ends


def structure(sc, fine):
    t = np.array(fine["t_s"])
    n = len(t) - 1
    T = np.array(fine["thrust_n"][:n])
    chi = np.array(fine["gimbal_rate_radps"][:n])
    de = np.array(fine["delta_rad"])

    def act(v, lo, hi, tol):
        return np.where(v <= lo + tol, -1, np.where(v >= hi - tol, 1, 0))

    aT = act(T, sc.T_min, sc.T_max, 1e-3 * (sc.T_max - sc.T_min))
    aC = act(chi, -sc.chi_max, sc.chi_max, 1e-3 * sc.chi_max)
    aD = act(de, -sc.delta_max, sc.delta_max, 1e-5)
    ends = sorted(run_ends(runs(aT, t[:n])) + run_ends(runs(aC, t[:n])) + run_ends(runs(aD, t)))
    merged = []
    for e in ends:
        if merged and e - merged[-1][-1] < MERGE_S:
            merged[-1].append(e)
        else:
            merged.append([e])
    tf = fine["tf_s"]
    events = [float(np.mean(m)) for m in merged if MERGE_S < np.mean(m) < tf - MERGE_S]
    edges = [0.0] + events + [tf]

    def kind(a, times, s):
        inside = a[(times > edges[s] + 1e-9) & (times < edges[s + 1] - 1e-9)]
        if len(inside) and np.all(inside == inside[0]):
            return int(inside[0])
        return 0

    segs = [(kind(aT, t[:n], s), kind(aC, t[:n], s), kind(aD, t, s)) for s in range(len(edges) - 1)]
    return edges, segs


def solve(sc, fine, edges, segs):
    S = len(segs)
    intervals = []
    for s, (kt, kc, kd) in enumerate(segs):
        dur = edges[s + 1] - edges[s]
        sub = max(1, math.ceil(dur / MAX_SPAN_S))
        fixed = kt != 0 and (kc != 0 or kd != 0)
        for j in range(sub):
            intervals.append((s, j / sub, (j + 1) / sub, FIXED_POINTS if fixed else FREE_POINTS))
    pts = [iv[3] for iv in intervals]
    N = sum(pts)
    nx, nu = 8, 2
    xs = np.array([100.0, 100.0, 100.0, 100.0, 1.0, 1.0, sc.x0[6], 1.0])
    nl = R.LgrNlp.__new__(R.LgrNlp)
    nl.sc, nl.problem, nl.x_scale, nl.u_scale, nl.nx = sc, "P2", xs, np.array([sc.T_max, 1.0]), nx
    X = ca.SX.sym("X", N + 1, nx)
    U = ca.SX.sym("U", N, nu)
    Dt = ca.SX.sym("Dt", S)
    lbU = np.empty((N, nu))
    ubU = np.empty((N, nu))
    lbU[:, 0], ubU[:, 0] = sc.T_min / sc.T_max, 1.0
    lbU[:, 1], ubU[:, 1] = -sc.chi_max, sc.chi_max
    lbX = np.full((N + 1, nx), -np.inf)
    ubX = np.full((N + 1, nx), np.inf)
    lbX[1:, 7], ubX[1:, 7] = -sc.delta_max, sc.delta_max
    g, start, cache, times = [], 0, {}, []
    for (s, a, b, n) in intervals:
        if n not in cache:
            tl = R.lgr_points(n)
            cache[n] = (tl, R.lagrange_diff_matrix(tl, np.append(tl, 1.0)))
        tl, D = cache[n]
        DX = ca.mtimes(ca.DM(D), X[start:start + n + 1, :])
        for i in range(n):
            f = nl._rhs_sx(X[start + i, :], U[start + i, :])
            for c in range(nx):
                g.append(DX[i, c] - 0.25 * Dt[s] * (b - a) * f[c] / xs[c])
        kt, kc, kd = segs[s]
        rows = slice(start, start + n)
        if kt != 0:
            lbU[rows, 0] = ubU[rows, 0] = 1.0 if kt > 0 else sc.T_min / sc.T_max
        if kd != 0:
            lbU[rows, 1] = ubU[rows, 1] = 0.0
            lbX[start + 1:start + n + 1, 7] = ubX[start + 1:start + n + 1, 7] = kd * sc.delta_max
        elif kc != 0:
            lbU[rows, 1] = ubU[rows, 1] = kc * sc.chi_max
        t0 = edges[s] + a * (edges[s + 1] - edges[s])
        t1 = edges[s] + b * (edges[s + 1] - edges[s])
        times.extend(t0 + (tl + 1) / 2 * (t1 - t0))
        start += n
    times.append(edges[-1])
    lbX[0, :] = ubX[0, :] = np.append(sc.x0, sc.delta0) / xs
    lbX[N, :6] = ubX[N, :6] = sc.xf / xs[:6]
    lbX[1:, 1] = np.maximum(lbX[1:, 1], sc.xf[1] / xs[1])
    lbX[1:, 6], ubX[1:, 6] = sc.m_dry / xs[6], 1.0
    t = np.array(fine["t_s"])
    cols = ["x_m", "z_m", "vx_mps", "vz_mps", "theta_rad", "pitch_rate_radps", "mass_kg", "delta_rad"]
    X0 = np.stack([np.interp(times, t, np.array(fine[c])) for c in cols], 1) / xs
    X0 = np.clip(X0, np.where(np.isfinite(lbX), lbX, -1e9), np.where(np.isfinite(ubX), ubX, 1e9))
    U0 = np.stack([np.interp(times[:-1], t[:-1], fine["thrust_n"][:-1]) / sc.T_max,
                   np.interp(times[:-1], t[:-1], fine["gimbal_rate_radps"][:-1])], 1)
    U0 = np.clip(U0, lbU, ubU)
    D0 = np.diff(edges)
    wv = ca.vertcat(ca.reshape(X.T, -1, 1), ca.reshape(U.T, -1, 1), Dt)
    solver = ca.nlpsol("arcs", "ipopt", {"x": wv, "f": -X[N, 6], "g": ca.vertcat(*g)},
                       {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
                        "ipopt.tol": 1e-10, "ipopt.max_iter": 3000})
    r = solver(x0=np.concatenate([X0.ravel(), U0.ravel(), D0]),
               lbx=np.concatenate([lbX.ravel(), lbU.ravel(), 0.2 * D0]),
               ubx=np.concatenate([ubX.ravel(), ubU.ravel(), 5 * D0 + 0.5]), lbg=0, ubg=0)
    x = np.array(r["x"]).ravel()
    dts = x[-S:]
    tf = dts.sum()
    ed = np.concatenate([[0.0], np.cumsum(dts)])
    breaks = [-1.0] + [2 * (ed[s] + b * dts[s]) / tf - 1 for (s, a, b, n) in intervals]
    breaks = [float(v) for v in breaks]
    breaks[-1] = 1.0
    st = solver.stats()
    return st["return_status"], st["iter_count"], float(x[N * nx + 6] * sc.x0[6]), breaks, pts


SOURCES = {
    "fine": ["--intervals", "20", "--nodes", "160"],
    "refined": ["--mesh-tolerance", "1e-6"],
    "single": [],
}


def one(index, source):
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "state.toml"
        path.write_text(scenario_text(list(states(index + 1, 0, 15))[index][1], 20))
        sc = R.load_scenario(str(path))
        fine = cli(["--scenario", str(path), *SOURCES[source]])
        reference = fine if source == "fine" else cli(["--scenario", str(path), *SOURCES["fine"]])
        edges, segs = structure(sc, fine)
        status, iters, mf, breaks, pts = solve(sc, fine, edges, segs)
        text = path.read_text()
        text = re.sub(r"(?m)^nodes = .*", f"nodes = {sum(pts)}\nintervals = {len(pts)}", text, count=1)
        text = text.replace("[discretization]", "[discretization]\nmesh = { breaks_tau = %s, points = %s }"
                            % (breaks, pts), 1)
        text += "\n[solver.refinement]\ntolerance = 1e-12\nmax_passes = 1\n"
        path.write_text(text)
        ours = cli(["--scenario", str(path)])
        le = ours["landing_error"]
        err = ours["refinement"]["passes"][0]["max_relative_error"]
        print(f"state {index}: {len(edges) - 2} events, {sum(pts)} points over {len(pts)} intervals; "
              f"IPOPT {status} in {iters} iterations, m_f {mf - reference['final_mass_kg']:+.3f} kg against the 20 x 8 answer; "
              f"bellyflop on its breaks: {ours['status']}, largest interval error {err:.1e}, "
              f"lands {le['position_m']:.3f} m and {le['velocity_mps']:.3f} m/s", flush=True)
        return le["position_m"] <= 0.1 and le["velocity_mps"] <= 0.05, sum(pts), err


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--state", type=int)
    ap.add_argument("--states", default="0-9", help="a range FIRST-LAST of the box states")
    ap.add_argument("--source", choices=list(SOURCES), default="fine",
                    help="the answer the structure is read off: the 20 x 8 mesh, bellyflop's refined "
                         "answer (--mesh-tolerance 1e-6), or the scenario's N = 20 mesh")
    args = ap.parse_args()
    if args.state is not None:
        chosen = [args.state]
    else:
        a, b = (int(x) for x in args.states.split("-"))
        chosen = list(range(a, b + 1))
    results = [one(i, args.source) for i in chosen]
    print(f"landed within 0.1 m and 0.05 m/s: {sum(r[0] for r in results)} of {len(results)}; "
          f"points: median {sorted(r[1] for r in results)[len(results) // 2]}, max {max(r[1] for r in results)}; "
          f"largest interval error: median {sorted(r[2] for r in results)[len(results) // 2]:.1e}")


if __name__ == "__main__":
    main()
