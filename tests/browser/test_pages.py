"""The three viewer.html pages in headless Chromium, opened from disk.

Each page loads without a console error; the slider is moved to three
times by script, and the vehicle drawn there (its centre of mass, pitch,
length and nose) is checked against the trajectory the CLI wrote
(trajectory.csv for a solve, flight.csv for a flight), read here on its
own. The campaign's dots are clicked and checked against runs.csv, and the
command the page prints flies the same run again. A scenario with a
[constraints] table draws its approach cone, trigger heights and bounds;
the paper's case draws none of them. A polished answer draws its switching
functions S_T and S_δ under the T and δ charts; a raw one (--fast) does not.
Screenshots go to $BELLYFLOP_SCREENSHOTS (scripts/screenshots sets it to
docs/) or to the test's temporary directory.
"""

import csv
import json
import math
import os
import subprocess
import tomllib
from pathlib import Path

import pytest

from cdp import Browser

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("BELLYFLOP_BIN", ROOT / "target" / "release" / "bellyflop"))
VEHICLE = tomllib.loads((ROOT / "scenarios" / "paper.toml").read_text())["vehicle"]
PX = 0.5  # drawing tolerance [px]
DEG = 0.05  # pitch tolerance [deg]


def cli(*args):
    r = subprocess.run([str(BIN), *args], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    return r.stdout


@pytest.fixture(scope="module")
def out(tmp_path_factory):
    d = tmp_path_factory.mktemp("viewer")
    cli("solve", "--quiet", "--out", str(d / "solve"))
    cli("sim", "--json", "--out", str(d / "sim"))
    cli("montecarlo", "--runs", "40", "--threads", "2", "--quiet", "--out", str(d / "campaign"))
    return d


@pytest.fixture(scope="module")
def shots(tmp_path_factory):
    d = os.environ.get("BELLYFLOP_SCREENSHOTS")
    return Path(d) if d else tmp_path_factory.mktemp("screenshots")


@pytest.fixture(scope="module")
def browser():
    with Browser() as b:
        yield b


def columns(path):
    with open(path) as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in rows[0]}


def at(ts, ys, t):
    """Linear interpolation, as the trajectory is sampled."""
    for i in range(1, len(ts)):
        if ts[i] >= t:
            w = (t - ts[i - 1]) / (ts[i] - ts[i - 1]) if ts[i] > ts[i - 1] else 1.0
            return ys[i - 1] + w * (ys[i] - ys[i - 1])
    return ys[-1]


def open_page(browser, path):
    browser.open(path.resolve().as_uri())
    assert browser.eval("window.viewer && window.viewer.kind") is not None
    assert browser.errors() == []


def move_slider(browser, t):
    """Set the range input's value and fire its input event, as a drag does."""
    return browser.eval(
        "(() => { const s = document.getElementById('slider'); s.value = %r;"
        " s.dispatchEvent(new Event('input', {bubbles: true})); return Number(s.value); })()" % t)


DRAWN = """(() => {
  const scene = document.getElementById('scene'), g = document.getElementById('vehicle');
  const m = g.getCTM(), sm = scene.getCTM().inverse();
  const local = (el, x, y) => new DOMPoint(x, y).matrixTransform(sm.multiply(el.getCTM()));
  const tip = document.getElementById('nose-tip'), pad = document.getElementById('pad');
  const cg = local(g, 0, 0), nose = local(tip, tip.cx.baseVal.value, tip.cy.baseVal.value);
  const body = document.getElementById('body').getBBox(), cap = document.getElementById('nose').getBBox();
  const r = sm.multiply(m), nz = sm.multiply(document.getElementById('nozzle').getCTM());
  const plume = document.getElementById('plume').points;
  const flame = local(document.getElementById('plume'), plume[2].x, plume[2].y);
  const exit = local(document.getElementById('plume'), (plume[0].x + plume[1].x) / 2, plume[0].y);
  return {cg: [cg.x, cg.y], tip: [nose.x, nose.y], angle: Math.atan2(r.b, r.a) * 180 / Math.PI,
    nozzle: Math.atan2(nz.b, nz.a) * 180 / Math.PI, plume: Math.hypot(flame.x - exit.x, flame.y - exit.y),
    plume_dir: Math.atan2(flame.x - exit.x, flame.y - exit.y) * 180 / Math.PI,
    length: body.height + cap.height, width: body.width,
    pad: [pad.x.baseVal.value + pad.width.baseVal.value / 2, pad.y.baseVal.value],
    scale: Number(scene.dataset.scale), ox: Number(scene.dataset.ox), oy: Number(scene.dataset.oy)};
})()"""


