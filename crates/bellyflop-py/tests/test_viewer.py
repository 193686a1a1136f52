"""Solution and Flight show the CLI's viewer: `save_html` writes the page
`bellyflop solve --out` / `sim --out` write as viewer.html, and
`_repr_html_` holds the same page in an iframe for Jupyter."""

from __future__ import annotations

import html
import json
import pickle

import pytest

import bellyflop
from conftest import run_cli

OPEN = '<script id="bellyflop-data" type="application/json">'


def page_data(page: str) -> dict:
    start = page.index(OPEN) + len(OPEN)
    return json.loads(page[start:page.index("</script>", start)])


def test_solution_page_is_the_cli_page(cli, tmp_path):
    s = bellyflop.solve(bellyflop.Scenario.paper())
    s.save_html(tmp_path / "py.html")
    mine = page_data((tmp_path / "py.html").read_text())
    run_cli(cli, "solve", "--quiet", "--out", str(tmp_path / "cli"))
    theirs = page_data((tmp_path / "cli" / "viewer.html").read_text())
    assert mine["kind"] == theirs["kind"] == "solve"
    # The same drawing: the plan's samples, the flown trajectory, the scenario.
    assert mine["plan"]["dense"] == theirs["plan"]["dense"]
    assert mine["flown"] == theirs["flown"]
    assert mine["scenario"] == theirs["scenario"]
    assert mine["plan"]["solution"]["final_mass_kg"] == s.final_mass_kg


def test_repr_html_is_the_saved_page_in_an_iframe(tmp_path):
    s = bellyflop.solve(bellyflop.Scenario.paper(), nodes=12)
    s.save_html(tmp_path / "v.html")
    r = s._repr_html_()
    assert r.startswith('<iframe srcdoc="')
    inner = r[len('<iframe srcdoc="'):r.index('" style=')]
    assert html.unescape(inner) == (tmp_path / "v.html").read_text()


def test_unpickled_solution_has_no_viewer_and_says_so():
    s = pickle.loads(pickle.dumps(bellyflop.solve(bellyflop.Scenario.paper(), nodes=12)))
    with pytest.raises(ValueError, match="rebuilt from JSON"):
        s._repr_html_()


def test_flight_page_plays_its_trace(tmp_path):
    f = bellyflop.sim(seed=1, run=0)
    f.save_html(tmp_path / "f.html")
    d = page_data((tmp_path / "f.html").read_text())
    assert d["kind"] == "flight"
    assert d["trace"]["t_s"] == list(f.trace["t_s"])
    assert d["flight"]["outcome_name"] == f.outcome_name
    assert len(d["flight"]["replans"]) == len(f.replans)


def test_save_html_into_a_missing_directory_is_an_os_error(tmp_path):
    f = bellyflop.sim(seed=1, run=0)
    with pytest.raises(OSError, match="missing"):
        f.save_html(tmp_path / "missing" / "f.html")
