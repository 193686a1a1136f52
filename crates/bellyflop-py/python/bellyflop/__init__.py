"""bellyflop: fuel-optimal flip-and-land trajectories, closed-loop landings
and Monte Carlo campaigns, from Python.

The numbers come from the Rust core crate, serialized by the same code as the
``bellyflop`` command line: ``solve(...).to_dict()`` is the object
``bellyflop solve --json`` prints, and ``montecarlo(...).runs_csv()`` the
runs.csv that ``bellyflop montecarlo --out`` writes.

- :class:`Scenario`: a landing problem (``Scenario.paper()``,
  ``Scenario.from_toml(path_or_text)``, ``Scenario.from_dict(d)``);
- :func:`solve` -> :class:`Solution`;
- :func:`sim` -> :class:`Flight` (one closed-loop landing with dispersions);
- :func:`montecarlo` -> :class:`Campaign` (many landings, on any
  ``concurrent.futures.Executor``).

Bad input raises :class:`InputError` (a ``ValueError``); a solve that does
not converge is a ``status``, not an exception.
"""

from __future__ import annotations

import os
import time
from concurrent.futures import Executor
from typing import Any, Dict, List, Mapping, Optional, Union

import numpy as np

from . import _bellyflop
from ._bellyflop import (
    Flight,
    InputError,
    InternalError,
    Scenario,
    SimConfig,
    Solution,
)

__all__ = [
    "Scenario",
    "SimConfig",
    "Solution",
    "Flight",
    "Campaign",
    "InputError",
    "InternalError",
    "solve",
    "sim",
    "montecarlo",
    "RUNS_CSV_COLUMNS",
]

#: The columns of runs.csv (and of :attr:`Campaign.columns`), in order.
RUNS_CSV_COLUMNS: List[str] = list(_bellyflop.runs_csv_columns())

ScenarioLike = Union[Scenario, Mapping[str, Any], str, "os.PathLike[str]", None]
ConfigLike = Union[SimConfig, Mapping[str, Any], str, "os.PathLike[str]", None]


def _scenario(s: ScenarioLike) -> Scenario:
    """A Scenario from None (the paper's case), a Scenario, a dict, or TOML."""
    if s is None:
        return Scenario.paper()
    if isinstance(s, Scenario):
        return s
    if isinstance(s, Mapping):
        return Scenario.from_dict(s)
    return Scenario.from_toml(s)


def _config(c: ConfigLike) -> SimConfig:
    """A SimConfig from None (the defaults), a SimConfig, a dict, or TOML."""
    if c is None:
        return SimConfig()
    if isinstance(c, SimConfig):
        return c
    if isinstance(c, Mapping):
        return SimConfig.from_dict(c)
    return SimConfig.from_toml(c)


def solve(
    scenario: ScenarioLike = None,
    *,
    nodes: Optional[int] = None,
    intervals: Optional[int] = None,
    method: Optional[str] = None,
    formulation: Optional[str] = None,
    interpolation: str = "pchip",
    mesh_tolerance: Optional[float] = None,
    fast: bool = False,
) -> Solution:
    """Solve one landing problem, as ``bellyflop solve --json`` does.

    ``scenario`` is the paper's case when omitted (or a Scenario, a dict, a
    TOML path or text). ``nodes`` (N), ``intervals`` (M), ``method``
    (``"direct"`` or ``"scvx"``) and ``formulation`` (``"exact"``,
    ``"paper"``, ``"vector"``) override the scenario; ``interpolation``
    (``"pchip"`` or ``"linear"``) rebuilds the controls for the landing error.
    ``mesh_tolerance`` refines the mesh until every interval's relative error
    is within it (``--mesh-tolerance``; the passes are in
    ``to_dict()["refinement"]``). By default a solved answer is polished
    into controls that fly (``to_dict()["controls_flown"]``, the README's
    "The flown controls"); ``fast=True`` returns the raw collocation answer
    (``--fast``).

    The GIL is released while the core solves. Raises :class:`InputError`
    on bad input; any other outcome is ``Solution.status``.
    """
    return _bellyflop.solve(
        _scenario(scenario),
        nodes=nodes,
        intervals=intervals,
        method=method,
        formulation=formulation,
        mesh_tolerance=mesh_tolerance,
        interpolation=interpolation,
        fast=fast,
    )