def check_vehicle_at(browser, traj, t):
    """The drawn vehicle at time t against the trajectory's x, z and θ."""
    # The range input keeps its value as a string of 15 significant digits.
    t_set = move_slider(browser, t)
    assert abs(t_set - t) < 1e-9
    t = t_set
    d = browser.eval(DRAWN)
    s, ox, oy = d["scale"], d["ox"], d["oy"]
    # The pad is at x = 0 on the ground line z = 0.
    assert abs(d["pad"][0] - ox) < PX and abs(d["pad"][1] - oy) < PX
    x, z, theta = (at(traj["t_s"], traj[k], t) for k in ("x_m", "z_m", "theta_rad"))
    assert abs(d["cg"][0] - (ox + s * x)) < PX, (t, d, x)
    assert abs(d["cg"][1] - (oy - s * z)) < PX, (t, d, z)
    # Pitch: the body axis (−sin θ, cos θ) drawn turned by −θ on the screen.
    assert abs(angle(d["angle"] + math.degrees(theta))) < DEG, (t, d["angle"], math.degrees(theta))
    # To scale: 50 m × 9 m, the nose tip (l − l_cg) ahead of the centre of mass.
    assert abs(d["length"] - s * VEHICLE["length_m"]) < PX
    assert abs(d["width"] - s * 2 * VEHICLE["radius_m"]) < PX
    ahead = s * (VEHICLE["length_m"] - VEHICLE["cg_m"])
    tip = (ox + s * x - ahead * math.sin(theta), oy - s * z - ahead * math.cos(theta))
    assert math.dist(d["tip"], tip) < PX, (t, d["tip"], tip)
    # The nozzle at δ: the exhaust leaves along (sin(θ+δ), −cos(θ+δ)), on the
    # screen (sin(θ+δ), cos(θ+δ)) since y points down.
    delta = at(traj["t_s"], traj["delta_rad"], t)
    assert abs(angle(d["nozzle"] + math.degrees(theta + delta))) < DEG, (t, d["nozzle"], delta)
    assert abs(angle(d["plume_dir"] - math.degrees(theta + delta))) < DEG, (t, d["plume_dir"])
    assert browser.eval("window.viewer.state().t") == t
    thrust = at(traj["t_s"], traj["thrust_n" if "thrust_n" in traj else "thrust_cmd_n"], t)
    return d["plume"], thrust


def angle(deg):
    """An angle in (−180, 180]."""
    return (deg + 180) % 360 - 180


def check_plume_scales_with_thrust(plumes):
    """The plume's drawn length is one constant times T at every time."""
    k = sum(p for p, _ in plumes) / sum(t for _, t in plumes)
    for p, t in plumes:
        assert abs(p - k * t) < PX, (plumes, k)


def three_times(traj):
    t0, t1 = traj["t_s"][0], traj["t_s"][-1]
    return [t0 + f * (t1 - t0) for f in (0.137, 0.5, 0.861)]


def test_solve_viewer_draws_the_vehicle_where_the_trajectory_is(out, browser, shots):
    open_page(browser, out / "solve" / "viewer.html")
    traj = columns(out / "solve" / "trajectory.csv")
    check_plume_scales_with_thrust([check_vehicle_at(browser, traj, t) for t in three_times(traj)])
    assert browser.errors() == []
    browser.screenshot(shots / "viewer-solve.png")


