#!/usr/bin/env python3
"""Independent NLP reference solver for the starship-like flip-and-land problem.

Chen, Ma, Wang, Su, "Online Trajectory Optimization Method for Large Attitude
Flip Vertical Landing of the Starship-like Vehicle", Mathematics 2023, 11, 288.

This file solves the paper's problems P1 and P2 *directly* as nonlinear programs
(no convexification, no SCvx) so that the project's own solver can be checked
against an independent answer:

* P1 (Sec. 2, Eq. 1-7): states x, z, Vx, Vz, theta, w, m; controls T, delta.
* P2 (Sec. 3.1, Eq. 8-10): P1 plus the gimbal angle delta as a state; the
  controls are T and chi = d(delta)/dt.

Both are transcribed with Legendre-Gauss-Radau (LGR) collocation, implemented
here from scratch (Sec. 3.2, Eq. 24), and solved with CasADi + IPOPT. The
collocation mesh is either the paper's single global LGR interval (M = 1), an
hp mesh of M equal LGR intervals, or an explicit layout of interval breaks and
points per interval (see `LgrMesh`).

An optional `[constraints]` table of the scenario adds the operational path
constraints of issue 37 (approach cone, pitch-rate limit, tilt limit below an
altitude, lateral-speed limit in the final descent) as smooth rows at the free
LGR nodes; `--no-constraints` ignores it (see `constraint_rows`).

Nothing from the rest of the repository is imported: the only inputs are the
scenario TOML file and the command-line options.

Usage:
    python nlp_reference.py --scenario ../../scenarios/paper.toml \
        --nodes 20 --problem P2 [--intervals M] [--repeat 5] [--json]
    python nlp_reference.py --scenario ../../scenarios/paper.toml --problem P2 \
        --breaks-tau -1,-0.2,1 --points 8,8        # explicit mesh layout
    python nlp_reference.py --scenario ../../scenarios/paper.toml --problem P2 \
        --layout-json bellyflop_solve.json         # bellyflop's solved mesh
    python nlp_reference.py --scenario with_constraints.toml --problem P2 \
        [--no-constraints]                         # [constraints] on / off
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import tomllib
import dataclasses
from dataclasses import dataclass

import casadi as ca
import numpy as np
from numpy.polynomial import legendre as npleg
from scipy.integrate import solve_ivp


# --------------------------------------------------------------------------
# Scenario
# --------------------------------------------------------------------------
@dataclass(frozen=True)
class Scenario:
    """All physical parameters in SI units, angles in radians."""

    name: str
    m_dry: float      # dry mass [kg]
    l_s: float        # vehicle length [m]
    r_s: float        # vehicle radius [m]
    l_cg: float       # centre of mass position [m]
    l_cp: float       # centre of pressure position [m]
    T_max: float      # [N]
    T_min: float      # [N]
    isp: float        # [s]
    delta_max: float  # [rad]
    chi_max: float    # [rad/s]
    C_LD: float       # lumped drag coefficient 1/2 rho c_D A [kg/m]
    g0: float         # [m/s^2]
    x0: np.ndarray    # initial [x, z, Vx, Vz, theta, w, m]
    delta0: float     # initial gimbal angle [rad]
    xf: np.ndarray    # terminal [x, z, Vx, Vz, theta, w]
    nodes: int        # default N
    tf_guess: float   # [s]
    mf_guess: float   # [kg]
    intervals: int = 1  # default number of LGR mesh intervals M
    # Explicit layout from [discretization.mesh] (None: uniform mesh of
    # `nodes` over `intervals`); when set, nodes = sum(points) and
    # intervals = len(points).
    mesh_breaks_tau: tuple[float, ...] | None = None
    mesh_points: tuple[int, ...] | None = None
    # The operational path constraints of the optional [constraints] table
    # (None: none, the paper's problem).
    constraints: Constraints | None = None

    def mesh(self) -> "LgrMesh":
        """The scenario's default mesh: its explicit layout, else uniform."""
        if self.mesh_points is not None:
            return LgrMesh.from_layout(self.mesh_breaks_tau, self.mesh_points)
        return LgrMesh(self.nodes, self.intervals)


def load_scenario(path: str) -> Scenario:
    """Read a scenario TOML file. An optional `[discretization.mesh]` table
    (`breaks_tau`, M + 1 values from -1 to 1; `points`, M sizes >= 2) defines
    the mesh and overrides `nodes` and `intervals` (N = sum(points),
    M = len(points)); an optional `[constraints]` table switches on the
    operational path constraints (`parse_constraints`). An invalid table
    raises ValueError."""
    with open(path, "rb") as fh:
        d = tomllib.load(fh)
    v, e, i, f = d["vehicle"], d["environment"], d["initial"], d["terminal"]
    disc = d["discretization"]
    rad = math.radians
    breaks, points = None, None
    if "mesh" in disc:
        tbl = disc["mesh"]
        if not isinstance(tbl, dict) or "breaks_tau" not in tbl or "points" not in tbl:
            raise ValueError(f"{path}: [discretization.mesh] needs breaks_tau and points")
        try:
            breaks, points = validate_layout(tbl["breaks_tau"], tbl["points"])
        except ValueError as exc:
            raise ValueError(f"{path}: [discretization.mesh]: {exc}") from None
    try:
        constraints = parse_constraints(d.get("constraints"))
    except ValueError as exc:
        raise ValueError(f"{path}: [constraints]: {exc}") from None
    return Scenario(
        name=d.get("name", path),
        m_dry=v["dry_mass_kg"], l_s=v["length_m"], r_s=v["radius_m"],
        l_cg=v["cg_m"], l_cp=v["cp_m"],
        T_max=v["max_thrust_n"], T_min=v["min_thrust_n"], isp=v["isp_s"],
        delta_max=rad(v["max_gimbal_deg"]), chi_max=rad(v["max_gimbal_rate_degps"]),
        C_LD=v["drag_coefficient_kgpm"], g0=e["g0_mps2"],
        x0=np.array([i["x_m"], i["z_m"], i["vx_mps"], i["vz_mps"],
                     rad(i["theta_deg"]), rad(i["pitch_rate_degps"]), i["mass_kg"]]),
        delta0=rad(i.get("gimbal_deg", 0.0)),
        xf=np.array([f["x_m"], f["z_m"], f["vx_mps"], f["vz_mps"],
                     rad(f["theta_deg"]), rad(f["pitch_rate_degps"])]),
        nodes=sum(points) if points else int(disc["nodes"]),
        tf_guess=disc["tf_guess_s"], mf_guess=disc["final_mass_guess_kg"],
        intervals=len(points) if points else int(disc.get("intervals", 1)),
        mesh_breaks_tau=tuple(breaks) if points else None,
        mesh_points=tuple(points) if points else None,
        constraints=constraints,
    )


