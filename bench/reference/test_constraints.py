"""Tests of the operational path constraints of nlp_reference.py (issue 37):
the `[constraints]` table, its rows, --no-constraints, the JSON report and
the check of the fixed initial and terminal states.

Each solve is the paper's case at N = 20 with one limit set tighter than the
unconstrained answer goes, so that it must be active: the answer meets it at
every node, touches it, and lands with less fuel.

Run with pytest (`python -m pytest bench/reference -q`) or, where pytest is
not installed (the reference's .venv), directly:
`bench/reference/.venv/bin/python bench/reference/test_constraints.py`.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
SCRIPT = HERE / "nlp_reference.py"
PAPER = ROOT / "scenarios" / "paper.toml"
sys.path.insert(0, str(HERE))
import nlp_reference as ref  # noqa: E402

NODES = "20"
HOLD_TOL = 1e-6     # a row holds: value <= this, in its unit (m, rad/s, rad, m/s)
ACTIVE_TOL = 1e-6   # a row is active: its largest value is > -this
# The paper's unconstrained answer at N = 20 (P2) reaches, at the nodes:
# |x - x_f|/(z - z_f) up to tan(18.4 deg) (node 18, a small overshoot just
# above the pad) and tan(11.55 deg) in mid-flight, |w| up to 23.5 deg/s,
# |theta| up to 7.9 deg below 100 m, and |Vx| up to 5.4 m/s at 41 m. Each
# case below is tighter than that (the cone at 11 deg is still wider than
# the initial state's 9.46 deg).
CASES = {
    "cone": "cone_half_angle_deg = 11.0",
    "pitch_rate": "max_pitch_rate_degps = 17.0",
    "tilt": "max_tilt_deg = 5.0\ntilt_below_m = 100.0",
    "final_descent": "final_descent_m = 50.0\nfinal_descent_lateral_mps = 1.0",
}

_cache: dict[tuple, dict] = {}


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args],
                          capture_output=True, text=True, cwd=ROOT)


def _scenario_with(table: str, tmp: str, name: str = "case", text: str | None = None) -> str:
    """The paper's scenario plus a [constraints] table, written to tmp."""
    path = Path(tmp) / f"{name}.toml"
    path.write_text((text or PAPER.read_text()) + f"\n[constraints]\n{table}\n")
    return str(path)


def _solve(table: str | None, problem: str = "P2", *extra: str) -> dict:
    """The JSON of one solve (cached: several tests read the same answer)."""
    key = (table, problem, extra)
    if key not in _cache:
        with tempfile.TemporaryDirectory() as tmp:
            scen = str(PAPER) if table is None else _scenario_with(table, tmp)
            r = _run("--scenario", scen, "--nodes", NODES, "--problem", problem, "--json", *extra)
        assert r.returncode == 0, r.stderr
        _cache[key] = json.loads(r.stdout)
    return _cache[key]


def _rows_from_nodes(out: dict, c: dict) -> dict[str, np.ndarray]:
    """Each limit's larger row (+ or -) at every node, written out here from
    the node arrays of the JSON (independently of nlp_reference's rows)."""
    x, z = np.array(out["x_m"]), np.array(out["z_m"])
    vx, th, w = np.array(out["vx_mps"]), np.array(out["theta_rad"]), np.array(out["pitch_rate_radps"])
    sc = ref.load_scenario(str(PAPER))
    dx, dz = x - sc.xf[0], z - sc.xf[1]

    def sp(u):  # softplus of width 1 m, written directly (|u| stays far below 709 here)
        return np.log1p(np.exp(u))

    rows = {}
    if "cone_half_angle_deg" in c:
        rows["cone"] = np.abs(dx) - math.tan(math.radians(c["cone_half_angle_deg"])) * dz
    if "max_pitch_rate_degps" in c:
        rows["pitch_rate"] = np.abs(w) - math.radians(c["max_pitch_rate_degps"])
    if "max_tilt_deg" in c:
        rows["tilt"] = (np.abs(th) - math.radians(c["max_tilt_deg"])
                        - math.pi / 180.0 * sp(dz - c["tilt_below_m"]))
    if "final_descent_m" in c:
        rows["final_descent"] = (np.abs(vx) - c["final_descent_lateral_mps"]
                                 - sp(dz - c["final_descent_m"]))
    return rows


