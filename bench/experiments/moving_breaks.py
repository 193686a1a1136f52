#!/usr/bin/env python3
"""Experiment (issue 16): interval breaks as decision variables ("moving
breaks"), solved by CasADi + IPOPT on bellyflop's transcription, before
building them into bellyflop's own NLP.

The NLP is the reference's (bench/reference/nlp_reference.py, P2 with the
ground bound) on an explicit mesh layout, with chosen interior breaks free:
interval k's defects become D_ref X - (t_f/2)(h_k/2) f, with h_k the
difference of its two (fixed or free) breaks, each free break within 45 % of
its neighbouring intervals. Optionally the thrust is fixed on chosen
intervals (to T_min or T_max), as Agamawi, Hager & Rao (2019) fix a
bang-bang control on the arcs next to a switch. The moved layout is then
solved by bellyflop on fixed breaks, refinement off but one pass's error
estimate on ([solver.refinement] tolerance 1e-12, max_passes 1), which
reports its re-integrated landing error.

    bench/experiments/moving_breaks.py --state 4 --variant all
    bench/experiments/moving_breaks.py --state 4 --variant events
    bench/experiments/moving_breaks.py --state 4 --variant events-thrust

Variants (the state is issue 15's seed-15 box state; 4 is the one with a
thrust pulse and seven switches):
- `none`, `all`: the mesh of bellyflop's sixth refinement pass, no break or
  every interior break free;
- `events`, `events-thrust`: breaks at the seven switches and arc ends read
  off the 20 x 8 reference answer of state 4 (EVENTS_S below, by hand),
  free, with the thrust free or fixed on the arcs next to its switches;
- `thrust-switches`: the same layout, only the thrust's three switches
  free, the thrust fixed next to them.

Needs bench/reference/.venv (bench/reference/requirements.txt) and the
release CLI. Nothing here is built into bellyflop.
"""
import argparse
import json
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

# State 4's switches and arc ends [s], read off its 20 x 8 reference answer,
# and the points per interval between them (63 in all).
EVENTS_S = [1.3, 1.8, 2.9, 3.8, 10.2, 11.1, 12.2]
EVENT_BREAKS_S = [0.0, 1.3, 1.8, 2.9, 3.8, 5.93, 8.07, 10.2, 11.1, 12.2]
EVENT_POINTS = [8, 4, 6, 6, 8, 8, 8, 6, 6, 3]
EVENT_MOVING = [1, 2, 3, 4, 7, 8, 9]          # break indices at events
EVENT_THRUST = {2: "lo", 3: "hi", 7: "hi", 8: "lo", 9: "hi"}  # interval: bound
EVENT_THRUST_SWITCHES = [3, 8, 9]            # the breaks at the thrust's switches


def cli(args):
    out = subprocess.run([str(BIN), "solve", "--json", *args], capture_output=True, text=True)
    return json.loads(out.stdout)


