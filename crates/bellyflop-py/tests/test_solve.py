"""solve(): the paper's Table 3, the CLI's --json bit for bit, statuses,
the GIL, pickling."""

from __future__ import annotations

import pickle
import struct
import threading

import numpy as np
import pytest

import bellyflop
from conftest import cli_json, without_timing

# Table 3 (the paper's SCvx row) and the tolerances of
# crates/bellyflop/tests/optimizer.rs (0.3 % on t_f, 25 kg on m_f).
PAPER_TF_S = 11.5666
PAPER_MF_KG = 114_568.6
# The CasADi + IPOPT reference on the same mesh (crates/bellyflop/tests/direct.rs:
# 0.1 kg, 1 ms).
IPOPT_N20_MF_KG = 114_569.455
IPOPT_N20_TF_S = 11.56895
# IPOPT on 20 intervals x 8 points (docs/validation.md, issue 25).
IPOPT_FINE_MF_KG = 114_576.30
# crates/bellyflop/tests/landing_precision.rs
MAX_POSITION_M = 2.0
MAX_VELOCITY_MPS = 0.5

NODE_ARRAYS = [
    "t_s", "x_m", "z_m", "vx_mps", "vz_mps", "theta_rad", "pitch_rate_radps",
    "mass_kg", "delta_rad", "thrust_n", "gimbal_rate_radps",
]


@pytest.fixture(scope="module")
def paper():
    return bellyflop.solve()


@pytest.mark.parametrize("method", ["direct", "scvx"])
def test_table3(method):
    sol = bellyflop.solve(method=method)
    assert sol.status == "solved", sol.message
    assert sol.method == method
    assert abs(sol.tf_s - PAPER_TF_S) / PAPER_TF_S <= 0.003, sol.tf_s
    assert abs(sol.final_mass_kg - PAPER_MF_KG) <= 25.0, sol.final_mass_kg
    e = sol.landing_error
    assert e["position_m"] <= MAX_POSITION_M and e["velocity_mps"] <= MAX_VELOCITY_MPS, e


def test_raw_direct_matches_ipopt_on_the_same_mesh():
    # fast=True keeps the raw N = 20 collocation answer: the same
    # transcription as the reference, so the same optimum.
    raw = bellyflop.solve(fast=True)
    assert abs(raw.final_mass_kg - IPOPT_N20_MF_KG) < 0.1
    assert abs(raw.tf_s - IPOPT_N20_TF_S) < 1e-3
    assert raw.iterations > 0 and raw.solve_time_ms > 0
    # It misses the pad by 0.8 m: beyond the default 0.1 m, so not solved.
    assert raw.status == "inaccurate" and "polish" in raw.message, raw.message


def test_polished_default_matches_the_fine_mesh_optimum(paper):
    # The default answer flies (polished controls): its fuel is the
    # continuous problem's, which IPOPT approaches on 20 intervals x 8
    # points (docs/validation.md, "The accurate answer by default").
    assert paper.status == "solved", paper.message
    assert abs(paper.final_mass_kg - IPOPT_FINE_MF_KG) < 0.5, paper.final_mass_kg
    e = paper.landing_error
    assert e["position_m"] <= 0.1 and e["velocity_mps"] <= 0.05, e


def test_arrays_are_float64_numpy(paper):
    for name in NODE_ARRAYS:
        a = getattr(paper, name)
        assert isinstance(a, np.ndarray) and a.dtype == np.float64, name
        assert a.shape == (paper.nodes + 1,), name
    assert paper.t_s[0] == 0.0 and paper.t_s[-1] == paper.tf_s


def _bits(a) -> list:
    return [struct.pack("<d", float(x)) for x in a]


@pytest.mark.parametrize(
    "kwargs,args",
    [
        ({}, []),
        ({"nodes": 30}, ["--nodes", "30"]),
        ({"method": "scvx"}, ["--method", "scvx"]),
        ({"nodes": 20, "intervals": 4}, ["--nodes", "20", "--intervals", "4"]),
        ({"mesh_tolerance": 1e-6}, ["--mesh-tolerance", "1e-6"]),
    ],
)
def test_equals_cli_json(cli, kwargs, args):
    sol = bellyflop.solve(**kwargs)
    # Any status: N = 20 on 4 intervals is `inaccurate` (exit 9).
    ref = cli_json(cli, "solve", "--json", *args, check_codes=(0, 3, 4, 5, 6, 9))
    assert sol.status == ref["status"]
    for name in NODE_ARRAYS:
        assert _bits(getattr(sol, name)) == _bits(ref[name]), name
    assert without_timing(sol.to_dict()) == without_timing(ref)
    assert sol.to_dict().keys() == ref.keys()


