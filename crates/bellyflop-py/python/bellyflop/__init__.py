"""bellyflop: fuel-optimal flip-and-land trajectories, closed-loop landings
and Monte Carlo campaigns, from Python.

The numbers come from the Rust core crate, serialized by the same code as the
``bellyflop`` command line: ``solve(...).to_dict()`` is the object
``bellyflop solve --json`` prints, and ``montecarlo(...).runs_csv()`` the
runs.csv that ``bellyflop montecarlo --out`` writes.

- :class:`Scenario`: a landing problem (``Scenario.paper()``,
  ``Scenario.from_toml(path)``, ``Scenario.from_toml_text(text)``,
  ``Scenario.from_dict(d)``);
- :func:`solve` -> :class:`Solution` (a planar scenario) or
  :class:`SixDofSolution` (a 6-DoF one, ``model = "6dof"``: the states and
  controls as numpy arrays named by the model's fields);
- :func:`sim` -> :class:`Flight` (one closed-loop landing with dispersions);
- :func:`montecarlo` -> :class:`Campaign` (many landings, on any
  ``concurrent.futures.Executor``).

Bad input raises :class:`InputError` (a ``ValueError``); a solve that does
not converge is a ``status``, not an exception; a campaign whose runs do not
all come back raises :class:`CampaignError`. Every object and exception
pickles.
"""

from __future__ import annotations

import concurrent.futures
import operator
import os
import time
from concurrent.futures import Executor
from typing import Any, Dict, List, Mapping, Optional, Sequence, Union

import numpy as np

from . import _bellyflop
from ._bellyflop import (
    CampaignTable,
    Flight,
    InputError,
    InternalError,
    Scenario,
    Section,
    SimConfig,
    SixDofSolution,
    Solution,
)

__all__ = [
    "Scenario",
    "SimConfig",
    "Solution",
    "SixDofSolution",
    "Flight",
    "Campaign",
    "CampaignTable",
    "Section",
    "InputError",
    "InternalError",
    "CampaignError",
    "solve",
    "sim",
    "montecarlo",
    "RUNS_CSV_COLUMNS",
]

#: The columns of runs.csv (and of :attr:`Campaign.columns`), in order.
RUNS_CSV_COLUMNS: List[str] = list(_bellyflop.runs_csv_columns())

#: The allowed range of each integer argument (``nodes``, ``intervals``,
#: ``runs``, ``seed``, ``run``, ``threads``): the core crate's range table.
ARGUMENT_RANGES: Dict[str, tuple] = {name: (lo, hi) for name, lo, hi in _bellyflop.argument_ranges()}


def _count(name: str, value: Any) -> int:
    """``value`` as an int within the range of argument ``name``, else
    InputError naming the argument, the value and the range."""
    lo, hi = ARGUMENT_RANGES[name]
    if isinstance(value, bool) or not hasattr(type(value), "__index__"):
        raise InputError(f"{name} = {value!r} is not an integer: allowed {lo} to {hi}")
    v = operator.index(value)
    if not lo <= v <= hi:
        raise InputError(f"{name} = {v} is out of range: allowed {lo} to {hi}")
    return v


class CampaignError(RuntimeError):
    """A campaign whose runs did not all come back once: runs missing after
    the re-submissions (:attr:`missing`), or a run that came back twice with
    different results. :attr:`campaign` holds the rows that did come back
    (a :class:`Campaign`, or None)."""

    def __init__(self, message: str, missing: Sequence[int] = (), campaign: Optional["Campaign"] = None):
        super().__init__(message)
        self.missing: List[int] = list(missing)
        self.campaign = campaign

    def __reduce__(self):
        return (type(self), (self.args[0], self.missing, self.campaign))


ScenarioLike = Union[Scenario, Mapping[str, Any], str, "os.PathLike[str]", None]
ConfigLike = Union[SimConfig, Mapping[str, Any], str, "os.PathLike[str]", None]


def _scenario(s: ScenarioLike) -> Scenario:
    """A Scenario from None (the paper's case), a Scenario, a dict, or the
    path of a TOML file."""
    if s is None:
        return Scenario.paper()
    if isinstance(s, Scenario):
        return s
    if isinstance(s, Mapping):
        return Scenario.from_dict(s)
    return Scenario.from_toml(s)