def _check_active_case(limit: str, problem: str = "P2") -> None:
    free = _solve(None, problem)
    out = _solve(CASES[limit], problem)
    assert out["success"] is True, out["status"]
    c = out["constraints"]
    assert c == ref.parse_constraints(tomllib.loads(CASES[limit])).as_dict()
    rep = out["constraint_rows"]
    assert list(rep) == [limit]
    r = rep[limit]
    mine = _rows_from_nodes(out, c)[limit]
    assert len(mine) == int(NODES) + 1
    np.testing.assert_allclose(r["per_node"], mine, rtol=0, atol=1e-12)
    # Holds at every node (the free ones, where the NLP imposes it, and the
    # two fixed ends).
    assert mine.max() <= HOLD_TOL, (limit, mine.max(), int(mine.argmax()))
    assert r["max"] <= HOLD_TOL and r["max_free"] <= HOLD_TOL
    # Active at a free node, with a positive price, and it costs fuel.
    assert r["max_free"] > -ACTIVE_TOL, (limit, r["max_free"])
    assert r["dmf_dbound_kg_per_unit"] > 1.0, r
    assert out["final_mass_kg"] < free["final_mass_kg"] - 1.0, \
        (out["final_mass_kg"], free["final_mass_kg"])
    # The paper's answer breaks the limit (that is why it is active): by
    # 3.3 m, 0.11 rad/s, 0.051 rad and 4.4 m/s.
    assert _rows_from_nodes(free, c)[limit].max() > 1e-3


def test_cone_is_met_and_active():
    _check_active_case("cone")


def test_pitch_rate_is_met_and_active():
    _check_active_case("pitch_rate")


def test_tilt_is_met_and_active():
    _check_active_case("tilt")


def test_final_descent_is_met_and_active():
    _check_active_case("final_descent")


def test_p1_cone_is_met_and_active():
    _check_active_case("cone", "P1")


def test_without_table_or_with_no_constraints_the_answer_is_the_papers():
    free = _solve(None)
    assert free["constraints"] is None and free["constraint_rows"] is None
    table = "\n".join(CASES.values())
    off = _solve(table, "P2", "--no-constraints")
    assert off["constraints"] is None and off["constraint_rows"] is None
    for key in ("final_mass_kg", "tf_s", "ipopt_iterations", "x_m", "thrust_n"):
        assert off[key] == free[key], key


def test_inactive_limits_cost_nothing():
    # The cone of 30 deg and the tilt of 10 deg below 100 m are wider than
    # the paper's answer: it stays (to IPOPT's tolerance) the same answer.
    free = _solve(None)
    out = _solve("cone_half_angle_deg = 30.0\nmax_tilt_deg = 10.0\ntilt_below_m = 100.0")
    assert out["success"] is True
    assert abs(out["final_mass_kg"] - free["final_mass_kg"]) < 1e-3
    for r in out["constraint_rows"].values():
        assert r["max_free"] < -1e-3 and abs(r["dmf_dbound_kg_per_unit"]) < 0.1, r
    # At t_f the cone's rows are 0 exactly: the pad is its apex.
    assert out["constraint_rows"]["cone"]["per_node"][-1] == 0.0