# --------------------------------------------------------------------------
# Operational path constraints (issue 37): the optional [constraints] table
# --------------------------------------------------------------------------
SIGMA_M = 1.0                  # softplus width of the altitude triggers [m]
S_TILT = math.pi / 180.0       # tilt limit's opening above tilt_below_m [rad/m] (1 deg/m)
S_LAT = 1.0                    # lateral limit's opening above final_descent_m [(m/s)/m]

# Each field of [constraints]: (lowest, highest, lowest excluded). All optional.
CONSTRAINT_RANGES = {
    "cone_half_angle_deg": (1.0, 89.0, False),
    "max_pitch_rate_degps": (0.0, 360.0, True),
    "max_tilt_deg": (0.0, 90.0, False),
    "tilt_below_m": (0.0, 1e5, False),
    "final_descent_m": (0.0, 1e5, False),
    "final_descent_lateral_mps": (0.0, 100.0, False),
}
# Fields that switch a limit on only together.
CONSTRAINT_PAIRS = (("max_tilt_deg", "tilt_below_m"),
                    ("final_descent_m", "final_descent_lateral_mps"))
# The limits in row order: name -> (unit of its rows' values, description).
LIMITS = {
    "cone": ("m", "the approach cone"),
    "pitch_rate": ("rad/s", "the pitch-rate limit"),
    "tilt": ("rad", "the tilt limit"),
    "final_descent": ("m/s", "the final descent's lateral-speed limit"),
}


@dataclass(frozen=True)
class Constraints:
    """The `[constraints]` table, in its own units (deg, deg/s, m, m/s);
    None is off. See `constraint_rows` for the rows they give."""

    cone_half_angle_deg: float | None = None
    max_pitch_rate_degps: float | None = None
    max_tilt_deg: float | None = None
    tilt_below_m: float | None = None
    final_descent_m: float | None = None
    final_descent_lateral_mps: float | None = None

    def as_dict(self) -> dict:
        """The fields given, as in the table (for the JSON output)."""
        return {k: getattr(self, k) for k in CONSTRAINT_RANGES if getattr(self, k) is not None}

    def limits(self) -> list[str]:
        """The names (keys of LIMITS) of the limits switched on, in row order."""
        on = {"cone": self.cone_half_angle_deg is not None,
              "pitch_rate": self.max_pitch_rate_degps is not None,
              "tilt": self.max_tilt_deg is not None,
              "final_descent": self.final_descent_m is not None}
        return [k for k in LIMITS if on[k]]


