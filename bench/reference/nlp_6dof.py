#!/usr/bin/env python3
"""CasADi + IPOPT on the 6-DoF flip-and-land (issue 38): the paper's planar
model lifted to 3-D, on the same LGR collocation with free t_f as
nlp_reference.py (whose mesh and scenario reader it uses).

The model is written here from its equations, apart from the Rust one
(crates/bellyflop/src/problem/six_dof.rs), so that each checks the other:

* state (16): r = (x, y, z), V, a body-to-inertial quaternion q (scalar
  first), body rates w, mass m, the gimbal angles (d1, d2);
* control (3): thrust T and the gimbal rates (chi1, chi2);
* m V' = T R d + D - m g z^, D = -C_LD |V - W| (V - W), d = (-sin d1 cos d2, -sin d2,
  cos d1 cos d2) in the body frame, R = R(q/|q|);
* q' = q (x) (0, w) / 2 + kappa (1 - |q|^2) q (kappa = 1/s);
* J w' = tau - w x J w, J = m diag(k_t, k_t, r^2/2), k_t = (6 r^2 + l^2)/12,
  tau = (-l_cg e_z) x (T d) + ((l_cp - l_cg) e_z) x (R^T D);
* m' = -T/(I_sp g0); (d1, d2)' = (chi1, chi2).

The planar problem is the special case y = Vy = 0, q = (cos th/2, 0,
-sin th/2, 0), w = (0, -w_planar, 0), d2 = 0. Bounds: T in [T_min, T_max];
the gimbal in a cone, cos d1 cos d2 >= cos d_max; its rate in a disc,
chi1^2 + chi2^2 <= chi_max^2; m >= m_dry; z >= z_f at every node after the
first (--ground). Terminal: at the pad, at rest, the body axis vertical and
up ((R e_z)_x = (R e_z)_y = 0, (R e_z)_z >= 0), pitch and yaw rates zero,
roll free. The attitude's start: the planar theta, then a yaw psi about
the vertical and a roll phi about the body axis.

    python nlp_6dof.py --planar-check --scenario ../../scenarios/paper.toml
    python nlp_6dof.py --states 10 --seed 38 [--nodes 20] [--json]

--states also flies each answer's controls (reintegrate6: T linear between
the collocation times, the gimbal angles linear over the nodes, DOP853)
and reports the landing miss and the lowest altitude along the flight.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import random
import statistics
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from nlp_reference import BOUND_RELAX, LgrMesh, LgrNlp, load_scenario  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

NX, NU = 16, 3
KAPPA = 1.0  # the pull of |q| toward 1 [1/s]


def quat_mul(a, b):
    return [
        a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
        a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
        a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
        a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
    ]


def attitude(theta, psi=0.0, phi=0.0):
    """q = q_yaw(psi about z) (x) q_pitch(theta about -y) (x) q_roll(phi about e_z)."""
    yaw = [math.cos(psi / 2), 0.0, 0.0, math.sin(psi / 2)]
    pitch = [math.cos(theta / 2), 0.0, -math.sin(theta / 2), 0.0]
    roll = [math.cos(phi / 2), 0.0, 0.0, math.sin(phi / 2)]
    return quat_mul(quat_mul(yaw, pitch), roll)


def rotation(q):
    n2 = q[0] ** 2 + q[1] ** 2 + q[2] ** 2 + q[3] ** 2
    s = 2.0 / n2
    w, x, y, z = q
    return [
        [1 - s * (y * y + z * z), s * (x * y - w * z), s * (x * z + w * y)],
        [s * (x * y + w * z), 1 - s * (x * x + z * z), s * (y * z - w * x)],
        [s * (x * z - w * y), s * (y * z + w * x), 1 - s * (x * x + y * y)],
    ]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def rhs6(sc, s, u, sin, cos, sqrt, wind=(0.0, 0.0, 0.0)):
    """The 16 derivatives (module docstring), for numpy or CasADi; the drag
    on the air-relative velocity V - wind."""
    v = [s[3], s[4], s[5]]
    va = [v[i] - wind[i] for i in range(3)]
    q = [s[6], s[7], s[8], s[9]]
    w = [s[10], s[11], s[12]]
    m, d1, d2 = s[13], s[14], s[15]
    T, chi1, chi2 = u[0], u[1], u[2]
    R = rotation(q)
    speed = sqrt(va[0] ** 2 + va[1] ** 2 + va[2] ** 2 + 1e-12)
    D = [-sc.C_LD * speed * vi for vi in va]
    d = [-sin(d1) * cos(d2), -sin(d2), cos(d1) * cos(d2)]
    Fb = [T * di for di in d]
    F = [sum(R[i][j] * Fb[j] for j in range(3)) for i in range(3)]
    Db = [sum(R[j][i] * D[j] for j in range(3)) for i in range(3)]
    tau_T = cross([0.0, 0.0, -sc.l_cg], Fb)
    tau_D = cross([0.0, 0.0, sc.l_cp - sc.l_cg], Db)
    kt = (6 * sc.r_s ** 2 + sc.l_s ** 2) / 12
    kr = sc.r_s ** 2 / 2
    J = [m * kt, m * kt, m * kr]
    Jw = [J[i] * w[i] for i in range(3)]
    gyro = cross(w, Jw)
    wdot = [(tau_T[i] + tau_D[i] - gyro[i]) / J[i] for i in range(3)]
    qw = quat_mul(q, [0.0, w[0], w[1], w[2]])
    pull = KAPPA * (1 - (q[0] ** 2 + q[1] ** 2 + q[2] ** 2 + q[3] ** 2))
    return (v
            + [(F[i] + D[i]) / m - (sc.g0 if i == 2 else 0.0) for i in range(3)]
            + [0.5 * qw[i] + pull * q[i] for i in range(4)]
            + wdot
            + [-T / (sc.isp * sc.g0), chi1, chi2])


class Nlp6:
    """The 6-DoF LGR NLP, built once: decision X (N+1) x 16, U N x 3, t_f,
    scaled to order one like nlp_reference.LgrNlp."""

    def __init__(self, sc, N, intervals=1, ground=True, tol=1e-9, max_iter=3000,
                 tf_bounds=(1.0, 100.0)):
        self.sc, self.N = sc, N
        self.mesh = LgrMesh(N, intervals)
        m0 = sc.x0[6]
        self.x_scale = np.array([100.0] * 6 + [1.0] * 4 + [1.0] * 3 + [m0] + [1.0] * 2)
        self.u_scale = np.array([sc.T_max, 1.0, 1.0])
        self.tf_scale = 10.0
        nw = (N + 1) * NX + N * NU + 1
        w = ca.SX.sym("w", nw)
        X = ca.reshape(w[:(N + 1) * NX], NX, N + 1).T
        U = ca.reshape(w[(N + 1) * NX:(N + 1) * NX + N * NU], NU, N).T
        tf = w[-1] * self.tf_scale
        DX = ca.vertcat(*[ca.mtimes(ca.DM(Dk), X[start:start + nk + 1, :])
                          for start, nk, _, _, Dk in self.mesh.intervals])
        g, lbg, ubg = [], [], []
        for i in range(N):
            xp = [X[i, k] * self.x_scale[k] for k in range(NX)]
            up = [U[i, k] * self.u_scale[k] for k in range(NU)]
            f = rhs6(sc, xp, up, ca.sin, ca.cos, ca.sqrt)
            for k in range(NX):
                g.append(DX[i, k] - 0.5 * tf * f[k] / self.x_scale[k])
                lbg.append(0.0)
                ubg.append(0.0)
        # Path: the gimbal cone at the nodes after the first, the rate disc
        # at every collocation point.
        cmax = math.cos(sc.delta_max)
        for i in range(1, N + 1):
            g.append(1.0 - ca.cos(X[i, 14]) * ca.cos(X[i, 15]))
            lbg.append(-ca.inf)
            ubg.append(1 - cmax - BOUND_RELAX)
        for i in range(N):
            g.append((U[i, 1] ** 2 + U[i, 2] ** 2) / sc.chi_max ** 2)
            lbg.append(-ca.inf)
            ubg.append(1.0 - BOUND_RELAX)
        # Terminal attitude: the body axis R e_z = (0, 0, +).
        R = rotation([X[N, 6 + k] for k in range(4)])
        g += [R[0][2], R[1][2], R[2][2]]
        lbg += [0.0, 0.0, 0.0]
        ubg += [0.0, 0.0, ca.inf]
        self.lbg, self.ubg = np.array(lbg), np.array(ubg)
        inf = np.inf
        lbX, ubX = np.full((N + 1, NX), -inf), np.full((N + 1, NX), inf)
        self.lbX, self.ubX = lbX, ubX
        # Terminal r, V at the pad at rest; pitch and yaw rates zero.
        pad = [sc.xf[0], 0.0, sc.xf[1], sc.xf[2], 0.0, sc.xf[3]]
        for k in range(6):
            lbX[N, k] = ubX[N, k] = pad[k] / self.x_scale[k]
        lbX[N, 10] = ubX[N, 10] = 0.0
        lbX[N, 11] = ubX[N, 11] = 0.0
        if ground:
            lbX[1:, 2] = sc.xf[1] / self.x_scale[2]
        lbX[1:, 13] = sc.m_dry / self.x_scale[13]
        ubX[1:, 13] = 1.0
        lbU, ubU = np.empty((N, NU)), np.empty((N, NU))
        lbU[:, 0], ubU[:, 0] = sc.T_min / sc.T_max, 1.0
        lbU[:, 1:], ubU[:, 1:] = -sc.chi_max, sc.chi_max
        self.lbU, self.ubU = lbU, ubU
        self.tf_bounds = tf_bounds
        opts = {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes",
                "ipopt.tol": tol, "ipopt.max_iter": max_iter,
                "ipopt.bound_relax_factor": BOUND_RELAX}
        self.solver = ca.nlpsol("lgr6", "ipopt", {"x": w, "f": -X[N, 13], "g": ca.vertcat(*g)}, opts)

    def bounds(self, start):
        lbX, ubX = self.lbX.copy(), self.ubX.copy()
        lbX[0] = ubX[0] = np.asarray(start) / self.x_scale
        pack = lambda X, U, t: np.concatenate([X.ravel(), U.ravel(), [t / self.tf_scale]])
        return pack(lbX, self.lbU, self.tf_bounds[0]), pack(ubX, self.ubU, self.tf_bounds[1])

    def guess(self, start):
        """A straight line from the start to the pad; q from the start's to
        upright with its yaw and roll (normalised linear interpolation);
        the mass to the scenario's guess; T mid-range."""
        sc, N = self.sc, self.N
        s = (self.mesh.nodes + 1.0) / 2.0
        end = np.array(start, dtype=float)
        end[:6] = [sc.xf[0], 0.0, sc.xf[1], sc.xf[2], 0.0, sc.xf[3]]
        end[6:10] = self.upright
        end[10:13] = 0.0
        end[13] = sc.mf_guess
        end[14:] = 0.0
        X = np.array(start)[None, :] + s[:, None] * (end - np.array(start))[None, :]
        X[:, 6:10] /= np.linalg.norm(X[:, 6:10], axis=1)[:, None]
        U = np.zeros((N, NU))
        U[:, 0] = 0.5 * (sc.T_min + sc.T_max) / sc.T_max
        return np.concatenate([(X / self.x_scale).ravel(), U.ravel(), [sc.tf_guess / self.tf_scale]])

    def solve(self, start, upright, repeat=1):
        self.upright = upright
        lbw, ubw = self.bounds(start)
        w0 = self.guess(start)
        walls = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            sol = self.solver(x0=w0, lbx=lbw, ubx=ubw, lbg=self.lbg, ubg=self.ubg)
            walls.append(time.perf_counter() - t0)
        st = self.solver.stats()
        wopt = np.asarray(sol["x"]).ravel()
        X = wopt[:(self.N + 1) * NX].reshape(self.N + 1, NX) * self.x_scale
        U = wopt[(self.N + 1) * NX:-1].reshape(self.N, NU) * self.u_scale
        tf = wopt[-1] * self.tf_scale
        return dict(converged=bool(st["success"]), status=st["return_status"],
                    iterations=int(st["iter_count"]), tf_s=float(tf), mf_kg=float(X[-1, 13]),
                    q_norm_max_dev=float(np.max(np.abs(np.linalg.norm(X[:, 6:10], axis=1) - 1))),
                    time_ms=1e3 * statistics.median(walls), X=X, U=U)