def solve_moving(sc, breaks, points, moving, thrust_fixed):
    mesh = R.LgrMesh.from_layout(breaks, points)
    N = mesh.N
    nlp = R.LgrNlp.__new__(R.LgrNlp)
    nlp.sc, nlp.problem = sc, "P2"
    nlp.x_scale = np.array([100.0, 100.0, 100.0, 100.0, 1.0, 1.0, sc.x0[6], 1.0])
    nlp.u_scale = np.array([sc.T_max, 1.0])
    nlp.nx, nlp.nu, nlp.N = 8, 2, N
    nx, nu = 8, 2
    nw = (N + 1) * nx + N * nu + 1
    w = ca.SX.sym("w", nw)
    b = ca.SX.sym("b", len(moving))
    X, U, tf_s = nlp._split(w)
    tf = 10.0 * tf_s
    bk = [ca.SX(v) for v in breaks]
    for j, k in enumerate(moving):
        bk[k] = b[j]
    g = []
    for k, (start, nk, lo, hi, Dk) in enumerate(mesh.intervals):
        d_ref = Dk * 0.5 * (hi - lo)
        h2 = 0.5 * (bk[k + 1] - bk[k])
        DX = ca.mtimes(ca.DM(d_ref), X[start:start + nk + 1, :])
        for i in range(nk):
            f = nlp._rhs_sx(X[start + i, :], U[start + i, :])
            for c in range(nx):
                g.append(DX[i, c] - 0.5 * tf * h2 * f[c] / nlp.x_scale[c])
    lbX = np.full((N + 1, nx), -np.inf)
    ubX = np.full((N + 1, nx), np.inf)
    lbX[0, :] = ubX[0, :] = np.append(sc.x0, sc.delta0) / nlp.x_scale
    lbX[N, :6] = ubX[N, :6] = sc.xf / nlp.x_scale[:6]
    lbX[1:, 1] = sc.xf[1] / nlp.x_scale[1]
    lbX[1:, 6] = sc.m_dry / nlp.x_scale[6]
    ubX[1:, 6] = 1.0
    lbX[1:, 7], ubX[1:, 7] = -sc.delta_max, sc.delta_max
    lbU = np.empty((N, nu))
    ubU = np.empty((N, nu))
    lbU[:, 0], ubU[:, 0] = sc.T_min / sc.T_max, 1.0
    lbU[:, 1], ubU[:, 1] = -sc.chi_max, sc.chi_max
    for k, side in thrust_fixed.items():
        start, nk = mesh.intervals[k][0], mesh.intervals[k][1]
        v = sc.T_min / sc.T_max if side == "lo" else 1.0
        lbU[start:start + nk, 0] = ubU[start:start + nk, 0] = v
    lbb = [breaks[k] - 0.45 * (breaks[k] - breaks[k - 1]) for k in moving]
    ubb = [breaks[k] + 0.45 * (breaks[k + 1] - breaks[k]) for k in moving]
    s = (mesh.nodes + 1) / 2
    a = np.append(sc.x0, sc.delta0)
    e = np.append(np.append(sc.xf, sc.mf_guess), 0.0)
    X0 = (a[None, :] + s[:, None] * (e - a)[None, :]) / nlp.x_scale
    U0 = np.zeros((N, 2))
    U0[:, 0] = 0.5 * (sc.T_min + sc.T_max) / sc.T_max
    w0 = nlp._pack(X0, np.clip(U0, lbU, ubU), sc.tf_guess / 10.0)
    solver = ca.nlpsol("moving", "ipopt", {"x": ca.vertcat(w, b), "f": -X[N, 6], "g": ca.vertcat(*g)},
                       {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
                        "ipopt.tol": 1e-9, "ipopt.max_iter": 3000})
    r = solver(x0=np.concatenate([w0, [breaks[k] for k in moving]]),
               lbx=np.concatenate([nlp._pack(lbX, lbU, 0.1), lbb]),
               ubx=np.concatenate([nlp._pack(ubX, ubU, 10.0), ubb]), lbg=0, ubg=0)
    x = np.array(r["x"]).ravel()
    moved = list(map(float, breaks))
    for j, k in enumerate(moving):
        moved[k] = float(x[nw + j])
    Xs, _, tfv = nlp._split(x[:nw])
    return solver.stats()["return_status"], float(Xs[N, 6] * sc.x0[6]), float(10 * tfv), moved


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--state", type=int, default=4)
    ap.add_argument("--variant", choices=["none", "all", "events", "events-thrust", "thrust-switches"], default="all")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "state.toml"
        path.write_text(scenario_text(list(states(args.state + 1, 0, 15))[args.state][1], 20))
        sc = R.load_scenario(str(path))
        ref = cli(["--scenario", str(path), "--intervals", "20", "--nodes", "160"])
        if args.variant in ("none", "all"):
            refined = cli(["--scenario", str(path), "--mesh-tolerance", "1e-6"])
            lay = refined["refinement"]["passes"][-1]["mesh"]
            breaks, points = lay["breaks_tau"], lay["points"]
            moving = [] if args.variant == "none" else list(range(1, len(points)))
            fixed = {}
        else:
            tf = ref["tf_s"]
            breaks = [2 * t / tf - 1 for t in EVENT_BREAKS_S] + [1.0]
            points = EVENT_POINTS
            moving = EVENT_THRUST_SWITCHES if args.variant == "thrust-switches" else EVENT_MOVING
            fixed = {} if args.variant == "events" else EVENT_THRUST
        status, mf, tf, moved = solve_moving(sc, breaks, points, moving, fixed)
        print(f"state {args.state}, {args.variant}: {sum(points)} points, {len(moving)} free breaks; "
              f"IPOPT {status}, m_f {mf:.3f} kg (20 x 8 reference {ref['final_mass_kg']:.3f} kg, "
              f"{mf - ref['final_mass_kg']:+.3f}), t_f {tf:.3f} s")
        for k in moving:
            print(f"  break {k}: {0.5 * (breaks[k] + 1) * tf:.3f} s -> {0.5 * (moved[k] + 1) * tf:.3f} s")
        text = path.read_text()
        text = re.sub(r"(?m)^nodes = .*", f"nodes = {sum(points)}\nintervals = {len(points)}", text, count=1)
        text = text.replace("[discretization]", "[discretization]\nmesh = { breaks_tau = %s, points = %s }"
                            % (moved, list(points)), 1)
        text += "\n[solver.refinement]\ntolerance = 1e-12\nmax_passes = 1\n"
        path.write_text(text)
        ours = cli(["--scenario", str(path)])
        le = ours["landing_error"]
        err = ours["refinement"]["passes"][0]["max_relative_error"]
        print(f"bellyflop on the moved breaks: {ours['status']}, m_f {ours['final_mass_kg']:.3f} kg, "
              f"largest interval error {err:.1e}, lands {le['position_m']:.3f} m and {le['velocity_mps']:.3f} m/s")


if __name__ == "__main__":
    main()