def test_scenario_attributes_and_toml():
    s = bellyflop.Scenario.paper()
    assert s.initial.mass_kg == 120_000.0
    assert s.discretization.nodes == 20
    assert s.solver.direct.tolerance == 1e-8
    assert set(s.to_dict()) >= {"vehicle", "environment", "initial", "terminal"}
    again = bellyflop.Scenario.from_toml_text(s.to_toml())
    assert again == s
    assert bellyflop.Scenario.from_dict(s.to_dict()) == s
    with pytest.raises(AttributeError):
        s.initial.no_such_field


def test_from_toml_path(tmp_path):
    p = tmp_path / "case.toml"
    p.write_text(bellyflop.Scenario.paper().to_toml())
    assert bellyflop.Scenario.from_toml(p) == bellyflop.Scenario.paper()
    assert bellyflop.Scenario.from_toml(str(p)) == bellyflop.Scenario.paper()
    assert bellyflop.solve(p).final_mass_kg == bellyflop.solve().final_mass_kg


def _paper_toml_with(key: str, value: str) -> str:
    lines = bellyflop.Scenario.paper().to_toml().splitlines()
    section, name = key.split(".")
    out, current = [], None
    for line in lines:
        if line.startswith("["):
            current = line.strip("[] ")
        if current == section and line.split("=")[0].strip() == name:
            line = f"{name} = {value}"
        out.append(line)
    return "\n".join(out) + "\n"


def test_negative_mass_names_the_field(tmp_path):
    text = _paper_toml_with("initial.mass_kg", "-5")
    with pytest.raises(bellyflop.InputError, match=r"initial\.mass_kg = -5 is out of range: allowed"):
        bellyflop.Scenario.from_toml_text(text)
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(bellyflop.InputError, match=r"initial\.mass_kg"):
        bellyflop.solve(p)
    assert issubclass(bellyflop.InputError, ValueError)


def test_two_nodes_is_bad_input():
    # The argument named as given (`nodes`), the range from the range table.
    with pytest.raises(bellyflop.InputError, match=r"nodes = 2 is out of range: allowed 4 to 200"):
        bellyflop.solve(nodes=2)


def test_nan_in_dict_is_bad_input():
    d = bellyflop.Scenario.paper().to_dict()
    d["initial"]["vz_mps"] = float("nan")
    with pytest.raises(bellyflop.InputError, match=r"initial\.vz_mps = NaN is out of range"):
        bellyflop.Scenario.from_dict(d)


def test_other_bad_input():
    d = bellyflop.Scenario.paper().to_dict()
    d["initial"]["speed_of_light"] = 1.0
    with pytest.raises(bellyflop.InputError, match="speed_of_light"):
        bellyflop.Scenario.from_dict(d)
    with pytest.raises(bellyflop.InputError, match="method"):
        bellyflop.solve(method="newton")
    with pytest.raises(bellyflop.InputError, match="TOML, line"):
        bellyflop.Scenario.from_toml_text("this is = = not toml")
    with pytest.raises(bellyflop.InputError, match="cannot read"):
        bellyflop.Scenario.from_toml("/no/such/file.toml")


def test_guesses_are_optional_and_clamped_with_a_warning():
    # Issue 29: left out, the guesses are derived from the state; given
    # outside [m_dry, m0], the final mass is clamped into it with a warning.
    assert bellyflop.Scenario.paper().warnings == []
    d = bellyflop.Scenario.paper().to_dict()
    d["initial"]["mass_kg"] = 105_000.0
    clamped = bellyflop.Scenario.from_dict(d)
    assert clamped.discretization.final_mass_guess_kg == 105_000.0
    assert len(clamped.warnings) == 1
    assert "final_mass_guess_kg = 110000" in clamped.warnings[0]
    del d["discretization"]["tf_guess_s"], d["discretization"]["final_mass_guess_kg"]
    derived = bellyflop.Scenario.from_dict(d)
    assert derived.warnings == []
    assert 85_000.0 < derived.discretization.final_mass_guess_kg < 105_000.0
    assert 5.0 < derived.discretization.tf_guess_s < 20.0
    d["discretization"]["final_mass_guess_kg"] = -1.0
    with pytest.raises(bellyflop.InputError, match=r"discretization\.final_mass_guess_kg = -1"):
        bellyflop.Scenario.from_dict(d)