def reintegrate6(sc, N, start, X, U, tf, rtol=1e-10, atol=1e-10):
    """The answer's controls flown by DOP853 from the start, as
    nlp_reference.reintegrate's default flies the planar answer: T linear in
    time between the collocation times (its last value held to t_f), the
    gimbal angles (d1, d2) its states, linear over all N + 1 nodes (so the
    gimbal states are prescribed, not integrated). Returns the final state
    and the lowest z along the flight (on a 1 ms grid)."""
    mesh = LgrMesh(N, 1)
    knots = (mesh.nodes + 1.0) / 2.0 * tf        # t_1 = 0 .. t_N, t_f
    T_knots = np.append(U[:, 0], U[-1, 0])
    state = np.array(start, dtype=float)
    lowest = state[2]
    for k in range(N):
        ta, tb = knots[k], knots[k + 1]
        if tb <= ta:
            continue

        def f(t, y, ta=ta, tb=tb, k=k):
            a = (t - ta) / (tb - ta)
            T = T_knots[k] + a * (T_knots[k + 1] - T_knots[k])
            d = X[k, 14:16] + a * (X[k + 1, 14:16] - X[k, 14:16])
            y = list(y[:14]) + list(d)
            return rhs6(sc, y, [T, 0.0, 0.0], math.sin, math.cos, math.sqrt)[:14]

        grid = np.arange(ta, tb, 1e-3)
        r = solve_ivp(f, (ta, tb), state[:14], method="DOP853", rtol=rtol, atol=atol,
                      t_eval=np.append(grid, tb))
        if not r.success:
            raise RuntimeError(f"re-integration failed: {r.message}")
        lowest = min(lowest, float(np.min(r.y[2])))
        state[:14] = r.y[:, -1]
        state[14:16] = X[k + 1, 14:16]
    return state, lowest