def _config(c: ConfigLike) -> SimConfig:
    """A SimConfig from None (the defaults), a SimConfig, a dict, or the
    path of a TOML file."""
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
    interpolation: Optional[str] = None,
    mesh_tolerance: Optional[float] = None,
    fast: bool = False,
) -> Union[Solution, SixDofSolution]:
    """Solve one landing problem, as ``bellyflop solve --json`` does.

    ``scenario`` is the paper's case when omitted (or a Scenario, a dict, the
    path of a TOML file; TOML text goes through ``Scenario.from_toml_text``).
    ``nodes`` (N), ``intervals`` (M), ``method``
    (``"direct"`` or ``"scvx"``) and ``formulation`` (``"exact"``,
    ``"paper"``, ``"vector"``) override the scenario; ``interpolation``
    (``"pchip"``, the default, or ``"linear"``) rebuilds the controls for the
    landing error.
    ``mesh_tolerance`` refines the mesh until every interval's relative error
    is within it (``--mesh-tolerance``; the passes are in
    ``to_dict()["refinement"]``). By default a solved answer is polished
    into controls that fly (``to_dict()["controls_flown"]``, the README's
    "The flown controls"); ``fast=True`` returns the raw collocation answer
    (``--fast``).

    A 6-DoF scenario (``model = "6dof"``, ``bellyflop init --model 6dof``)
    is solved by the 6-DoF pipeline, as ``bellyflop solve`` solves it, into
    a :class:`SixDofSolution`: ``status``, ``message``, ``tf_s``,
    ``final_mass_kg``, ``fuel_kg``, ``iterations``, ``controls_flown`` and
    ``flown`` (the check of the controls as flown; None when the solve did
    not converge), ``to_dict()`` (the ``--json`` object), the node times
    ``t_s`` and the tables ``states`` and ``controls`` as dicts of numpy
    arrays named by the model's fields (the columns of trajectory.csv).
    Only ``nodes``, ``intervals`` and ``fast`` apply to it: a ``method``
    other than ``"direct"``, a ``formulation``, an ``interpolation`` or a
    ``mesh_tolerance`` other than 0 raises :class:`InputError` naming it.

    The GIL is released while the core solves. Raises :class:`InputError`
    on bad input (integers out of range included); any other outcome is
    ``Solution.status``.
    """
    return _bellyflop.solve(
        _scenario(scenario),
        nodes=None if nodes is None else _count("nodes", nodes),
        intervals=None if intervals is None else _count("intervals", intervals),
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
    seed, run = _count("seed", seed), _count("run", run)
    return _bellyflop.sim(_scenario(scenario), _config(config), seed=seed, run=run)


def _fly_chunk(
    scenario: Scenario, config: SimConfig, seed: int, start: int, stop: int, attempt: int = 0
) -> list:
    """Fly runs ``start..stop`` on one thread (an executor's task): the
    rows as plain tuples, which pickle. ``attempt`` counts re-submissions:
    it changes nothing here, but makes a re-submitted task a new task for
    executors that name tasks by their arguments (Dask's pure keys would
    otherwise hand back the lost future again)."""
    del attempt
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

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Campaign) and self._table == other._table

    def __reduce__(self):
        return (Campaign, (self._table,))

    def runs_csv(self) -> str:
        """The text of runs.csv, as ``bellyflop montecarlo --out`` writes it."""
        return self._table.runs_csv()

    def __repr__(self) -> str:
        return f"<bellyflop.Campaign {len(self)} runs, {self.summary['in_spec']} in spec>"


def _chunks(runs: Sequence[int], chunk: int) -> List[range]:
    """Consecutive runs of ``runs`` (sorted) as ranges of at most ``chunk``."""
    out: List[range] = []
    for k in runs:
        if out and out[-1].stop == k and len(out[-1]) < chunk:
            out[-1] = range(out[-1].start, k + 1)
        else:
            out.append(range(k, k + 1))
    return out


#: How often a campaign on an executor checks for Ctrl-C while it waits [s].
_POLL_S = 0.1