def test_to_dict_carries_the_cli_warnings(cli, paper, tmp_path):
    # The paper's file at 105 t: its 110 t final-mass guess is clamped with
    # a warning, which to_dict() carries as `solve --json` does (same key,
    # same content); without one, neither has the key.
    p = tmp_path / "clamped.toml"
    p.write_text(_paper_toml_with("initial.mass_kg", "105000.0"))
    sol = bellyflop.solve(p)
    ref = cli_json(cli, "solve", "--json", "--scenario", str(p), check_codes=(0, 9))
    warnings = sol.to_dict()["warnings"]
    assert warnings == ref["warnings"] == bellyflop.Scenario.from_toml(p).warnings
    assert len(warnings) == 1 and "final_mass_guess_kg = 110000" in warnings[0], warnings
    assert sol.warnings == warnings
    assert without_timing(sol.to_dict()) == without_timing(ref)
    assert "warnings" not in paper.to_dict()  # test_equals_cli_json: nor the CLI's


def test_certified_infeasible_is_a_status(cli, tmp_path):
    # From 100 m the descent cannot be stopped (README): a status, no exception.
    d = bellyflop.Scenario.paper().to_dict()
    d["initial"]["z_m"] = 100.0
    sol = bellyflop.solve(d)
    assert sol.status == "infeasible"
    assert sol.message
    p = tmp_path / "low.toml"
    p.write_text(bellyflop.Scenario.from_dict(d).to_toml())
    ref = cli_json(cli, "solve", "--json", "--scenario", str(p), check_codes=(3,))
    assert without_timing(sol.to_dict()) == without_timing(ref)


def test_constraints_from_a_dict_are_held_and_equal_the_cli(cli, tmp_path):
    # Issue 37: the scenario's [constraints] table, as the CLI reads it.
    d = bellyflop.Scenario.paper().to_dict()
    d["constraints"] = {"max_pitch_rate_degps": 17.0}
    s = bellyflop.Scenario.from_dict(d)
    assert s.constraints.max_pitch_rate_degps == 17.0
    sol = bellyflop.solve(s)
    assert sol.status == "solved", sol.message
    (limit,) = sol.to_dict()["path"]["limits"]
    assert limit["limit"] == "pitch_rate"
    assert -1e-2 * limit["scale"] <= limit["worst"] <= 1e-3 * limit["scale"]
    assert sol.final_mass_kg < bellyflop.solve().final_mass_kg - 1.0
    p = tmp_path / "rate.toml"
    p.write_text(s.to_toml())
    ref = cli_json(cli, "solve", "--json", "--scenario", str(p))
    assert without_timing(sol.to_dict()) == without_timing(ref)
    d["constraints"] = {"cone_half_angle_deg": 0.5}
    with pytest.raises(bellyflop.InputError, match=r"constraints\.cone_half_angle_deg = 0\.5 is out of range"):
        bellyflop.Scenario.from_dict(d)


def test_pickle_round_trip(paper):
    again = pickle.loads(pickle.dumps(paper))
    assert again.to_dict() == paper.to_dict()
    for name in NODE_ARRAYS:
        assert _bits(getattr(again, name)) == _bits(getattr(paper, name))
    s = bellyflop.Scenario.paper()
    assert pickle.loads(pickle.dumps(s)) == s
    c = bellyflop.SimConfig()
    assert pickle.loads(pickle.dumps(c)) == c


def test_solve_releases_the_gil():
    # A counting loop in this thread keeps running while another thread
    # solves: its longest stall stays far below the solve's own time. With the
    # GIL held through the solve, the loop would stall for all of it.
    import time

    box = {}

    def work():
        box["sol"] = bellyflop.solve(nodes=60)

    t = threading.Thread(target=work)
    t.start()
    last = time.perf_counter()
    gap = 0.0
    while t.is_alive():
        now = time.perf_counter()
        gap = max(gap, now - last)
        last = now
    t.join()
    core_s = box["sol"]._core_ms / 1e3
    assert core_s > 0.02, core_s
    assert gap < 0.5 * core_s, (gap, core_s)


def test_a_panic_is_an_exception():
    with pytest.raises(bellyflop.InternalError, match="a test asked for a panic"):
        bellyflop._bellyflop._panic_for_tests()
    assert bellyflop.solve().status == "solved"