def test_fixed_states_that_break_a_limit_are_reported():
    with tempfile.TemporaryDirectory() as tmp:
        # The initial state (x = 100 m, z = 600 m) is at 9.46 deg from the pad.
        r = _run("--scenario", _scenario_with("cone_half_angle_deg = 9.0", tmp),
                 "--nodes", NODES, "--json")
        assert r.returncode == 2 and r.stdout == "", (r.returncode, r.stdout)
        assert "the initial state breaks the approach cone: row = +4.96934 m" in r.stderr, r.stderr
        assert "no solve attempted" in r.stderr
        # 90 deg belly-first at 600 m, with the tilt limit in force up to 600 m.
        r = _run("--scenario", _scenario_with("max_tilt_deg = 10.0\ntilt_below_m = 600.0", tmp),
                 "--nodes", NODES)
        assert r.returncode == 2 and "the initial state breaks the tilt limit" in r.stderr, r.stderr
        # A terminal state (fixed too) that breaks a limit.
        text = PAPER.read_text().replace('pitch_rate_degps = 0.0\n\n[discretization]',
                                         'pitch_rate_degps = 5.0\n\n[discretization]')
        assert text != PAPER.read_text()
        r = _run("--scenario", _scenario_with("max_pitch_rate_degps = 4.0", tmp, text=text),
                 "--nodes", NODES)
        assert r.returncode == 2 and "the terminal state breaks the pitch-rate limit" in r.stderr, \
            r.stderr


def test_invalid_tables_are_refused():
    for table, msg in [
        ("cone_half_angle_deg = 0.5", "cone_half_angle_deg = 0.5 is out of range: allowed [1, 89]"),
        ("cone_half_angle_deg = 90", "out of range"),
        ("max_pitch_rate_degps = 0", "allowed (0, 360]"),
        ("max_tilt_deg = 10.0", "max_tilt_deg needs tilt_below_m"),
        ("final_descent_lateral_mps = 1.0", "final_descent_lateral_mps needs final_descent_m"),
        ("final_descent_m = 30.0\nfinal_descent_lateral_mps = 101.0", "out of range"),
        ("max_tilt_deg = -1.0\ntilt_below_m = 10.0", "out of range"),
        ('cone_half_angle_deg = "30"', "must be a number"),
        ("cone_deg = 30.0", "unknown field(s) cone_deg"),
    ]:
        with tempfile.TemporaryDirectory() as tmp:
            path = _scenario_with(table, tmp)
            try:
                ref.load_scenario(path)
            except ValueError as exc:
                assert "[constraints]" in str(exc) and msg in str(exc), (table, str(exc))
            else:
                raise AssertionError(f"{table!r} was accepted")
            if table.startswith(("cone_half_angle_deg = 0.5", "cone_deg")):
                # The CLI refuses the file too, even with --no-constraints.
                r = _run("--scenario", path, "--no-constraints")
                assert r.returncode == 2 and msg in r.stderr, (table, r.stderr)
    assert ref.parse_constraints({}) is None and ref.parse_constraints(None) is None


def test_softplus_is_the_smooth_max_and_never_overflows():
    import casadi as ca
    u = np.array([-800.0, -40.0, -1.0, 0.0, 1.0, 40.0, 700.0, 800.0, 5000.0])
    sp = ref.softplus(u)
    assert np.all(np.isfinite(sp))
    np.testing.assert_allclose(sp[2:7], np.log1p(np.exp(u[2:7])), rtol=1e-15, atol=1e-300)
    assert sp[-1] == 5000.0 and sp[0] == 0.0
    assert np.all(sp >= np.maximum(u, 0.0)) and np.all(sp - np.maximum(u, 0.0) <= math.log(2) + 1e-15)
    # CasADi: the derivative is the logistic function, sp'(0) = 1/2, and finite far above.
    s = ca.SX.sym("u")
    f = ca.Function("f", [s], [ca.gradient(ref.softplus(s, lib=ca), s)])
    for v in (-50.0, -1.0, 0.0, 1.0, 50.0, 800.0):
        assert abs(float(f(v)) - 1.0 / (1.0 + math.exp(-v))) < 1e-15, v


if __name__ == "__main__":
    tests = [(k, v) for k, v in sorted(globals().items()) if k.startswith("test_") and callable(v)]
    failed = 0
    for name, fn in tests:
        try:
            fn()
            print(f"PASS {name}")
        except Exception as exc:  # noqa: BLE001 - report every failure
            failed += 1
            print(f"FAIL {name}: {type(exc).__name__}: {exc}")
    print(f"{len(tests) - failed} passed, {failed} failed")
    sys.exit(1 if failed else 0)