def start_state(sc, y=0.0, vy=0.0, psi=0.0, phi=0.0, rates=(0.0, 0.0, 0.0)):
    """The 6-DoF start of a scenario: its planar state, then the out-of-plane
    offsets; rates are body rates added to (0, -w0, 0)."""
    x0 = sc.x0
    s = np.zeros(NX)
    s[0:6] = [x0[0], y, x0[1], x0[2], vy, x0[3]]
    s[6:10] = attitude(x0[4], psi, phi)
    s[10:13] = [rates[0], -x0[5] + rates[1], rates[2]]
    s[13] = x0[6]
    s[14] = sc.delta0
    return s


def planar_solve(p2, repeat):
    """The planar P2 solve from its straight line, `repeat` times: the
    answer, IPOPT's stats and the median time [ms], as Nlp6.solve times."""
    walls = []
    for _ in range(repeat):
        sol, st, wall = p2.solve(p2.initial_guess())
        walls.append(wall)
    return sol, st, 1e3 * statistics.median(walls)


def planar_check(sc, N, repeat):
    """The 6-DoF solve of a planar state against the planar P2 solve."""
    six = Nlp6(sc, N).solve(start_state(sc), attitude(0.0), repeat)
    p2 = LgrNlp(sc, N, "P2", intervals=1, ground=True)
    sol, st, planar_ms = planar_solve(p2, repeat)
    X, _, tf = p2.unpack_physical(sol["x"])
    out = dict(six={k: v for k, v in six.items() if k not in ("X", "U")},
               planar=dict(converged=bool(st["success"]), tf_s=tf, mf_kg=float(X[-1, 6]), time_ms=planar_ms),
               out_of_plane_max=float(np.max(np.abs(six["X"][:, [1, 4, 7, 9, 10, 12, 15]]))))
    out["tf_rel"] = abs(six["tf_s"] - tf) / tf
    out["mf_rel"] = abs(six["mf_kg"] - out["planar"]["mf_kg"]) / out["planar"]["mf_kg"]
    return out