def montecarlo(
    runs: int,
    *,
    seed: int = 0,
    scenario: ScenarioLike = None,
    config: ConfigLike = None,
    executor: Optional[Executor] = None,
    chunk: Optional[int] = None,
    threads: int = 0,
    retries: int = 2,
) -> Campaign:
    """Fly ``runs`` dispersed closed-loop landings of campaign ``seed``.

    Each run's draw depends only on (seed, run index), as in the CLI, so the
    rows equal those of ``bellyflop montecarlo --runs N --seed S`` whatever
    runs them:

    - ``executor=None``: in this process on ``threads`` threads (0: one per
      core; never more than the runs), the GIL released;
    - ``executor=E``: any ``concurrent.futures.Executor`` (a process pool,
      Dask's ``client.get_executor()``, a Ray adapter...). The runs are cut
      into tasks of ``chunk`` runs (default: about four tasks per worker
      when the executor tells its worker count, else 8 runs).

    Every run is accounted for: each index in 0..runs must come back exactly
    once. Runs that do not (a lost worker, a failed future, a task that
    dropped rows) are submitted again, up to ``retries`` more times, then
    :class:`CampaignError` names them and keeps the rows that came back
    (``e.campaign``). A run that comes back twice is kept once when both
    rows agree (every column but the wall-clock ones), else it is a
    :class:`CampaignError`. The summary counts each run once.

    Ctrl-C (SIGINT) raises ``KeyboardInterrupt`` within a fraction of a
    second: no further run starts and the executor's outstanding futures are
    cancelled.
    """
    runs = _count("runs", runs)
    seed = _count("seed", seed)
    threads = _count("threads", threads)
    if chunk is not None and (isinstance(chunk, bool) or not isinstance(chunk, int) or chunk < 1):
        raise InputError(f"chunk = {chunk!r} is out of range: allowed 1 or more")
    if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
        raise InputError(f"retries = {retries!r} is out of range: allowed 0 or more")
    s = _scenario(scenario)
    c = _config(config)
    start = time.perf_counter()
    if executor is None:
        workers = min(threads or (os.cpu_count() or 1), runs)
        rows = _bellyflop.campaign_chunk(s, c, seed, 0, runs, threads=workers)
    else:
        workers = _workers(executor)
        if chunk is not None:
            size = chunk
        elif workers:
            size = max(1, -(-runs // (4 * workers)))
        else:
            size = 8
        rows = _gather(executor, s, c, seed, runs, size, retries, workers, start)
    wall_s = time.perf_counter() - start
    table = _bellyflop.campaign_table(rows, c, seed, workers, wall_s, runs)
    return Campaign(table)


def _gather(
    executor: Executor,
    s: Scenario,
    c: SimConfig,
    seed: int,
    runs: int,
    size: int,
    retries: int,
    workers: int,
    start: float,
) -> list:
    """Every run's row from ``executor``: the chunks submitted, the runs
    that did not come back submitted again (``retries`` times at most)."""
    rows: list = []
    todo = list(range(runs))
    lost: Optional[BaseException] = None
    for attempt in range(retries + 1):
        try:
            futures = [executor.submit(_fly_chunk, s, c, seed, r.start, r.stop, attempt) for r in _chunks(todo, size)]
        except Exception as e:  # noqa: BLE001 - a broken executor: what came back is kept
            lost = e
            break
        got, error = _wait(futures)
        if error is not None:
            lost = error
        rows, missing, conflict, message = _bellyflop.campaign_account(rows + got, runs, c)
        if conflict is not None:
            raise CampaignError(conflict, campaign=None)
        if not missing:
            return rows
        todo = missing
    rows, missing, _, message = _bellyflop.campaign_account(rows, runs, c)
    table = _bellyflop.campaign_table(rows, c, seed, workers, time.perf_counter() - start)
    how = f" (after {attempt} re-submissions" + (f"; last failure: {lost!r})" if lost else ")")
    raise CampaignError(message + how, missing, Campaign(table)) from lost


def _wait(futures: list) -> tuple:
    """The rows of every future, and the last exception of those that
    failed (lost runs, to submit again). A bad-input or internal error is
    raised as is. On Ctrl-C (or any exception here) the futures not done
    are cancelled."""
    got: list = []
    error: Optional[BaseException] = None
    pending = set(futures)
    try:
        while pending:
            done, pending = concurrent.futures.wait(
                pending, timeout=_POLL_S, return_when=concurrent.futures.FIRST_COMPLETED
            )
            for f in done:
                try:
                    got.extend(f.result())
                except (InputError, InternalError):
                    raise
                except Exception as e:  # noqa: BLE001 - a lost task: its runs go again
                    error = e
    except BaseException:
        for f in pending:
            f.cancel()
        raise
    return got, error


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
