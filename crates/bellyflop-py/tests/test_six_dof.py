"""solve() on a 6-DoF scenario (model = "6dof"): the 6-DoF pipeline's
answer, the CLI's --json bit for bit, the node tables as named numpy
arrays, the arguments that do not apply refused by name, pickling."""

from __future__ import annotations

import pickle
import struct

import numpy as np
import pytest

import bellyflop
from conftest import cli_json, run_cli, without_timing

#: The model's field tables (crates/bellyflop/src/problem/model.rs), the
#: columns of trajectory.csv after t_s.
STATES = [
    "x_m", "y_m", "z_m", "vx_mps", "vy_mps", "vz_mps", "q0", "q1", "q2", "q3",
    "wx_radps", "wy_radps", "wz_radps", "mass_kg", "delta1_rad", "delta2_rad",
]
CONTROLS = ["thrust_n", "gimbal_rate1_radps", "gimbal_rate2_radps"]
# test_solve.py's references: Table 3's t_f, IPOPT's fine-mesh final mass.
PAPER_TF_S = 11.5666
IPOPT_FINE_MF_KG = 114_576.30


def _bits(a) -> list:
    return [struct.pack("<d", float(x)) for x in a]


@pytest.fixture(scope="module")
def six_file(cli, tmp_path_factory):
    """The 6-DoF paper case as `bellyflop init --model 6dof` writes it."""
    path = tmp_path_factory.mktemp("six") / "six.toml"
    run_cli(cli, "init", "--force", "--model", "6dof", str(path))
    return path


@pytest.fixture(scope="module")
def six(six_file):
    return bellyflop.solve(six_file)


def test_six_dof_paper_case_solves(six):
    assert isinstance(six, bellyflop.SixDofSolution)
    assert six.model == "6dof"
    assert six.status == "solved", six.message
    assert six.message == ""
    # The planar paper case in the 6-DoF model (an exact special case): its
    # controls, flown, cannot save fuel beyond the planar problem's optimum
    # (IPOPT on 20 intervals x 8 points, test_solve.py, within its 0.5 kg).
    assert 114_500.0 < six.final_mass_kg <= IPOPT_FINE_MF_KG + 0.5, six.final_mass_kg
    assert abs(six.tf_s - PAPER_TF_S) / PAPER_TF_S <= 0.003, six.tf_s
    assert six.fuel_kg == pytest.approx(120_000.0 - six.final_mass_kg, abs=1e-6)
    assert six.iterations > 0 and six.polish_iterations > 0
    # The polished controls, flown, land within the scenario's tolerances.
    assert six.controls_flown is not None
    flown = six.flown
    assert flown["landing_miss_m"] <= 0.1 and flown["landing_miss_mps"] <= 0.05, flown
    assert flown["lowest_altitude_m"] >= -1e-3, flown


def test_six_dof_arrays_match_the_json(six):
    d = six.to_dict()
    n = six.nodes
    assert isinstance(six.t_s, np.ndarray) and six.t_s.dtype == np.float64
    assert _bits(six.t_s) == _bits(d["t_s"]) and six.t_s.shape == (n + 1,)
    assert six.t_s[0] == 0.0 and six.t_s[-1] == six.tf_s
    assert list(six.states) == STATES == d["states"]["names"]
    assert list(six.controls) == CONTROLS == d["controls"]["names"]
    for k, name in enumerate(STATES):
        a = six.states[name]
        assert a.dtype == np.float64 and a.shape == (n + 1,), name
        assert _bits(a) == _bits(row[k] for row in d["states"]["rows"]), name
        assert _bits(getattr(six, name)) == _bits(a), name
    for k, name in enumerate(CONTROLS):
        a = six.controls[name]
        assert a.dtype == np.float64 and a.shape == (n,), name
        assert _bits(a) == _bits(row[k] for row in d["controls"]["rows"]), name
        assert _bits(getattr(six, name)) == _bits(a), name
    assert six.units["z_m"] == "m" and six.units["thrust_n"] == "N"
    # The paper case is planar: nothing leaves the x–z plane (but rounding).
    assert six.y_m[0] == 0.0 and np.abs(six.y_m).max() < 1e-6
    assert np.abs(six.delta2_rad).max() < 1e-6 and np.abs(six.vy_mps).max() < 1e-6
    assert six.mass_kg[-1] == six.final_mass_kg
    with pytest.raises(AttributeError, match='no field "theta_rad"'):
        six.theta_rad


