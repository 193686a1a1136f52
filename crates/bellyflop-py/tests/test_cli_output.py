"""The CLI's output never panics (issue 36): a closed pipe ends a command
quietly, a full disk is an error naming the file, `--threads` is capped by
the runs, and Ctrl-C during `montecarlo --out` writes the runs that
finished. Also: the documents quote the defaults the code has."""

from __future__ import annotations

import csv
import json
import os
import re
import resource
import signal
import subprocess
import time

import pytest

import bellyflop
from conftest import ROOT

#: One invocation of every command and output form (small, so each takes
#: about a second in a release build).
COMMANDS = [
    ["solve"],
    ["solve", "--json"],
    ["solve", "--method", "scvx"],
    ["init"],
    ["sweep", "--nodes", "15,20"],
    ["sweep", "--nodes", "15,20", "--json"],
    ["sim"],
    ["sim", "--json"],
    ["montecarlo", "--runs", "2", "--quiet"],
    ["montecarlo", "--runs", "2", "--json"],
]


def ids(cmd):
    return " ".join(cmd)


@pytest.mark.parametrize("cmd", COMMANDS, ids=ids)
def test_closed_pipe_ends_quietly(cli, cmd):
    # The reader has gone before the first byte: every write is EPIPE.
    r, w = os.pipe()
    os.close(r)
    p = subprocess.run([str(cli), *cmd], stdout=w, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    os.close(w)
    assert p.returncode == 141, (p.returncode, p.stderr[-2000:])
    assert "panicked" not in p.stderr and "error" not in p.stderr, p.stderr[-2000:]


@pytest.mark.parametrize("cmd", [["solve"], ["init"], ["sim", "--json"]], ids=ids)
def test_head_c_1(cli, cmd):
    # As a shell runs it: `bellyflop CMD | head -c 1`.
    line = " ".join([str(cli), *cmd]) + " | head -c 1; echo \" ${PIPESTATUS[0]}\" >&2"
    p = subprocess.run(["bash", "-c", line], capture_output=True, text=True, cwd=ROOT)
    assert len(p.stdout) == 1
    status = int(p.stderr.split()[-1])
    # 141 when the CLI wrote after head left; its own code when it was done.
    assert status in (0, 141), p.stderr[-2000:]
    assert "panicked" not in p.stderr


@pytest.mark.parametrize("cmd", COMMANDS, ids=ids)
def test_full_disk_on_stdout_is_an_error(cli, cmd):
    with open("/dev/full", "w") as full:
        p = subprocess.run([str(cli), *cmd], stdout=full, stderr=subprocess.PIPE, text=True, cwd=ROOT)
    assert p.returncode == 1, (p.returncode, p.stderr[-2000:])
    assert "panicked" not in p.stderr
    assert "error: cannot write to stdout: No space left on device" in p.stderr, p.stderr[-2000:]


def test_init_into_a_full_disk_names_the_file(cli):
    p = subprocess.run([str(cli), "init", "--force", "/dev/full"], capture_output=True, text=True)
    assert p.returncode == 1, p.stderr
    assert "error: /dev/full: No space left on device" in p.stderr, p.stderr
    assert "panicked" not in p.stderr


def _file_size_limit(limit: int):
    def limit_files():
        # Ignored, SIGXFSZ turns a write beyond the limit into EFBIG.
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return limit_files


@pytest.mark.parametrize(
    "cmd,big",
    [
        (["montecarlo", "--runs", "40", "--quiet"], "runs.csv"),
        (["solve", "--quiet"], "trajectory.csv"),
        (["init", "--force"], None),
    ],
    ids=["montecarlo", "solve", "init"],
)
def test_a_failed_write_leaves_no_half_file(cli, tmp_path, cmd, big):
    # A file-size limit of 2 kB (as a full disk would) fails the first
    # larger file: the command names it and exits 1, and nothing under its
    # name (nor a temporary file) is left behind.
    if cmd[0] == "init":
        target = tmp_path / "case.toml"
        args = [*cmd, str(target)]
    else:
        target = tmp_path / "out" / big
        args = [*cmd, "--out", str(tmp_path / "out")]
    p = subprocess.run(
        [str(cli), *args], capture_output=True, text=True, cwd=ROOT, preexec_fn=_file_size_limit(2048)
    )
    assert p.returncode == 1, (p.returncode, p.stderr[-2000:])
    assert f"error: {target}: File too large" in p.stderr, p.stderr[-2000:]
    assert not target.exists()
    leftovers = [f.name for f in target.parent.iterdir() if ".partial" in f.name]
    assert leftovers == []


def test_threads_are_capped_by_the_runs(cli):
    start = time.perf_counter()
    p = subprocess.run(
        [str(cli), "montecarlo", "--runs", "2", "--threads", "20000", "--json"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    elapsed = time.perf_counter() - start
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout)["threads"] == 2
    assert "warning: --threads 20000 is more than" in p.stderr
    assert elapsed < 1.0, elapsed
    print(f"montecarlo --runs 2 --threads 20000: {elapsed:.3f} s")
    p = subprocess.run([str(cli), "montecarlo", "--runs", "2", "--threads", "2000000"], capture_output=True, text=True)
    assert p.returncode == 2
    assert "--threads = 2000000 is out of range: allowed 0 to 1000000" in p.stderr


def test_sigint_writes_the_runs_that_finished(cli, tmp_path):
    out = tmp_path / "mc"
    runs = 400
    p = subprocess.Popen(
        [str(cli), "montecarlo", "--runs", str(runs), "--threads", "2", "--quiet", "--out", str(out), "--seed", "3"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    time.sleep(2.0)
    p.send_signal(signal.SIGINT)
    sent = time.perf_counter()
    stdout, stderr = p.communicate(timeout=120)
    ended = time.perf_counter() - sent
    assert p.returncode == 130, (p.returncode, stderr[-2000:])
    rows = list(csv.DictReader((out / "runs.csv").open()))
    summary = json.loads((out / "summary.json").read_text())
    assert 0 < len(rows) < runs, len(rows)
    assert summary["partial"] is True and summary["requested_runs"] == runs
    assert summary["runs"] == len(rows)
    assert len({r["run"] for r in rows}) == len(rows)
    assert f"interrupted: {len(rows)} of {runs} runs finished" in stderr
    assert "campaign" in stdout
    print(f"SIGINT after 2 s: {len(rows)} of {runs} rows in runs.csv; exit {ended:.3f} s after the signal")
    # The finished rows are those of an uninterrupted campaign.
    ref = bellyflop.montecarlo(3, seed=3)
    for r, k in zip(rows, range(3)):
        if int(r["run"]) == k:
            assert r["fuel_kg"] == str(ref["fuel_kg"][k])


# Where the documents quote the solver's default landing tolerances.
DOCS = ["README.md", "docs/reliability.md", "crates/bellyflop-py/README.md"]


def _default_tolerances():
    d = bellyflop.Scenario.paper().to_dict()
    del d["solver"]["landing_position_tolerance_m"]
    del d["solver"]["landing_velocity_tolerance_mps"]
    s = bellyflop.Scenario.from_dict(d).solver
    return s.landing_position_tolerance_m, s.landing_velocity_tolerance_mps


def test_documents_quote_the_default_landing_tolerances():
    pos, vel = _default_tolerances()
    quoted = []
    for doc in DOCS:
        text = (ROOT / doc).read_text()
        for m in re.finditer(r"landing_position_tolerance_m`\s*\(([0-9.e+-]+) m\)", text):
            quoted.append((doc, "position", float(m.group(1)), pos))
        for m in re.finditer(r"landing_velocity_tolerance_mps`\s*\(([0-9.e+-]+) m/s\)", text):
            quoted.append((doc, "velocity", float(m.group(1)), vel))
        for m in re.finditer(r"the ([0-9.]+) m / ([0-9.]+) m/s (?:landing )?tolerances", text):
            quoted.append((doc, "position", float(m.group(1)), pos))
            quoted.append((doc, "velocity", float(m.group(2)), vel))
    assert len(quoted) >= 4, quoted
    wrong = [q for q in quoted if q[2] != q[3]]
    assert wrong == [], wrong


def test_python_readme_prints_what_the_code_prints():
    # The README's first example quotes solve()'s status, t_f and m_f.
    text = (ROOT / "crates/bellyflop-py/README.md").read_text()
    m = re.search(r"sol\.status, sol\.tf_s, sol\.final_mass_kg\s+# \('(\w+)', ([0-9.]+)\.\.\., ([0-9.]+)\.\.\.\)", text)
    assert m, "the example's comment is gone"
    sol = bellyflop.solve()
    assert sol.status == m.group(1)
    assert str(sol.tf_s).startswith(m.group(2)), (sol.tf_s, m.group(2))
    assert str(sol.final_mass_kg).startswith(m.group(3)), (sol.final_mass_kg, m.group(3))