def parse_constraints(tbl) -> Constraints | None:
    """Check a `[constraints]` table (the dict from the TOML, or None) and
    return it, or None when it is absent or empty (no limit: the paper's
    problem). Every field is optional and must be a number within
    CONSTRAINT_RANGES; the fields of a CONSTRAINT_PAIRS pair come together;
    an unknown field is refused (a misspelt limit must not silently be off).
    Raises ValueError naming the field."""
    if tbl is None:
        return None
    if not isinstance(tbl, dict):
        raise ValueError(f"must be a table (got {tbl!r})")
    unknown = [k for k in tbl if k not in CONSTRAINT_RANGES]
    if unknown:
        raise ValueError(f"unknown field(s) {', '.join(unknown)}; the fields are "
                         f"{', '.join(CONSTRAINT_RANGES)}")
    vals = {}
    for key, v in tbl.items():
        lo, hi, lo_open = CONSTRAINT_RANGES[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ValueError(f"{key} must be a number (got {v!r})")
        v = float(v)
        if not (math.isfinite(v) and (v > lo if lo_open else v >= lo) and v <= hi):
            raise ValueError(f"{key} = {v:g} is out of range: allowed "
                             f"{'(' if lo_open else '['}{lo:g}, {hi:g}]")
        vals[key] = v
    for a, b in CONSTRAINT_PAIRS:
        if (a in vals) != (b in vals):
            have, missing = (a, b) if a in vals else (b, a)
            raise ValueError(f"{have} needs {missing}: the two are given together")
    return Constraints(**vals) if vals else None


def softplus(u, lib=np):
    """sp(u) = SIGMA ln(1 + exp(u / SIGMA)), written as
    max(u, 0) + SIGMA log1p(exp(-|u| / SIGMA)) so that it never overflows.
    `lib` is numpy or casadi (both have fmax, fabs, log1p, exp). The direct
    form overflows to inf (and NaN derivatives) for u > 709 SIGMA, i.e. at
    altitudes 709 m above a trigger, which initial states and iterates can
    reach. In CasADi this form's value and gradient are exact everywhere (the
    derivative of fmax at u = 0 is 1/2, which is sp'(0)); its AD Hessian is
    exact except at u == 0.0 exactly, where sign(0) = 0 gives 0 instead of
    1/(4 SIGMA): a single floating-point value that the iterates do not hit."""
    return lib.fmax(u, 0.0) + SIGMA_M * lib.log1p(lib.exp(-lib.fabs(u) / SIGMA_M))


def constraint_rows(c: Constraints, xf, s, lib=np) -> list[tuple[str, object]]:
    """The smooth rows g <= 0 of the limits switched on, at the state
    s = [x, z, Vx, Vz, theta, w, m] in physical units (numbers, numpy arrays
    over nodes, or CasADi expressions; `lib` as in `softplus`). Returns
    [(limit, g)], two rows (+ then -) per limit in LIMITS order, each in the
    unit of LIMITS. With dx = x - x_f, dz = z - z_f (the pad):
      cone:          +-dx - tan(gamma) dz                      [m]
      pitch_rate:    +-w - w_max                               [rad/s]
      tilt:          +-theta - theta_max - S_TILT sp(dz - h)   [rad]
      final_descent: +-Vx - v_fd - S_LAT sp(dz - h_fd)         [m/s]
    """
    dx, dz = s[0] - xf[0], s[1] - xf[1]
    rows: list[tuple[str, object]] = []

    def both(limit, y, bound):
        rows.append((limit, y - bound))
        rows.append((limit, -y - bound))

    if c.cone_half_angle_deg is not None:
        both("cone", dx, math.tan(math.radians(c.cone_half_angle_deg)) * dz)
    if c.max_pitch_rate_degps is not None:
        both("pitch_rate", s[5], math.radians(c.max_pitch_rate_degps))
    if c.max_tilt_deg is not None:
        both("tilt", s[4], math.radians(c.max_tilt_deg)
             + S_TILT * softplus(dz - c.tilt_below_m, lib))
    if c.final_descent_m is not None:
        both("final_descent", s[2], c.final_descent_lateral_mps
             + S_LAT * softplus(dz - c.final_descent_m, lib))
    return rows


def constraint_report(c: Constraints, xf, X: np.ndarray) -> dict:
    """Each limit's rows over the N + 1 state nodes of X ((N+1) x >=7,
    physical): {limit: {"unit", "per_node" (max of its two rows at each
    node), "max" (over all nodes), "node" (where), "max_free" (over the free
    nodes 1..N-1, where the NLP imposes it; the two ends are fixed) and
    "node_free"}}. A row value <= 0 holds; the free maximum near 0 means the
    limit is active. (At t_f the cone's value is 0 by construction: the apex.)"""
    per: dict[str, np.ndarray] = {}
    for limit, g in constraint_rows(c, xf, [X[:, k] for k in range(7)]):
        per[limit] = np.maximum(per[limit], g) if limit in per else np.asarray(g, float)
    out = {}
    for limit, v in per.items():
        k = int(np.argmax(v))
        kf = 1 + int(np.argmax(v[1:-1])) if len(v) > 2 else None
        out[limit] = {"unit": LIMITS[limit][0], "max": float(v[k]), "node": k,
                      "max_free": None if kf is None else float(v[kf]), "node_free": kf,
                      "per_node": v.tolist()}
    return out


def _row_detail(limit: str, c: Constraints, xf, state) -> str:
    """A limit's row written out with the numbers of one state (for messages)."""
    x, z, vx, th, w = state[0], state[1], state[2], state[4], state[5]
    dx, dz = x - xf[0], z - xf[1]
    if limit == "cone":
        return (f"|x - x_f| - tan(gamma) (z - z_f) with gamma = {c.cone_half_angle_deg:g} deg, "
                f"x - x_f = {dx:g} m, z - z_f = {dz:g} m")
    if limit == "pitch_rate":
        return (f"|w| - w_max with w = {math.degrees(w):g} deg/s, "
                f"w_max = {c.max_pitch_rate_degps:g} deg/s")
    if limit == "tilt":
        return (f"|theta| - theta_max - S_TILT sp(z - z_f - h) with theta = "
                f"{math.degrees(th):g} deg, theta_max = {c.max_tilt_deg:g} deg, "
                f"z - z_f = {dz:g} m, h = {c.tilt_below_m:g} m")
    return (f"|Vx| - v_fd - S_LAT sp(z - z_f - h_fd) with Vx = {vx:g} m/s, "
            f"v_fd = {c.final_descent_lateral_mps:g} m/s, z - z_f = {dz:g} m, "
            f"h_fd = {c.final_descent_m:g} m")


def check_fixed_ends(sc: Scenario, c: Constraints, tol: float = 1e-9) -> None:
    """The states at t = 0 ([initial]) and at t_f ([terminal]) are fixed, so
    the NLP cannot move them onto a limit: raise ValueError naming each limit
    that either breaks (row value > tol in its unit), with the value, instead
    of letting IPOPT fail without saying why."""
    bad = []
    for where, state in (("initial", sc.x0), ("terminal", np.append(sc.xf, sc.x0[6]))):
        worst: dict[str, float] = {}
        for limit, g in constraint_rows(c, sc.xf, list(state)):
            worst[limit] = max(worst.get(limit, -math.inf), float(g))
        for limit, v in worst.items():
            if v > tol:
                bad.append(f"the {where} state breaks {LIMITS[limit][1]}: row = {v:+.6g} "
                           f"{LIMITS[limit][0]} > 0 ({_row_detail(limit, c, sc.xf, state)})")
    if bad:
        raise ValueError("; ".join(bad) + ". That state is fixed, so the problem is "
                         "infeasible: no solve attempted")


# --------------------------------------------------------------------------
# Dynamics, Eq. (1)-(3) and (8)
# --------------------------------------------------------------------------
def p1_rhs(sc: Scenario, s, T, delta, sin, cos, sqrt):
    """Right-hand side of Eq. (1) for state s = [x, z, Vx, Vz, theta, w, m].

    Written once against generic math functions so that the same code builds
    the CasADi SX graph (NLP) and evaluates with numpy (re-integration).
    Returns a list of 7 derivatives.
    """
    _, _, vx, vz, th, w, m = (s[k] for k in range(7))
    speed = sqrt(vx * vx + vz * vz)
    Dx = -sc.C_LD * speed * vx                       # Eq. (2)
    Dz = -sc.C_LD * speed * vz
    J = m * (6.0 * sc.r_s ** 2 + sc.l_s ** 2) / 12.0  # Eq. (3)
    M_T = -sc.l_cg * T * sin(delta)
    M_D = -(sc.l_cp - sc.l_cg) * (Dx * cos(th) + Dz * sin(th))
    return [
        vx,
        vz,
        (-T * sin(th + delta) + Dx) / m,
        (T * cos(th + delta) + Dz) / m - sc.g0,
        w,
        (M_T + M_D) / J,
        -T / (sc.isp * sc.g0),
    ]


# --------------------------------------------------------------------------
# Legendre-Gauss-Radau collocation (own implementation)
# --------------------------------------------------------------------------
def lgr_points(N: int) -> np.ndarray:
    """N LGR points on [-1, 1): tau_1 = -1 and the roots of
    P_{N-1} + P_N, sorted ascending. Roots are polished by Newton's method."""
    c = np.zeros(N + 1)
    c[N - 1] = 1.0
    c[N] = 1.0
    tau = np.sort(np.real(npleg.legroots(c)))
    dc = npleg.legder(c)
    for _ in range(5):  # Newton polish (the companion-matrix roots are ~1e-14 already)
        step = npleg.legval(tau, c) / npleg.legval(tau, dc)
        step[0] = 0.0   # tau_1 = -1 exactly
        tau = tau - step
    tau[0] = -1.0
    return tau


def lagrange_diff_matrix(tau_col: np.ndarray, tau_all: np.ndarray) -> np.ndarray:
    """D[i, j] = dL_j/dtau (tau_col[i]) for the Lagrange basis L_j on tau_all.

    Barycentric formula: with weights b_j = 1 / prod_{k != j}(tau_j - tau_k),
    L_j'(tau_i) = (b_j / b_i) / (tau_i - tau_j) for i != j and
    L_i'(tau_i) = -sum_{j != i} L_j'(tau_i). Requires tau_col subset of tau_all
    (here the N collocation points are the first N of the N+1 support points).
    """
    n = len(tau_all)
    b = np.array([1.0 / np.prod([tau_all[j] - tau_all[k] for k in range(n) if k != j])
                  for j in range(n)])
    D = np.zeros((len(tau_col), n))
    for i, ti in enumerate(tau_col):
        ii = int(np.argmin(np.abs(tau_all - ti)))
        for j in range(n):
            if j != ii:
                D[i, j] = (b[j] / b[ii]) / (tau_all[ii] - tau_all[j])
        D[i, ii] = -np.sum(D[i, :])
    return D


def lgr_weights(N: int, tau: np.ndarray | None = None) -> np.ndarray:
    """The N LGR quadrature weights on [-1, 1]:
    w_i = (1 - tau_i) / (N^2 P_{N-1}(tau_i)^2), so w_1 = 2 / N^2. Exact for
    polynomials of degree <= 2N - 2."""
    if tau is None:
        tau = lgr_points(N)
    c = np.zeros(N)
    c[N - 1] = 1.0
    return (1.0 - tau) / (N * N * npleg.legval(tau, c) ** 2)


def validate_layout(breaks_tau, points) -> tuple[list[float], list[int]]:
    """Check an explicit mesh layout and return it as (floats, ints).

    `breaks_tau` holds M + 1 strictly increasing values from -1 to +1 (the
    ends within 1e-12, then set exactly), `points` the M interval sizes n_k,
    each >= 2. Raises ValueError with a message naming the problem.
    """
    try:
        if isinstance(breaks_tau, (str, bytes)):
            raise TypeError
        b = [float(v) for v in breaks_tau]
    except (TypeError, ValueError):
        raise ValueError(f"breaks_tau must be a list of numbers (got {breaks_tau!r})") from None
    try:
        if isinstance(points, (str, bytes)):
            raise TypeError
        pts = []
        for v in points:
            if isinstance(v, bool) or not float(v).is_integer():
                raise ValueError
            pts.append(int(v))
    except (TypeError, ValueError):
        raise ValueError(f"points must be a list of integers (got {points!r})") from None
    if len(pts) < 1:
        raise ValueError("points must list at least one interval")
    if len(b) != len(pts) + 1:
        raise ValueError(
            f"breaks_tau needs len(points) + 1 = {len(pts) + 1} values for "
            f"{len(pts)} interval(s) (got {len(b)})")
    if not all(math.isfinite(v) for v in b):
        raise ValueError(f"breaks_tau must be finite (got {b})")
    if abs(b[0] + 1.0) > 1e-12 or abs(b[-1] - 1.0) > 1e-12:
        raise ValueError(f"breaks_tau must run from -1 to 1 (got {b[0]:g} .. {b[-1]:g})")
    b[0], b[-1] = -1.0, 1.0
    for k in range(len(pts)):
        if not b[k + 1] > b[k]:
            raise ValueError(
                f"breaks_tau must be strictly increasing (breaks_tau[{k}] = {b[k]:g}, "
                f"breaks_tau[{k + 1}] = {b[k + 1]:g})")
    for k, n in enumerate(pts):
        if n < 2:
            raise ValueError(f"each interval needs at least 2 LGR points (points[{k}] = {n})")
    return b, pts


def parse_layout(text: str) -> dict:
    """Read a mesh layout from JSON text: the `mesh_layout` object of a
    bellyflop `solve --json` output (or of this script's `--json` output), or
    a bare {"breaks_tau": [...], "points": [...]} object. Returns that
    object unvalidated; raises ValueError if there is none."""
    try:
        d = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"not JSON: {exc}") from None
    if isinstance(d, dict) and isinstance(d.get("mesh_layout"), dict):
        d = d["mesh_layout"]
    if not (isinstance(d, dict) and "breaks_tau" in d and "points" in d):
        raise ValueError('no "mesh_layout": {"breaks_tau": [...], "points": [...]} object')
    return d


