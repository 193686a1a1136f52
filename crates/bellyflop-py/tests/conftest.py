"""Shared fixtures: the repository's `bellyflop` CLI (release build), run
from the tests to compare the package's output with the command line's."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]

#: Keys whose values are wall-clock measurements (differ between any two runs).
TIMING_KEYS = {"solve_time_ms", "total_time_ms", "time_ms", "ms", "solve_ms", "late", "wall_time_s"}


@pytest.fixture(scope="session")
def cli() -> Path:
    """The release `bellyflop` binary (BELLYFLOP_CLI, else target/release,
    built with `cargo build --release --locked -p bellyflop-cli` if absent)."""
    path = Path(os.environ.get("BELLYFLOP_CLI", ROOT / "target" / "release" / "bellyflop"))
    if not path.exists():
        subprocess.run(
            ["cargo", "build", "--release", "--locked", "-p", "bellyflop-cli"],
            cwd=ROOT,
            check=True,
        )
    return path


def run_cli(cli: Path, *args: str, check_codes=(0,)) -> subprocess.CompletedProcess:
    p = subprocess.run([str(cli), *args], capture_output=True, text=True, cwd=ROOT)
    assert p.returncode in check_codes, f"bellyflop {' '.join(args)}: exit {p.returncode}\n{p.stderr}"
    return p


def cli_json(cli: Path, *args: str, check_codes=(0,)) -> dict:
    return json.loads(run_cli(cli, *args, check_codes=check_codes).stdout)


def without_timing(v):
    """`v` with every wall-clock key dropped, recursively."""
    if isinstance(v, dict):
        return {k: without_timing(x) for k, x in v.items() if k not in TIMING_KEYS}
    if isinstance(v, list):
        return [without_timing(x) for x in v]
    return v


def pytest_configure(config):
    config.addinivalue_line(
        "markers",
        "big: the property-based run of at least 10,000 examples per type (about a minute each)",
    )