def test_solve_viewer_lights_the_active_thrust_bound(out, browser):
    open_page(browser, out / "solve" / "viewer.html")
    traj = columns(out / "solve" / "trajectory.csv")
    t_max = VEHICLE["max_thrust_n"]
    # A sample well inside the arc at T_max.
    on = [t for t, T in zip(traj["t_s"], traj["thrust_n"]) if T > t_max * (1 - 1e-6)]
    assert on, "the paper's landing burns at T_max"
    mid = on[len(on) // 2]
    move_slider(browser, mid)
    assert "T = T_max" in browser.eval("window.viewer.state().active")
    assert browser.eval("document.querySelector('svg.chart[data-key=thrust_n]').classList.contains('active')")
    # The polished answer is bang-bang (T_min, then T_max): a sample inside
    # the T_min arc must light T_min and put T_max out.
    t_min = VEHICLE["min_thrust_n"]
    low = [t for t, T in zip(traj["t_s"], traj["thrust_n"]) if T < t_min * (1 + 1e-6)]
    assert low, "the paper's fall burns at T_min"
    move_slider(browser, low[len(low) // 2])
    active = browser.eval("window.viewer.state().active")
    assert "T = T_min" in active and "T = T_max" not in active, active


def test_flight_viewer_follows_the_flown_trajectory(out, browser, shots):
    open_page(browser, out / "sim" / "viewer.html")
    trace = columns(out / "sim" / "flight.csv")
    check_plume_scales_with_thrust([check_vehicle_at(browser, trace, t) for t in three_times(trace)])
    # One marker per re-plan of flight.json, named by its time and status.
    flight = json.loads((out / "sim" / "flight.json").read_text())
    titles = browser.eval("[...document.querySelectorAll('#scene circle.replan title')].map(e => e.textContent)")
    assert len(titles) == len(flight["replans"]) > 0
    for title, r in zip(titles, flight["replans"]):
        assert title.startswith("t = %.2f s: %s" % (r["time_s"], r["status"])), title
    # Each re-plan's answer drawn in the scene, from its own start.
    paths = browser.eval("document.querySelectorAll('#scene polyline.replan-path').length")
    assert paths == sum(1 for r in flight["replans"] if r["status"] != "bad_state")
    verdict = browser.eval("document.getElementById('verdict').textContent")
    assert flight["outcome_name"] in verdict
    assert browser.errors() == []
    browser.screenshot(shots / "viewer-sim.png")


def test_campaign_viewer_shows_a_clicked_run_and_how_to_fly_it(out, browser, shots):
    open_page(browser, out / "campaign" / "viewer.html")
    with open(out / "campaign" / "runs.csv") as f:
        rows = list(csv.DictReader(f))
    box = [float(v) for v in browser.eval("document.getElementById('scatter-x').dataset.box").split(",")]
    xr = [float(v) for v in browser.eval("document.getElementById('scatter-x').dataset.xr").split(",")]
    for row in (rows[0], rows[len(rows) // 2], rows[-1]):
        k = row["run"]
        sel = "#scatter-x circle.dot[data-run='%s']" % k
        cx = browser.eval("Number(document.querySelector(\"%s\").getAttribute('cx'))" % sel)
        want = box[0] + (box[2] - box[0]) * (float(row["x_error_m"]) - xr[0]) / (xr[1] - xr[0])
        assert abs(cx - want) < PX
        browser.eval("document.querySelector(\"%s\").dispatchEvent(new MouseEvent('click', {bubbles: true}))" % sel)
        shown = browser.eval("[...document.querySelectorAll('#run-row tr')].map(r => [r.cells[0].textContent, r.cells[1].textContent])")
        assert dict(shown).keys() == row.keys()
        for name, value in shown:
            try:
                assert float(value) == float(row[name]), name
            except ValueError:
                assert value == row[name], name
        cmd = browser.eval("document.getElementById('run-command').textContent")
        assert cmd == f"bellyflop sim --seed 1 --run {k} --out run-{k}"
    # The printed command flies the last run again: the same touchdown.
    again = json.loads(cli(*cmd.split()[1:-2], "--json"))
    assert again["outcome"]["x_error_m"] == float(rows[-1]["x_error_m"])
    assert browser.errors() == []
    browser.screenshot(shots / "viewer-campaign.png")


def test_python_page_is_the_solve_viewer(out, browser, tmp_path):
    """Solution.save_html's page plays the same solve as the CLI's."""
    import bellyflop

    page = tmp_path / "py-viewer.html"
    bellyflop.solve(bellyflop.Scenario.paper()).save_html(page)
    open_page(browser, page)
    traj = columns(out / "solve" / "trajectory.csv")
    check_plume_scales_with_thrust([check_vehicle_at(browser, traj, t) for t in three_times(traj)])
    assert browser.errors() == []


# Every limit of the [constraints] table, at `bellyflop init`'s values.
CONSTRAINTS = {"cone_half_angle_deg": 30.0, "max_pitch_rate_degps": 30.0, "max_tilt_deg": 10.0,
               "tilt_below_m": 50.0, "final_descent_m": 20.0, "final_descent_lateral_mps": 2.0}


@pytest.fixture(scope="module")
def constrained(tmp_path_factory):
    """The paper's scenario as `bellyflop init` writes it, with a [constraints]
    table added, solved with --out: (scenario, output directory)."""
    d = tmp_path_factory.mktemp("constrained")
    text = cli("init") + "\n[constraints]\n" + "".join(f"{k} = {v!r}\n" for k, v in CONSTRAINTS.items())
    (d / "scenario.toml").write_text(text)
    scenario = tomllib.loads(text)
    assert scenario["constraints"] == CONSTRAINTS
    cli("solve", "--quiet", "--scenario", str(d / "scenario.toml"), "--out", str(d / "solve"))
    return scenario, d / "solve"


LIMITS = """(() => {
  const scene = document.getElementById('scene'), v = a => a.baseVal.value;
  const curves = k => [...document.querySelectorAll(`svg.chart[data-key=${k}] polyline.limit`)]
    .map(p => ({sign: Number(p.dataset.sign), points: [...p.points].map(q => [q.x, q.y])}));
  return {
    cone: [...scene.querySelectorAll('line.cone')].map(e => [v(e.x1), v(e.y1), v(e.x2), v(e.y2)]),
    triggers: Object.fromEntries([...scene.querySelectorAll('line.trigger')].map(e => [e.dataset.limit, v(e.y1)])),
    labels: [...scene.querySelectorAll('text.limit-label')].map(e => e.textContent),
    charts: Object.fromEntries(['theta_rad', 'pitch_rate_radps', 'vx_mps'].map(k => [k, curves(k)])),
    summary: document.getElementById('limits') && document.getElementById('limits').textContent,
    drawn: document.querySelectorAll('.limit, .limit-label, #limits, clipPath').length,
    scale: Number(scene.dataset.scale), ox: Number(scene.dataset.ox), oy: Number(scene.dataset.oy)};
})()"""


def test_solve_viewer_draws_the_cone_and_the_limits(constrained, browser):
    scenario, out = constrained
    open_page(browser, out / "viewer.html")
    d = browser.eval(LIMITS)
    s, ox, oy = d["scale"], d["ox"], d["oy"]
    pad = (ox + s * scenario["terminal"]["x_m"], oy - s * scenario["terminal"]["z_m"])
    # The cone: two edges from the pad, one each side, at tan γ from the vertical.
    tan = math.tan(math.radians(CONSTRAINTS["cone_half_angle_deg"]))
    assert len(d["cone"]) == 2
    sides = []
    for x1, y1, x2, y2 in d["cone"]:
        assert math.dist((x1, y1), pad) < PX
        assert y2 < y1 - 100, "the edge rises from the pad"
        assert abs(abs(x2 - x1) / (y1 - y2) - tan) < 1e-6
        sides.append(math.copysign(1, x2 - x1))
    assert sorted(sides) == [-1, 1]
    # A dashed line at each trigger height above the pad, labelled.
    heights = {"tilt": CONSTRAINTS["tilt_below_m"], "final_descent": CONSTRAINTS["final_descent_m"]}
    assert d["triggers"].keys() == heights.keys()
    for k, h in heights.items():
        assert abs(d["triggers"][k] - (pad[1] - s * h)) < PX, k
        assert any("below %.1f m" % h in t for t in d["labels"]), d["labels"]
    # ±bound on θ, w and Vx: mirror images about 0; w's is constant, the
    # triggered ones are the limit well below their height and open above it.
    traj = columns(out / "trajectory.csv")
    z_f = scenario["terminal"]["z_m"]
    for key, h in [("pitch_rate_radps", None), ("theta_rad", heights["tilt"]), ("vx_mps", heights["final_descent"])]:
        curves = sorted(d["charts"][key], key=lambda c: -c["sign"])
        assert [c["sign"] for c in curves] == [1, -1], key
        up, down = curves[0]["points"], curves[1]["points"]
        assert len(up) == len(down) == len(traj["t_s"]), key
        middle = [(a[1] + b[1]) / 2 for a, b in zip(up, down)]
        assert max(middle) - min(middle) < 0.02, key  # points in 0.01 px
        base = up[-1][1]
        below = [p[1] for p, z in zip(up, traj["z_m"]) if h is None or z - z_f < h - 10]
        above = [p[1] for p, z in zip(up, traj["z_m"]) if h is not None and z - z_f > h + 10]
        assert below and all(abs(y - base) < 0.05 for y in below), key
        assert h is None or (above and all(y < base - 5 for y in above)), key
    # The summary: each limit with its worst margin from solution.json's path.limits.
    limits = json.loads((out / "solution.json").read_text())["path"]["limits"]
    assert len(limits) == 4
    to_deg = {"pitch_rate": math.degrees, "tilt": math.degrees}
    for r in limits:
        margin = to_deg.get(r["limit"], float)(-r["worst"])
        assert "worst margin %.2f" % margin in d["summary"], (r, d["summary"])
    assert d["summary"].count("worst margin") == 4
    assert browser.errors() == []


def test_paper_case_draws_no_limit(out, browser):
    open_page(browser, out / "solve" / "viewer.html")
    d = browser.eval(LIMITS)
    assert d["drawn"] == 0 and d["summary"] is None and d["cone"] == [] and d["triggers"] == {}
    assert all(c == [] for c in d["charts"].values())


SWITCHING = """(() => {
  const chart = k => document.querySelector(`svg.chart[data-key=${k}]`);
  const box = (k, e) => { const a = chart(k).getBoundingClientRect(), b = chart(e).getBoundingClientRect();
    return {left: a.left - b.left, below: a.top - b.bottom}; };
  const one = k => chart(k) && {
    points: [...chart(k).querySelectorAll('polyline.switching')].map(p => p.points.length),
    zero: chart(k).querySelectorAll('line.zero').length,
    arcs: [...chart(k).querySelectorAll('rect.arc')].map(r => r.getAttribute('class')),
    title: chart(k).querySelector('.title').textContent};
  return {thrust: one('switching_thrust'), delta: one('switching_delta'),
    drawn: document.querySelectorAll('polyline.switching, rect.arc').length,
    under_thrust: chart('switching_thrust') && box('switching_thrust', 'thrust_n'),
    under_delta: chart('switching_delta') && box('switching_delta', 'delta_rad')};
})()"""


def test_solve_viewer_draws_the_switching_functions(out, browser):
    """The polished paper page draws S_T under T, its thrust arcs shaded
    behind, and S_δ under δ: one point per sample of optimality.switching."""
    sol = json.loads((out / "solve" / "solution.json").read_text())
    sw, arcs = sol["optimality"]["switching"], sol["optimality"]["thrust_arcs"]
    n = len(sw["t_s"])
    assert n > 100 and len(sw["thrust"]) == len(sw["delta"]) == n
    open_page(browser, out / "solve" / "viewer.html")
    d = browser.eval(SWITCHING)
    assert d["thrust"]["points"] == [n] and d["delta"]["points"] == [n], d
    assert d["thrust"]["zero"] == d["delta"]["zero"] == 1
    assert d["thrust"]["arcs"] == ["arc " + a["kind"] for a in arcs] and d["delta"]["arcs"] == []
    assert "∂H/∂T" in d["thrust"]["title"] and "∂H/∂δ" in d["delta"]["title"]
    # Each in its chart's column, below it.
    for k in ("under_thrust", "under_delta"):
        assert abs(d[k]["left"]) < PX and d[k]["below"] >= 0, (k, d[k])
    assert browser.errors() == []


def test_raw_page_draws_no_switching_function(tmp_path, browser):
    """An answer without the polish (--fast) has no certificate: no chart of it."""
    r = subprocess.run([str(BIN), "solve", "--quiet", "--fast", "--out", str(tmp_path / "raw")],
                       capture_output=True, text=True, timeout=600)
    # The raw N = 20 answer misses the pad by metres: `inaccurate` (exit 9).
    assert r.returncode in (0, 9), r.stderr
    assert "optimality" not in json.loads((tmp_path / "raw" / "solution.json").read_text())
    open_page(browser, tmp_path / "raw" / "viewer.html")
    d = browser.eval(SWITCHING)
    assert d["thrust"] is None and d["delta"] is None and d["drawn"] == 0, d