class LgrMesh:
    """N LGR collocation points split over M intervals (an hp mesh).

    tau in [-1, 1] is cut at the breaks tau_0 = -1 < tau_1 < ... < tau_M = 1;
    interval k = [tau_k, tau_{k+1}] carries n_k >= 2 points, N = sum n_k.
    `LgrMesh(N, M)` is the uniform mesh: tau_k = -1 + 2k/M, n_k = N // M, the
    first N % M intervals one more. `LgrMesh.from_layout(breaks_tau, points)`
    is any explicit layout (bellyflop's `[discretization.mesh]` table or its
    solved `mesh_layout`). Interval k's points are the standard n_k-point LGR
    points mapped affinely from [-1, 1] onto [tau_k, tau_{k+1}]; its
    non-collocated end point is the next interval's first point (a shared state
    node), and tau = +1 is the last state node. So `nodes` holds N + 1 strictly
    increasing values: each interval's LGR points in turn, then +1. Collocation
    point i (global) of interval k uses the row (2/h_k) D^(k)_i over the
    n_k + 1 state nodes start_k .. start_k + n_k, where D^(k) is the
    n_k x (n_k + 1) LGR differentiation matrix on [-1, 1] and
    h_k = tau_{k+1} - tau_k. `weights` are the N quadrature weights on [-1, 1]
    (each interval's LGR weights times h_k/2).

    M = 1 is the paper's global mesh, value for value (2/h = 1, nodes unmapped).
    """

    def __init__(self, N: int, M: int):
        if M < 1:
            raise ValueError(f"intervals must be >= 1 (got {M})")
        base, extra = divmod(N, M)
        if base < 2:
            raise ValueError(
                f"N = {N} over M = {M} intervals leaves {base} point(s) in an interval; "
                f"each interval needs at least 2, so M <= {N // 2}")
        breaks = [-1.0 + 2.0 * k / M for k in range(M)] + [1.0]
        self._build(breaks, [base + (1 if k < extra else 0) for k in range(M)])
        self.uniform = True

    @classmethod
    def from_layout(cls, breaks_tau, points) -> "LgrMesh":
        """The mesh of an explicit layout: M + 1 breaks from -1 to 1 (strictly
        increasing) and M interval sizes (each >= 2). Raises ValueError (see
        `validate_layout`). A uniform layout gives `LgrMesh(N, M)` exactly."""
        b, pts = validate_layout(breaks_tau, points)
        mesh = cls.__new__(cls)
        mesh._build(b, pts)
        mesh.uniform = False
        return mesh

    def _build(self, breaks: list[float], points: list[int]) -> None:
        M, N = len(points), sum(points)
        self.N, self.M = N, M
        self.breaks_tau = list(breaks)
        # Per interval: (start node, n_k, tau_lo, tau_hi, scaled local D).
        self.intervals: list[tuple[int, int, float, float, np.ndarray]] = []
        nodes, weights = [], []
        cache: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}
        start = 0
        for k, nk in enumerate(points):
            tau_lo, tau_hi = breaks[k], breaks[k + 1]
            half = 0.5 * (tau_hi - tau_lo)          # h_k / 2
            if nk not in cache:
                t = lgr_points(nk)
                cache[nk] = (t, lagrange_diff_matrix(t, np.append(t, 1.0)), lgr_weights(nk, t))
            t, D, wq = cache[nk]
            whole = tau_lo == -1.0 and tau_hi == 1.0   # M = 1: keep the rule unmapped
            nodes.extend(t if whole else tau_lo + half * (t + 1.0))
            weights.extend(wq if whole else half * wq)
            self.intervals.append((start, nk, tau_lo, tau_hi, D / half))
            start += nk
        assert start == N
        nodes.append(1.0)
        self.nodes = np.array(nodes)                 # N + 1 state nodes in tau
        self.weights = np.array(weights)             # N quadrature weights
        self.points = [iv[1] for iv in self.intervals]
        assert np.all(np.diff(self.nodes) > 0)

    def layout(self) -> dict:
        """{"breaks_tau": [...], "points": [...]}, as bellyflop's `mesh_layout`."""
        return {"breaks_tau": [float(b) for b in self.breaks_tau],
                "points": [int(n) for n in self.points]}

    def global_matrix(self) -> np.ndarray:
        """The N x (N+1) block-row differentiation matrix (dense, for checks)."""
        D = np.zeros((self.N, self.N + 1))
        for start, nk, _, _, Dk in self.intervals:
            D[start:start + nk, start:start + nk + 1] = Dk
        return D


