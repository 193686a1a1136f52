"""Tests of the explicit mesh layouts of nlp_reference.py (`LgrMesh.from_layout`,
`[discretization.mesh]`, --breaks-tau / --points / --layout-json).

Run with pytest (`python -m pytest bench/reference -q`) or, where pytest is
not installed, directly: `python bench/reference/test_mesh_layout.py`.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
SCRIPT = HERE / "nlp_reference.py"
PAPER = ROOT / "scenarios" / "paper.toml"
sys.path.insert(0, str(HERE))
import nlp_reference as ref  # noqa: E402

UNIFORM_CASES = [(20, 1), (10, 1), (16, 2), (19, 3), (17, 4), (40, 5), (160, 20)]


def _raises(fn, *args, match: str) -> None:
    """Assert that fn(*args) raises ValueError whose message contains match."""
    try:
        fn(*args)
    except ValueError as exc:
        assert match in str(exc), f"{match!r} not in {str(exc)!r}"
        return
    raise AssertionError(f"no ValueError from {fn.__name__}{args}")


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(SCRIPT), *args],
                          capture_output=True, text=True, cwd=ROOT)


def test_uniform_layout_equals_uniform_mesh():
    for N, M in UNIFORM_CASES:
        uni = ref.LgrMesh(N, M)
        breaks = [-1.0 + 2.0 * k / M for k in range(M)] + [1.0]
        lay = ref.LgrMesh.from_layout(breaks, uni.points)
        assert (lay.N, lay.M, lay.points) == (uni.N, uni.M, uni.points)
        np.testing.assert_allclose(lay.nodes, uni.nodes, rtol=0, atol=1e-14)
        np.testing.assert_allclose(lay.weights, uni.weights, rtol=0, atol=1e-14)
        np.testing.assert_allclose(lay.global_matrix(), uni.global_matrix(), rtol=0, atol=1e-14)
        for a, b in zip(lay.intervals, uni.intervals):
            assert a[:2] == b[:2]
            assert abs(a[2] - b[2]) <= 1e-14 and abs(a[3] - b[3]) <= 1e-14
            np.testing.assert_allclose(a[4], b[4], rtol=0, atol=1e-14)
        assert lay.layout() == {"breaks_tau": breaks, "points": uni.points}


def test_global_mesh_is_the_lgr_rule():
    for N in (5, 12, 20):
        mesh = ref.LgrMesh.from_layout([-1.0, 1.0], [N])
        t = ref.lgr_points(N)
        np.testing.assert_array_equal(mesh.nodes, np.append(t, 1.0))
        np.testing.assert_array_equal(mesh.weights, ref.lgr_weights(N))
        assert abs(mesh.weights.sum() - 2.0) < 1e-13


def test_nonuniform_layout_differentiates_polynomials_exactly():
    breaks, points = [-1.0, -0.7, -0.05, 0.4, 1.0], [3, 8, 5, 2]
    mesh = ref.LgrMesh.from_layout(breaks, points)
    assert mesh.N == sum(points) and mesh.M == len(points)
    assert mesh.breaks_tau == breaks and mesh.points == points
    D = mesh.global_matrix()
    for k, (start, nk, lo, hi, _) in enumerate(mesh.intervals):
        assert (lo, hi) == (breaks[k], breaks[k + 1])
        tk = mesh.nodes[start:start + nk + 1]       # the interval's n_k + 1 nodes
        assert abs(tk[0] - lo) < 1e-15 and abs(tk[-1] - hi) < 1e-15
        rows = D[start:start + nk]
        mid = 0.5 * (lo + hi)
        for deg in range(nk + 1):                   # degree <= n_k is exact
            p = np.zeros(mesh.N + 1)
            p[start:start + nk + 1] = (tk - mid) ** deg
            exact = deg * (tk[:nk] - mid) ** (deg - 1) if deg else np.zeros(nk)
            np.testing.assert_allclose(rows @ p, exact, rtol=0, atol=1e-10,
                                       err_msg=f"interval {k}, degree {deg}")
    # Quadrature: the weights integrate degree <= 2 n_k - 2 exactly per interval.
    for start, nk, lo, hi, _ in mesh.intervals:
        w, t = mesh.weights[start:start + nk], mesh.nodes[start:start + nk]
        deg = 2 * nk - 2
        assert abs(w @ t ** deg - (hi ** (deg + 1) - lo ** (deg + 1)) / (deg + 1)) < 1e-13


def test_invalid_layouts_are_refused():
    f = ref.LgrMesh.from_layout
    _raises(f, [-1.0, 0.0, 1.0], [8], match="len(points) + 1")
    _raises(f, [-1.0, 0.5, 0.2, 1.0], [4, 4, 4], match="strictly increasing")
    _raises(f, [-1.0, 0.0, 0.0, 1.0], [4, 4, 4], match="strictly increasing")
    _raises(f, [-0.9, 1.0], [8], match="from -1 to 1")
    _raises(f, [-1.0, 0.9], [8], match="from -1 to 1")
    _raises(f, [-1.0, 0.0, 1.0], [8, 1], match="at least 2")
    _raises(f, [-1.0, 0.0, 1.0], [8, 2.5], match="integers")
    _raises(f, [-1.0, 1.0], [], match="at least one interval")


def test_scenario_mesh_table_overrides_nodes_and_intervals():
    text = PAPER.read_text().replace(
        "[solver]", "[discretization.mesh]\nbreaks_tau = [-1.0, -0.3, 0.1, 1.0]\n"
                    "points = [5, 8, 6]\n\n[solver]", 1)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "mesh.toml"
        path.write_text(text)
        sc = ref.load_scenario(str(path))
        assert (sc.nodes, sc.intervals) == (19, 3)
        assert sc.mesh().layout() == {"breaks_tau": [-1.0, -0.3, 0.1, 1.0], "points": [5, 8, 6]}
        path.write_text(text.replace("points = [5, 8, 6]", "points = [5, 8]"))
        _raises(ref.load_scenario, str(path), match="[discretization.mesh]")
    sc = ref.load_scenario(str(PAPER))
    assert sc.mesh_points is None and sc.mesh().layout()["points"] == [sc.nodes]


def test_cli_refuses_inconsistent_layouts():
    base = ["--scenario", str(PAPER)]
    for extra, msg in [
        (["--breaks-tau", "-1,0,1", "--points", "8"], "len(points) + 1"),
        (["--breaks-tau", "-1,0.5,0.2,1", "--points", "4,4,4"], "strictly increasing"),
        (["--breaks-tau", "-1,0,1", "--points", "8,1"], "at least 2"),
        (["--breaks-tau", "-1,0,1"], "must be given together"),
        (["--breaks-tau", "-1,0,1", "--points", "8,8", "--nodes", "20"], "--nodes 20 disagrees"),
        (["--breaks-tau", "-1,0,1", "--points", "8,8", "--intervals", "3"], "--intervals 3 disagrees"),
        (["--layout-json", str(PAPER)], "not JSON"),
    ]:
        r = _run(*base, *extra)
        assert r.returncode == 2 and msg in r.stderr, (extra, r.stderr)


def test_end_to_end_explicit_layout():
    args = ["--scenario", str(PAPER), "--breaks-tau", "-1,-0.2,1", "--points", "8,8",
            "--problem", "P2", "--ground", "--json"]
    r = _run(*args)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["success"] is True and out["status"] == "Solve_Succeeded"
    assert out["mesh_layout"] == {"breaks_tau": [-1.0, -0.2, 1.0], "points": [8, 8]}
    assert (out["nodes"], out["intervals"], out["interval_points"]) == (16, 2, [8, 8])
    assert len(out["t_s"]) == 17 and len(out["thrust_n"]) == 16
    # The same layout read back from a solve --json output (--layout-json).
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "solve.json"
        path.write_text(json.dumps({"status": "converged", "mesh_layout": out["mesh_layout"]}))
        r2 = _run("--scenario", str(PAPER), "--layout-json", str(path),
                  "--problem", "P2", "--ground", "--json")
    assert r2.returncode == 0, r2.stderr
    out2 = json.loads(r2.stdout)
    assert out2["mesh_layout"] == out["mesh_layout"]
    assert abs(out2["final_mass_kg"] - out["final_mass_kg"]) < 1e-6


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