# The documented box (issue 15: bench/envelope.py's BOX) with the 3-D
# offsets of issue 38.
BOX = [(-200, 200), (500, 800), (-15, 15), (-95, -70), (80, 95), (110000, 125000)]
OUT = dict(y=(-200, 200), vy=(-15, 15), psi_deg=(-20, 20), phi_deg=(-20, 20), rate_degps=(-5, 5))


def dispersed_starts(sc_path, count, seed):
    """The seeded 3-D states of the box (BOX and OUT): per state its name,
    scenario (its planar start, the guess m_f = m_0 - 5 t), 6-DoF start and
    the upright attitude with its yaw and roll (the guess's end)."""
    rng = random.Random(seed)
    for k in range(count):
        x, z, vx, vz, th, m = (rng.uniform(lo, hi) for lo, hi in BOX)
        y, vy = rng.uniform(*OUT["y"]), rng.uniform(*OUT["vy"])
        psi, phi = (math.radians(rng.uniform(*OUT[f])) for f in ("psi_deg", "phi_deg"))
        rates = tuple(math.radians(rng.uniform(*OUT["rate_degps"])) for _ in range(3))
        sc = load_scenario(sc_path)
        sc = dataclasses.replace(sc, x0=np.array([x, z, vx, vz, math.radians(th), 0.0, m]),
                                 mf_guess=m - 5000.0)
        yield f"box3d{k}", sc, start_state(sc, y, vy, psi, phi, rates), attitude(0.0, psi, phi)