# --------------------------------------------------------------------------
# NLP construction
# --------------------------------------------------------------------------
# IPOPT's bound_relax_factor (its default value, set explicitly): the path rows
# are imposed as g <= -BOUND_RELAX so that IPOPT's relaxed bound is g <= 0.
BOUND_RELAX = 1e-8

class LgrNlp:
    """Builds the LGR-collocated NLP for P1 or P2 once; can be solved repeatedly.

    Decision vector (all scaled to order one, physical = scale * scaled):
        X  (N+1) x nx   states at the N collocation points and at tau = +1
        U   N    x nu   controls at the N collocation points
        tf              final time
    The mesh is `mesh` if given (any `LgrMesh`, e.g. `LgrMesh.from_layout`;
    its N must equal N), else `LgrMesh(N, intervals)`; intervals = 1 is the
    global mesh.
    """

    def __init__(self, sc: Scenario, N: int, problem: str,
                 tol: float = 1e-9, max_iter: int = 3000,
                 tf_bounds: tuple[float, float] = (1.0, 100.0),
                 intervals: int = 1, ground: bool = False,
                 mesh: LgrMesh | None = None):
        self.ground = ground
        if problem not in ("P1", "P2"):
            raise ValueError("problem must be P1 or P2")
        if mesh is not None and mesh.N != N:
            raise ValueError(f"mesh has {mesh.N} points, not N = {N}")
        self.sc, self.N, self.problem = sc, N, problem
        self.mesh = mesh if mesh is not None else LgrMesh(N, intervals)
        self.tau_all = self.mesh.nodes               # N + 1 state nodes
        self.tau = self.tau_all[:N]                  # N collocation points

        # State/control layout and scale factors (physical = scale * scaled).
        m0 = sc.x0[6]
        #            x      z      Vx     Vz     theta  w    m
        xs = [100.0, 100.0, 100.0, 100.0, 1.0, 1.0, m0]
        if problem == "P1":
            us = [sc.T_max, 1.0]                 # T, delta
        else:
            xs = xs + [1.0]                      # delta
            us = [sc.T_max, 1.0]                 # T, chi
        self.x_scale = np.array(xs)
        self.u_scale = np.array(us)
        self.tf_scale = 10.0
        self.nx, self.nu = len(xs), len(us)

        self._build(tol, max_iter, tf_bounds)

    # -- helpers to pack/unpack the flat decision vector ----------------------
    def _split(self, w):
        N, nx, nu = self.N, self.nx, self.nu
        nX = (N + 1) * nx
        X = ca.reshape(w[:nX], nx, N + 1).T if isinstance(w, (ca.SX, ca.MX)) \
            else np.reshape(w[:nX], (N + 1, nx))
        U = ca.reshape(w[nX:nX + N * nu], nu, N).T if isinstance(w, (ca.SX, ca.MX)) \
            else np.reshape(w[nX:nX + N * nu], (N, nu))
        return X, U, w[nX + N * nu]

    def _pack(self, X, U, tf):
        return np.concatenate([np.asarray(X).ravel(), np.asarray(U).ravel(), [tf]])

    def _rhs_sx(self, xk, uk):
        """Scaled-in, physical-out dynamics at one node (SX)."""
        sc = self.sc
        xp = [xk[k] * self.x_scale[k] for k in range(self.nx)]
        T = uk[0] * self.u_scale[0]
        if self.problem == "P1":
            delta = uk[1] * self.u_scale[1]
        else:
            delta = xp[7]
        f = p1_rhs(sc, xp, T, delta, ca.sin, ca.cos, ca.sqrt)
        if self.problem == "P2":
            f.append(uk[1] * self.u_scale[1])   # delta_dot = chi
        return f

    def _build(self, tol, max_iter, tf_bounds):
        sc, N, nx, nu = self.sc, self.N, self.nx, self.nu
        t0 = time.perf_counter()

        nw = (N + 1) * nx + N * nu + 1
        w = ca.SX.sym("w", nw)
        X, U, tf_s = self._split(w)
        tf = tf_s * self.tf_scale

        # Defects, Eq. (24): sum_j D_ij X_j - (tf/2) f(X_i, U_i) = 0, i = 1..N,
        # expressed in scaled state units (each row divided by its state scale).
        # D is block-row: interval k's rows (2/h_k) D^(k) touch only its own
        # n_k + 1 nodes, so DX is built interval by interval from dense local
        # products. The constraint Jacobian then has only those blocks as
        # structural nonzeros (no zero-valued entries from a dense global D).
        DX = ca.vertcat(*[ca.mtimes(ca.DM(Dk), X[start:start + nk + 1, :])
                          for start, nk, _, _, Dk in self.mesh.intervals])  # N x nx
        g = []
        for i in range(N):
            f = self._rhs_sx(X[i, :], U[i, :])
            for k in range(nx):
                g.append(DX[i, k] - 0.5 * tf * f[k] / self.x_scale[k])
        g = ca.vertcat(*g)
        n_defects = self.n_defects = g.shape[0]

        # Operational path constraints (issue 37, sc.constraints): the rows
        # g_c <= 0 of `constraint_rows` at the free state nodes 1..N-1 (the
        # two ends are fixed; check_fixed_ends checks them), node by node,
        # each divided by its state's scale (cone by x's, pitch rate by w's,
        # tilt by theta's, final descent by Vx's) so that it is O(1) like the
        # defects. With no table nothing is added: the paper's NLP, row for row.
        c = sc.constraints
        if c is not None:
            self.row_scale = row_scale = {
                "cone": self.x_scale[0], "pitch_rate": self.x_scale[5],
                "tilt": self.x_scale[4], "final_descent": self.x_scale[2]}
            rows = []
            for i in range(1, N):
                s = [X[i, k] * self.x_scale[k] for k in range(7)]
                rows.extend(gi / row_scale[limit]
                            for limit, gi in constraint_rows(c, sc.xf, s, lib=ca))
            g = ca.vertcat(g, *rows)
        self.n_path_rows = g.shape[0] - n_defects

        # Objective, Eq. (6): maximize m(tf)  ->  minimize -m(tf)/m0 (scaled).
        J = -X[N, 6]

        # Variable bounds (scaled).
        inf = np.inf
        lbX = np.full((N + 1, nx), -inf)
        ubX = np.full((N + 1, nx), inf)
        # Initial state fixed (Eq. 4). For P2 the initial delta too.
        x0_full = list(sc.x0) + ([sc.delta0] if self.problem == "P2" else [])
        lbX[0, :] = ubX[0, :] = np.array(x0_full) / self.x_scale
        # Terminal x, z, Vx, Vz, theta, w fixed (Eq. 4).
        lbX[N, :6] = ubX[N, :6] = sc.xf / self.x_scale[:6]
        # Optional ground bound z >= z_f at every node after the first (as
        # bellyflop imposes; the paper states none).
        if self.ground:
            lbX[1:, 1] = sc.xf[1] / self.x_scale[1]
        # Mass: m >= m_dry at every node (at t_f this is Eq. 4; elsewhere it is
        # implied because m is monotonically decreasing) and m <= m0.
        lbX[1:, 6] = sc.m_dry / self.x_scale[6]
        ubX[1:, 6] = sc.x0[6] / self.x_scale[6]
        if self.problem == "P2":
            lbX[1:, 7] = -sc.delta_max / self.x_scale[7]   # Eq. (5) on the delta state
            ubX[1:, 7] = sc.delta_max / self.x_scale[7]
        lbU = np.empty((N, nu))
        ubU = np.empty((N, nu))
        lbU[:, 0], ubU[:, 0] = sc.T_min / self.u_scale[0], sc.T_max / self.u_scale[0]
        lim = sc.delta_max if self.problem == "P1" else sc.chi_max   # Eq. (5) / (9)
        lbU[:, 1], ubU[:, 1] = -lim / self.u_scale[1], lim / self.u_scale[1]
        self.lbw = self._pack(lbX, lbU, tf_bounds[0] / self.tf_scale)
        self.ubw = self._pack(ubX, ubU, tf_bounds[1] / self.tf_scale)
        # The path rows' upper bound is -BOUND_RELAX, not 0: IPOPT widens
        # every bound by bound_relax_factor * max(1, |bound|) before it
        # starts, so g <= 0 could end at g = +1e-8 (scaled: 1e-6 m for the
        # cone), while g <= -1e-8 widens to g <= 0 exactly.
        self.lbg = np.concatenate([np.zeros(n_defects), np.full(self.n_path_rows, -inf)])
        self.ubg = np.concatenate([np.zeros(n_defects), np.full(self.n_path_rows, -BOUND_RELAX)])

        opts = {
            "print_time": False,
            "ipopt.print_level": 0,
            "ipopt.sb": "yes",            # no IPOPT banner
            "ipopt.tol": tol,
            "ipopt.max_iter": max_iter,
            "ipopt.bound_relax_factor": BOUND_RELAX,   # IPOPT's default, named
        }
        self.solver = ca.nlpsol("lgr", "ipopt", {"x": w, "f": J, "g": g}, opts)
        self.build_time = time.perf_counter() - t0

    # -- initial guess ---------------------------------------------------------
    def initial_guess(self) -> np.ndarray:
        """Straight line between initial and terminal states in tau, mass from
        m0 to final_mass_guess_kg, delta from delta0 to 0, T mid-range, chi 0."""
        sc, N = self.sc, self.N
        s = (self.tau_all + 1.0) / 2.0                   # 0 .. 1 at the N+1 nodes
        a = np.append(sc.x0, sc.delta0)                   # 8 start values
        b = np.append(np.append(sc.xf, sc.mf_guess), 0.0)  # 8 end values
        Xp = a[None, :] + s[:, None] * (b - a)[None, :]
        X = Xp[:, :self.nx] / self.x_scale
        U = np.empty((N, self.nu))
        U[:, 0] = 0.5 * (sc.T_min + sc.T_max) / self.u_scale[0]
        if self.problem == "P1":
            U[:, 1] = Xp[:N, 7] / self.u_scale[1]       # delta: delta0 -> 0
        else:
            U[:, 1] = 0.0                               # chi
        return self._pack(X, U, sc.tf_guess / self.tf_scale)

    # -- solve -----------------------------------------------------------------
    def solve(self, w0: np.ndarray):
        t0 = time.perf_counter()
        sol = self.solver(x0=w0, lbx=self.lbw, ubx=self.ubw, lbg=self.lbg, ubg=self.ubg)
        wall = time.perf_counter() - t0
        stats = self.solver.stats()
        return sol, stats, wall

    def path_sensitivities(self, lam_g) -> dict[str, float]:
        """Each limit's multipliers as a fuel price: the sum over its rows
        (both signs, all free nodes) of m0 lambda / row scale, i.e. dm_f/db,
        the kg of final mass gained per unit (the row's unit) by which every
        one of its rows is loosened. > 0: the limit is active; 0: inactive."""
        c = self.sc.constraints
        if c is None:
            return {}
        lam = np.asarray(lam_g).ravel()[self.n_defects:]
        names = [limit for limit in c.limits() for _ in (1, -1)]   # row order at a node
        lam = lam.reshape(self.N - 1, len(names)) if self.N > 1 else lam.reshape(0, len(names))
        out: dict[str, float] = {}
        for j, limit in enumerate(names):
            out[limit] = out.get(limit, 0.0) + float(np.sum(lam[:, j])) \
                * self.sc.x0[6] / self.row_scale[limit]
        return out

    def unpack_physical(self, wopt: np.ndarray):
        X, U, tf_s = self._split(np.asarray(wopt).ravel())
        return X * self.x_scale, U * self.u_scale, float(tf_s) * self.tf_scale


