"""Type stubs of the native module bellyflop._bellyflop (pyo3)."""

from __future__ import annotations

import os
from typing import Any, Dict, List, Mapping, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
PathLike = Union[str, "os.PathLike[str]"]

class InputError(ValueError):
    """Bad input: the message names the field, its value and the allowed range."""

class InternalError(RuntimeError):
    """A bug in bellyflop (a Rust panic, caught before it reached Python)."""

class Section:
    """A read-only table of a Scenario or SimConfig; fields as attributes."""
    def __getattr__(self, name: str) -> Any: ...
    def __getitem__(self, name: str) -> Any: ...
    def keys(self) -> List[str]: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def __eq__(self, other: object) -> bool: ...

class Scenario:
    """A landing problem, validated on construction. Its tables
    (``vehicle``, ``environment``, ``initial``, ``terminal``,
    ``discretization``, ``solver``) are attributes (:class:`Section`)."""
    name: str
    vehicle: Section
    environment: Section
    initial: Section
    terminal: Section
    discretization: Section
    solver: Section
    warnings: List[str]
    """What reading it changed: a guess given outside its range, clamped."""
    @staticmethod
    def paper() -> Scenario: ...
    @staticmethod
    def from_toml(path: PathLike) -> Scenario: ...
    @staticmethod
    def from_toml_text(text: str) -> Scenario: ...
    @staticmethod
    def from_toml_file(path: PathLike) -> Scenario: ...
    @staticmethod
    def from_dict(d: Mapping[str, Any]) -> Scenario: ...
    def to_toml(self) -> str: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def __getattr__(self, name: str) -> Any: ...

class SimConfig:
    """The closed loop's tables ``dispersions``, ``guidance``, ``plant``,
    ``touchdown``; every field optional (the defaults when built empty)."""
    dispersions: Section
    guidance: Section
    plant: Section
    touchdown: Section
    def __init__(self) -> None: ...
    @staticmethod
    def from_toml(path: PathLike) -> SimConfig: ...
    @staticmethod
    def from_toml_text(text: str) -> SimConfig: ...
    @staticmethod
    def from_toml_file(path: PathLike) -> SimConfig: ...
    @staticmethod
    def from_dict(d: Mapping[str, Any]) -> SimConfig: ...
    def to_toml(self) -> str: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def __getattr__(self, name: str) -> Any: ...

class Solution:
    """The object ``bellyflop solve --json`` prints; keys as attributes."""
    status: str
    message: str
    method: str
    formulation: str
    nodes: int
    intervals: int
    tf_s: float
    final_mass_kg: float
    fuel_kg: float
    iterations: int
    solve_time_ms: float
    t_s: FloatArray
    x_m: FloatArray
    z_m: FloatArray
    vx_mps: FloatArray
    vz_mps: FloatArray
    theta_rad: FloatArray
    pitch_rate_radps: FloatArray
    mass_kg: FloatArray
    delta_rad: FloatArray
    thrust_n: FloatArray
    gimbal_rate_radps: FloatArray
    checks: Dict[str, float]
    history: List[Dict[str, Any]]
    direct_history: List[Dict[str, Any]]
    landing_error: Optional[Dict[str, float]]
    propagation: Dict[str, Any]
    _core_ms: float
    def to_dict(self) -> Dict[str, Any]: ...
    def save_html(self, path: "os.PathLike[str] | str") -> None:
        """Write the viewer page (viewer.html of ``bellyflop solve --out``)."""
    def _repr_html_(self) -> str: ...
    def to_json(self) -> str: ...
    def __getattr__(self, name: str) -> Any: ...

class SixDofSolution:
    """The object ``bellyflop solve --json`` prints on a 6-DoF scenario;
    keys as attributes, each state and control field too (``z_m``,
    ``thrust_n``)."""
    model: str
    status: str
    message: str
    tf_s: float
    final_mass_kg: float
    fuel_kg: float
    iterations: int
    polish_iterations: Optional[int]
    solve_time_ms: float
    nodes: int
    t_s: FloatArray
    controls_flown: Optional[Dict[str, Any]]
    flown: Optional[Dict[str, Any]]
    _core_ms: float
    @property
    def states(self) -> Dict[str, FloatArray]:
        """The node states by name, N + 1 each, at ``t_s``."""
    @property
    def controls(self) -> Dict[str, FloatArray]:
        """The controls by name, N each, at ``t_s[:-1]``."""
    @property
    def units(self) -> Dict[str, str]: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def to_json(self) -> str: ...
    def __getattr__(self, name: str) -> Any: ...

class Flight:
    """The object ``bellyflop sim --json`` prints, with the flown trace."""
    seed: int
    run: int
    outcome: Dict[str, Any]
    outcome_name: str
    fuel_kg: float
    first_plan: Dict[str, Any]
    replans: List[Dict[str, Any]]
    saturation: Dict[str, Any]
    config: Dict[str, Any]
    @property
    def trace(self) -> Dict[str, FloatArray]: ...
    @property
    def row(self) -> Dict[str, Any]: ...
    def to_dict(self) -> Dict[str, Any]: ...
    def save_html(self, path: "os.PathLike[str] | str") -> None:
        """Write the viewer page (viewer.html of ``bellyflop sim --out``)."""
    def _repr_html_(self) -> str: ...
    def __getattr__(self, name: str) -> Any: ...

class CampaignTable:
    @property
    def summary(self) -> Dict[str, Any]: ...
    def runs_csv(self) -> str: ...
    def columns(self) -> Dict[str, Any]: ...
    def __len__(self) -> int: ...
    def __eq__(self, other: object) -> bool: ...

def solve(
    scenario: Scenario,
    nodes: Optional[int] = ...,
    intervals: Optional[int] = ...,
    method: Optional[str] = ...,
    formulation: Optional[str] = ...,
    interpolation: Optional[str] = ...,
    mesh_tolerance: Optional[float] = ...,
    fast: bool = ...,
) -> Union[Solution, SixDofSolution]: ...
def sim(scenario: Scenario, config: SimConfig, seed: int = ..., run: int = ...) -> Flight: ...
def campaign_chunk(
    scenario: Scenario, config: SimConfig, seed: int, start: int, stop: int, threads: int = ...
) -> List[Tuple[Any, ...]]: ...
def campaign_table(
    rows: Any, config: SimConfig, seed: int, threads: int, wall_s: float, runs: Optional[int] = ...
) -> CampaignTable: ...
def campaign_account(
    rows: Any, runs: int, config: SimConfig
) -> Tuple[List[Tuple[Any, ...]], List[int], Optional[str], Optional[str]]: ...
def argument_ranges() -> List[Tuple[str, int, int]]: ...
def runs_csv_columns() -> List[str]: ...
def _panic_for_tests() -> None: ...