def test_six_dof_equals_cli_json(cli, six, six_file):
    ref = cli_json(cli, "solve", "--json", "--scenario", str(six_file))
    assert without_timing(six.to_dict()) == without_timing(ref)
    assert six.to_dict().keys() == ref.keys()
    fast = bellyflop.solve(six_file, nodes=16, fast=True)
    ref = cli_json(
        cli, "solve", "--json", "--scenario", str(six_file), "--nodes", "16", "--fast",
        check_codes=(0, 9),
    )
    assert without_timing(fast.to_dict()) == without_timing(ref)
    assert fast.nodes == 16 and fast.polish_iterations is None and fast.controls_flown is None
    # The raw answer is checked as flown too: it misses the pad (N = 16).
    assert fast.status == "inaccurate" and "raw collocation controls" in fast.message
    assert fast.flown["landing_miss_m"] > 0.1


def test_six_dof_out_of_plane_state(six_file):
    s = bellyflop.Scenario.from_toml(six_file).to_dict()
    s["initial"].update(y_m=-35.0, vy_mps=6.5, yaw_deg=30.0)
    sol = bellyflop.solve(s)
    assert isinstance(sol, bellyflop.SixDofSolution)
    assert sol.y_m[0] == -35.0 and sol.vy_mps[0] == 6.5
    # It lands on the pad (y = 0), solved or not: the tables are the answer's.
    assert sol.status in ("solved", "inaccurate"), sol.message
    assert abs(sol.y_m[-1]) < 0.1, sol.y_m[-1]


@pytest.mark.parametrize(
    "kwargs,field",
    [
        ({"method": "scvx"}, "method"),
        ({"formulation": "exact"}, "formulation"),
        ({"interpolation": "linear"}, "interpolation"),
        ({"mesh_tolerance": 1e-6}, "mesh_tolerance"),
    ],
)
def test_six_dof_refuses_planar_only_arguments(cli, six_file, kwargs, field):
    with pytest.raises(bellyflop.InputError, match=rf"^{field} = .* does not apply to a 6-DoF scenario") as e:
        bellyflop.solve(six_file, **kwargs)
    # The CLI's flag gives the same reason (its own hint in the last
    # parentheses: `leave it out` for `leave it None`).
    ((name, value),) = kwargs.items()
    flag = "--" + name.replace("_", "-")
    err = run_cli(cli, "solve", "--scenario", str(six_file), flag, str(value), check_codes=(2,)).stderr
    reason = str(e.value).split(": ", 1)[1].rsplit(" (", 1)[0]
    assert err.startswith(f"error: {flag} ") and reason in err, (err, reason)


def test_six_dof_arguments_that_apply(six_file):
    # method="direct" and mesh_tolerance=0 are what the 6-DoF solve does:
    # they override a file's other method and tolerance, as the CLI's flags.
    s = bellyflop.Scenario.from_toml(six_file).to_dict()
    s["solver"]["method"] = "scvx"
    s["solver"]["refinement"]["tolerance"] = 1e-4
    sol = bellyflop.solve(s, method="direct", mesh_tolerance=0.0, nodes=12, fast=True)
    assert sol.nodes == 12 and sol.states["z_m"].shape == (13,)
    with pytest.raises(bellyflop.InputError, match=r"^solver\.method = \"scvx\" does not apply"):
        bellyflop.solve(s)


@pytest.mark.parametrize(
    "path,value,named",
    [
        (["formulation"], "vector", r'solver\.formulation = "vector"'),
        (["refinement", "tolerance"], 1e-4, r"solver\.refinement\.tolerance = 0\.0001"),
        (["polish_repairs"], 0, r"solver\.polish_repairs = 0"),
        (["max_iterations"], 50, r"solver\.max_iterations = 50"),
    ],
)
def test_six_dof_refuses_file_settings_it_would_ignore(cli, tmp_path, six_file, path, value, named):
    # A [solver] setting that the 6-DoF solve does not read, at a value
    # other than its default: refused by name, with the CLI's message.
    s = bellyflop.Scenario.from_toml(six_file).to_dict()
    table = s["solver"]
    for key in path[:-1]:
        table = table[key]
    table[path[-1]] = value
    with pytest.raises(bellyflop.InputError, match=rf"^{named} does not apply to a 6-DoF scenario") as e:
        bellyflop.solve(s)
    p = tmp_path / "six.toml"
    p.write_text(bellyflop.Scenario.from_dict(s).to_toml())
    err = run_cli(cli, "solve", "--scenario", str(p), check_codes=(2,)).stderr
    assert err == f"error: {e.value}\n"


def test_six_dof_pickle_round_trip(six):
    again = pickle.loads(pickle.dumps(six))
    assert isinstance(again, bellyflop.SixDofSolution)
    assert again == six and again.to_dict() == six.to_dict()
    for name in STATES:
        assert _bits(again.states[name]) == _bits(six.states[name])
    assert _bits(again.t_s) == _bits(six.t_s)


def test_six_dof_leaves_the_planar_solve_a_solution():
    sol = bellyflop.solve(fast=True)
    assert isinstance(sol, bellyflop.Solution) and not isinstance(sol, bellyflop.SixDofSolution)