def sim(
    scenario: ScenarioLike = None,
    config: ConfigLike = None,
    *,
    seed: int = 0,
    run: int = 0,
) -> Flight:
    """Fly run ``run`` of campaign ``seed`` in closed loop, as
    ``bellyflop sim --seed S --run K --json`` does (the same dispersions as
    that run of :func:`montecarlo`). ``config`` holds the tables
    ``[dispersions]``, ``[guidance]``, ``[plant]``, ``[touchdown]``."""
    return _bellyflop.sim(_scenario(scenario), _config(config), seed=seed, run=run)


def _fly_chunk(
    scenario: Scenario, config: SimConfig, seed: int, start: int, stop: int
) -> list:
    """Fly runs ``start..stop`` on one thread (an executor's task): the
    rows as plain tuples, which pickle."""
    return _bellyflop.campaign_chunk(scenario, config, seed, start, stop, threads=1)


class Campaign:
    """A Monte Carlo campaign: one row per run and the summary.

    - :attr:`columns`: runs.csv's columns by name (numbers as numpy arrays,
      ``outcome`` as a numpy array of str), rows in run order;
    - :attr:`summary`: the object ``bellyflop montecarlo --json`` prints;
    - :meth:`runs_csv`: the text of runs.csv.

    ``max_replan_ms`` and ``late_replans`` are wall-clock measurements; every
    other column depends only on (seed, run index).
    """

    def __init__(self, table: Any) -> None:
        self._table = table
        cols = dict(table.columns())
        cols["outcome"] = np.asarray(cols["outcome"], dtype=str)
        self.columns: Dict[str, np.ndarray] = {k: cols[k] for k in RUNS_CSV_COLUMNS}
        self.summary: Dict[str, Any] = table.summary

    def __getitem__(self, column: str) -> np.ndarray:
        return self.columns[column]

    def __len__(self) -> int:
        return len(self._table)

    def runs_csv(self) -> str:
        """The text of runs.csv, as ``bellyflop montecarlo --out`` writes it."""
        return self._table.runs_csv()

    def __repr__(self) -> str:
        return f"<bellyflop.Campaign {len(self)} runs, {self.summary['in_spec']} in spec>"


def _chunks(runs: int, chunk: int) -> List[range]:
    return [range(a, min(a + chunk, runs)) for a in range(0, runs, chunk)]


def montecarlo(
    runs: int,
    *,
    seed: int = 0,
    scenario: ScenarioLike = None,
    config: ConfigLike = None,
    executor: Optional[Executor] = None,
    chunk: Optional[int] = None,
    threads: int = 0,
) -> Campaign:
    """Fly ``runs`` dispersed closed-loop landings of campaign ``seed``.

    Each run's draw depends only on (seed, run index), as in the CLI, so the
    rows equal those of ``bellyflop montecarlo --runs N --seed S`` whatever
    runs them:

    - ``executor=None``: in this process on ``threads`` threads (0: one per
      core), the GIL released;
    - ``executor=E``: any ``concurrent.futures.Executor`` (a process pool,
      Dask's ``client.get_executor()``, a Ray adapter...). The runs are cut
      into tasks of ``chunk`` runs (default: about four tasks per worker
      when the executor tells its worker count, else 8 runs).
    """
    if not isinstance(runs, int) or isinstance(runs, bool) or not 1 <= runs <= 1_000_000:
        raise InputError(f"runs = {runs!r} is out of range: allowed 1 to 1000000")
    if chunk is not None and (not isinstance(chunk, int) or chunk < 1):
        raise InputError(f"chunk = {chunk!r} is out of range: allowed 1 or more")
    s = _scenario(scenario)
    c = _config(config)
    start = time.perf_counter()
    if executor is None:
        rows = _bellyflop.campaign_chunk(s, c, seed, 0, runs, threads=threads)
        workers = threads or (os.cpu_count() or 1)
    else:
        workers = _workers(executor)
        if chunk is not None:
            size = chunk
        elif workers:
            size = max(1, -(-runs // (4 * workers)))
        else:
            size = 8
        futures = [
            executor.submit(_fly_chunk, s, c, seed, r.start, r.stop)
            for r in _chunks(runs, size)
        ]
        rows = [row for f in futures for row in f.result()]
    wall_s = time.perf_counter() - start
    table = _bellyflop.campaign_table(rows, c, seed, workers, wall_s)
    return Campaign(table)


def _workers(executor: Executor) -> int:
    """The executor's worker count when it tells (0 when it does not)."""
    n = getattr(executor, "_max_workers", None)
    if isinstance(n, int) and n > 0:
        return n
    client = getattr(executor, "_client", None)  # dask's ClientExecutor
    if client is not None:
        try:
            return sum(client.nthreads().values())
        except Exception:  # noqa: BLE001 - a count is only a chunking hint
            return 0
    return 0