def dispersed(sc_path, count, seed, N, repeat):
    rows = []
    for name, sc, start, upright in dispersed_starts(sc_path, count, seed):
        six = Nlp6(sc, N).solve(start, upright, repeat)
        end, lowest = reintegrate6(sc, N, start, six["X"], six["U"], six["tf_s"])
        pad = np.array([sc.xf[0], 0.0, sc.xf[1]])
        p2 = LgrNlp(sc, N, "P2", intervals=1, ground=True)
        sol, st, planar_ms = planar_solve(p2, repeat)
        row = dict(name=name, converged=six["converged"], status=six["status"],
                   iterations=six["iterations"], tf_s=six["tf_s"], mf_kg=six["mf_kg"],
                   time_ms=six["time_ms"], planar_converged=bool(st["success"]), planar_time_ms=planar_ms,
                   q_norm_max_dev=six["q_norm_max_dev"],
                   flown_miss_m=float(np.linalg.norm(end[0:3] - pad)),
                   flown_miss_mps=float(np.linalg.norm(end[3:6])),
                   flown_lowest_z_m=lowest - sc.xf[1])
        rows.append(row)
        print(f"{row['name']:8s} {row['status']:28s} it {row['iterations']:4d} tf {row['tf_s']:7.3f} s "
              f"mf {row['mf_kg']:10.2f} kg  {row['time_ms']:8.1f} ms (planar {planar_ms:7.1f} ms) "
              f"|q|-1 {row['q_norm_max_dev']:.1e}; flown: miss {row['flown_miss_m']:.2f} m "
              f"{row['flown_miss_mps']:.2f} m/s, lowest z {row['flown_lowest_z_m']:+.2f} m", file=sys.stderr)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    here = Path(__file__).resolve().parent
    ap.add_argument("--scenario", default=str(here.parent.parent / "scenarios" / "paper.toml"))
    ap.add_argument("--nodes", type=int, default=20)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--planar-check", action="store_true")
    ap.add_argument("--states", type=int, default=0)
    ap.add_argument("--seed", type=int, default=38)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    sc = load_scenario(a.scenario)
    if a.planar_check:
        out = planar_check(sc, a.nodes, a.repeat)
        print(json.dumps(out, indent=1) if a.json else
              f"6-DoF: {out['six']['status']}, tf {out['six']['tf_s']:.9f} s, mf {out['six']['mf_kg']:.6f} kg, "
              f"{out['six']['time_ms']:.1f} ms\nplanar: tf {out['planar']['tf_s']:.9f} s, "
              f"mf {out['planar']['mf_kg']:.6f} kg, {out['planar']['time_ms']:.1f} ms\n"
              f"relative: tf {out['tf_rel']:.1e}, mf {out['mf_rel']:.1e}; out of plane max "
              f"{out['out_of_plane_max']:.1e}")
        return 0 if out["six"]["converged"] and out["tf_rel"] < 1e-6 and out["mf_rel"] < 1e-6 else 1
    if a.states:
        rows = dispersed(a.scenario, a.states, a.seed, a.nodes, a.repeat)
        conv = [r for r in rows if r["converged"]]
        ratio = [r["time_ms"] / r["planar_time_ms"] for r in conv]
        summary = dict(states=len(rows), converged=len(conv),
                       time_ms_median=statistics.median(r["time_ms"] for r in conv) if conv else None,
                       planar_time_ms_median=statistics.median(r["planar_time_ms"] for r in rows),
                       ratio_median=statistics.median(ratio) if ratio else None,
                       flown_miss_m_median=statistics.median(r["flown_miss_m"] for r in conv) if conv else None,
                       flown_below_ground=int(sum(r["flown_lowest_z_m"] < -1e-3 for r in conv)))
        print(json.dumps(dict(summary=summary, rows=rows), indent=1) if a.json else summary)
        return 0
    ap.error("give --planar-check or --states K")


if __name__ == "__main__":
    sys.exit(main())