# --------------------------------------------------------------------------
# Re-integration of the nonlinear dynamics with the optimal controls
# --------------------------------------------------------------------------
def reintegrate(sc: Scenario, problem: str, t_col, U, X, tf, p2_delta="state",
                rtol=1e-10, atol=1e-10):
    """Integrate the nonlinear dynamics from the initial state over [0, tf].

    Controls are interpolated linearly in time between the N collocation
    times t_1 = 0 .. t_N and held at their last value from t_N to tf.

    P1: u = (T, delta) interpolated; Eq. (1) integrated.
    P2, p2_delta == "state" (default): T interpolated as above and delta is the
        optimal delta *state* interpolated linearly over all N+1 nodes
        (including tf); Eq. (1) integrated.
    P2, p2_delta == "chi": u = (T, chi) interpolated and the augmented
        dynamics Eq. (8) are integrated from delta(0) = delta0, i.e. delta is
        the integral of the interpolated chi. The optimal chi is bang-bang
        (it sits on +-chi_max during the flip and the final flare), so its
        linear interpolation integrates to a delta that drifts from the
        collocated delta by ~0.01-0.1 rad; the open-loop pitch dynamics
        amplify this into tens of metres of landing error. That is why
        "state" is the default.

    Integration is done segment by segment between consecutive knots (where
    the interpolated controls have kinks) with DOP853.
    Returns the final state [x, z, Vx, Vz, theta, w, m(, delta)].
    """
    T_k = U[:, 0]
    knots = np.append(t_col, tf)          # t_1 .. t_N, tf
    # Control values on the knots (hold last value on [t_N, tf]).
    T_knots = np.append(T_k, T_k[-1])
    if problem == "P1":
        d_knots = np.append(U[:, 1], U[-1, 1])
        mode = "delta"
    elif p2_delta == "chi":
        d_knots = np.append(U[:, 1], U[-1, 1])  # chi values
        mode = "chi"
    else:
        d_knots = X[:, 7]                       # delta state at all N+1 nodes
        mode = "delta"

    def make_rhs(ta, tb, Ta, Tb, da, db):
        h = tb - ta

        def rhs(t, s):
            a = (t - ta) / h if h > 0 else 0.0
            T = Ta + a * (Tb - Ta)
            d = da + a * (db - da)
            if mode == "delta":
                return p1_rhs(sc, s, T, d, math.sin, math.cos, math.sqrt)
            f = p1_rhs(sc, s, T, s[7], math.sin, math.cos, math.sqrt)
            f.append(d)                          # delta_dot = chi
            return f
        return rhs

    s = list(sc.x0) + ([sc.delta0] if mode == "chi" else [])
    for k in range(len(knots) - 1):
        ta, tb = knots[k], knots[k + 1]
        if tb <= ta:
            continue
        r = solve_ivp(make_rhs(ta, tb, T_knots[k], T_knots[k + 1],
                               d_knots[k], d_knots[k + 1]),
                      (ta, tb), s, method="DOP853", rtol=rtol, atol=atol)
        if not r.success:
            raise RuntimeError(f"re-integration failed: {r.message}")
        s = list(r.y[:, -1])
    return np.array(s)


# --------------------------------------------------------------------------
# CLI
# --------------------------------------------------------------------------
_LIST_FLAGS = ("--breaks-tau", "--points")


def _join_list_flags(argv: list[str]) -> list[str]:
    """Glue the value of --breaks-tau / --points to its flag ("--flag=VALUE").

    argparse takes a separate value such as "-1,-0.2,1" for an option (it only
    recognises plain negative numbers) and then reports a missing argument."""
    out, it = [], iter(argv)
    for a in it:
        nxt = next(it, None) if a in _LIST_FLAGS else None
        out.append(a if nxt is None else f"{a}={nxt}")
    return out


def _number_list(kind):
    """argparse type: a comma-separated list of `kind` values."""
    def parse(text: str) -> list:
        try:
            vals = [kind(v) for v in text.split(",") if v.strip()]
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected comma-separated {kind.__name__}s, got {text!r}") from None
        if not vals:
            raise argparse.ArgumentTypeError(f"empty list {text!r}")
        return vals
    return parse


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenario", required=True, help="scenario TOML file")
    ap.add_argument("--nodes", type=int, default=None,
                    help="number of LGR collocation points N (default: scenario)")
    ap.add_argument("--problem", choices=["P1", "P2"], default="P2")
    ap.add_argument("--intervals", type=int, default=None,
                    help="number of LGR mesh intervals M (hp mesh; N // M >= 2). "
                         "Default: the scenario's discretization.intervals, else 1 "
                         "(the paper's global mesh)")
    ap.add_argument("--breaks-tau", type=_number_list(float), default=None, metavar="B0,..,BM",
                    help="explicit mesh layout: M + 1 strictly increasing interval "
                         "breaks in tau from -1 to 1 (with --points)")
    ap.add_argument("--points", type=_number_list(int), default=None, metavar="N1,..,NM",
                    help="explicit mesh layout: LGR points per interval, each >= 2 "
                         "(with --breaks-tau); N = sum, M = count")
    ap.add_argument("--layout-json", default=None, metavar="FILE",
                    help="explicit mesh layout from the \"mesh_layout\" object of a "
                         "bellyflop `solve --json` output file (or of this script's)")
    ap.add_argument("--repeat", type=int, default=1,
                    help="solve K times from the same guess; report median solve time")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    ap.add_argument("--ground", action="store_true",
                    help="impose z >= z_f at every node after the first (bellyflop's ground bound)")
    ap.add_argument("--no-constraints", action="store_true",
                    help="ignore the scenario's [constraints] table (solve the paper's "
                         "problem from the same file)")
    ap.add_argument("--tol", type=float, default=1e-9, help="IPOPT tol")
    ap.add_argument("--max-iter", type=int, default=3000, help="IPOPT max_iter")
    ap.add_argument("--p2-delta", choices=["state", "chi"], default="state",
                    help="P2 re-integration: interpolate the delta state linearly "
                         "(default) or integrate the linearly interpolated chi")
    args = ap.parse_args(_join_list_flags(sys.argv[1:] if argv is None else list(argv)))

    try:
        sc = load_scenario(args.scenario)
    except ValueError as exc:
        ap.error(str(exc))
    if args.no_constraints:
        sc = dataclasses.replace(sc, constraints=None)
    if sc.constraints is not None:
        try:
            check_fixed_ends(sc, sc.constraints)
        except ValueError as exc:
            ap.error(f"{args.scenario}: [constraints]: {exc}")

    # The mesh: an explicit layout from the command line (--breaks-tau and
    # --points, or --layout-json), else the scenario's [discretization.mesh]
    # unless --nodes / --intervals ask for a different N / M, else the
    # uniform mesh of N over M.
    layout, where = None, None
    if args.layout_json is not None:
        if args.breaks_tau is not None or args.points is not None:
            ap.error("--layout-json cannot be combined with --breaks-tau / --points")
        try:
            with open(args.layout_json) as fh:
                d = parse_layout(fh.read())
        except (OSError, ValueError) as exc:
            ap.error(f"--layout-json {args.layout_json}: {exc}")
        layout, where = (d["breaks_tau"], d["points"]), f"--layout-json {args.layout_json}"
    elif args.breaks_tau is not None or args.points is not None:
        if args.breaks_tau is None or args.points is None:
            ap.error("--breaks-tau and --points must be given together")
        layout, where = (args.breaks_tau, args.points), "--breaks-tau / --points"
    if layout is not None:
        try:
            mesh = LgrMesh.from_layout(*layout)
        except ValueError as exc:
            ap.error(f"{where}: {exc}")
        if args.nodes is not None and args.nodes != mesh.N:
            ap.error(f"--nodes {args.nodes} disagrees with the layout of {where}: "
                     f"N = sum(points) = {mesh.N}")
        if args.intervals is not None and args.intervals != mesh.M:
            ap.error(f"--intervals {args.intervals} disagrees with the layout of {where}: "
                     f"M = len(points) = {mesh.M}")
    elif (sc.mesh_points is not None and args.nodes in (None, sc.nodes)
          and args.intervals in (None, sc.intervals)):
        mesh = sc.mesh()
    else:
        N = args.nodes or sc.nodes
        if N < 2:
            ap.error("--nodes must be >= 2")
        M = args.intervals if args.intervals is not None else sc.intervals
        if M < 1:
            ap.error(f"--intervals must be >= 1 (got {M})")
        if N // M < 2:
            ap.error(f"N = {N} over M = {M} intervals: each interval needs at least "
                     f"2 collocation points, so M <= {N // 2}")
        mesh = LgrMesh(N, M)
    N, M = mesh.N, mesh.M

    nlp = LgrNlp(sc, N, args.problem, tol=args.tol, max_iter=args.max_iter,
                 ground=args.ground, mesh=mesh)
    w0 = nlp.initial_guess()

    walls, sol, stats = [], None, None
    for _ in range(max(1, args.repeat)):
        sol, stats, wall = nlp.solve(w0)
        walls.append(wall)
    wopt = np.asarray(sol["x"]).ravel()
    X, U, tf = nlp.unpack_physical(wopt)
    t_nodes = (nlp.tau_all + 1.0) * tf / 2.0
    defects = np.asarray(sol["g"]).ravel()[:nlp.n_defects]
    max_defect = float(np.max(np.abs(defects))) if defects.size else 0.0

    sf = reintegrate(sc, args.problem, t_nodes[:N], U, X, tf, p2_delta=args.p2_delta)
    pos_err = float(np.hypot(sf[0] - sc.xf[0], sf[1] - sc.xf[1]))
    vel_err = float(np.hypot(sf[2] - sc.xf[2], sf[3] - sc.xf[3]))

    delta = U[:, 1] if args.problem == "P1" else X[:, 7]
    out = {
        "problem": args.problem,
        "nodes": N,
        "intervals": M,
        "interval_points": nlp.mesh.points,
        "mesh_layout": nlp.mesh.layout(),
        "scenario": sc.name,
        "status": stats["return_status"],
        "success": bool(stats["success"]),
        "tf_s": tf,
        "final_mass_kg": float(X[N, 6]),
        "ipopt_iterations": int(stats["iter_count"]),
        "solve_time_ms": 1e3 * float(np.median(walls)),
        "build_time_ms": 1e3 * nlp.build_time,
        "repeat": len(walls),
        "max_scaled_defect": max_defect,
        "landing_error": {
            "position_m": pos_err,
            "velocity_mps": vel_err,
            "theta_rad": float(sf[4] - sc.xf[4]),
            "mass_kg": float(sf[6] - X[N, 6]),
            "p2_delta_mode": args.p2_delta if args.problem == "P2" else None,
        },
        # State arrays have N+1 entries at t_s (the last one is t_f). Controls
        # (thrust_n, and delta_rad for P1, gimbal_rate_radps for P2) have N
        # entries at the collocation times t_s[:N]. For P2 delta_rad is the
        # state (N+1 entries).
        "t_s": t_nodes.tolist(),
        "x_m": X[:, 0].tolist(),
        "z_m": X[:, 1].tolist(),
        "vx_mps": X[:, 2].tolist(),
        "vz_mps": X[:, 3].tolist(),
        "theta_rad": X[:, 4].tolist(),
        "pitch_rate_radps": X[:, 5].tolist(),
        "mass_kg": X[:, 6].tolist(),
        "thrust_n": U[:, 0].tolist(),
        "delta_rad": delta.tolist(),
    }
    if args.problem == "P2":
        out["gimbal_rate_radps"] = U[:, 1].tolist()
    # The [constraints] table as read (null: none, or --no-constraints) and
    # each limit's rows over the nodes (constraint_report).
    c = sc.constraints
    out["constraints"] = None if c is None else c.as_dict()
    out["constraint_rows"] = None if c is None else constraint_report(c, sc.xf, X)
    if c is not None:
        for limit, kg in nlp.path_sensitivities(sol["lam_g"]).items():
            out["constraint_rows"][limit]["dmf_dbound_kg_per_unit"] = kg

    if args.json:
        json.dump(out, sys.stdout)
        sys.stdout.write("\n")
    else:
        mesh = "global mesh" if M == 1 else \
            f"{M} intervals ({'+'.join(str(p) for p in nlp.mesh.points)} points)"
        if M > 1 and not nlp.mesh.uniform:
            mesh += " at breaks_tau " + ",".join(f"{b:.6g}" for b in nlp.mesh.breaks_tau)
        print(f"{args.problem}  N={N}  {mesh}  scenario={sc.name}")
        print(f"  IPOPT: {out['status']} ({out['ipopt_iterations']} iterations), "
              f"max scaled defect {max_defect:.2e}")
        print(f"  t_f = {tf:.4f} s   m(t_f) = {out['final_mass_kg']:.1f} kg")
        print(f"  build {out['build_time_ms']:.1f} ms, solve {out['solve_time_ms']:.1f} ms "
              f"(median of {len(walls)})")
        print(f"  re-integrated landing error: position {pos_err:.4f} m, "
              f"velocity {vel_err:.4f} m/s")
        if c is not None:
            print("  constraints: " + ", ".join(f"{k} = {v:g}" for k, v in c.as_dict().items()))
            for limit, r in out["constraint_rows"].items():
                print(f"    {limit:<13s} max row {r['max_free']:+.3e} {r['unit']} at free "
                      f"node {r['node_free']}, dm_f/dbound {r['dmf_dbound_kg_per_unit']:.4g} "
                      f"kg/({r['unit']})")
        print("  thrust [kN] at collocation points: "
              + " ".join(f"{v / 1e3:.0f}" for v in U[:, 0]))
    return 0 if out["success"] else 1


if __name__ == "__main__":
    sys.exit(main())
