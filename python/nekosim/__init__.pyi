"""nekosim from Python (docs/python.md)."""

import os
from typing import Any, Dict, List, Mapping, Optional, Protocol, Union

import pandas as pd
import pyarrow as pa

from ._errors import ScenarioError as ScenarioError
from ._nekosim import Decision as Decision
from ._nekosim import MotionResult as MotionResult
from ._nekosim import RobotHandle as Robot
from ._nekosim import RunEnded as RunEnded
from ._nekosim import Seen as Seen
from ._nekosim import View as View

_Path = Union[str, "os.PathLike[str]"]

class LookComputeMove(Protocol):
    """What a Python Look-Compute-Move algorithm provides (``colours`` and
    ``colour_name`` are optional)."""
    def compute(self, view: View) -> Decision: ...

class SeedStyle(Protocol):
    """A seed-style algorithm's class: ``run`` calls the robot and blocks on each call.
    A plain function ``algorithm(robot, **config)`` does as well."""
    def run(self, robot: Robot) -> None: ...

def register(name: str, algorithm: Any) -> None:
    """Registers a Python algorithm under ``name`` for every run: a Look-Compute-Move one
    (a class or an object with ``compute``) or a seed-style one (a function, or a class or
    object with ``run``)."""

def registered() -> Dict[str, Any]: ...

class Run:
    @property
    def summary(self) -> Dict[str, Any]:
        """The figures ``nekosim run`` prints."""
    @property
    def log(self) -> List[str]:
        """The Neko log's lines."""
    @property
    def trace_table(self) -> pa.Table:
        """The trace as an Arrow table."""
    @property
    def trace(self) -> pd.DataFrame:
        """The trace: one row per record, one typed column per field."""
    def positions(self, t: float) -> pd.DataFrame:
        """Exact positions at simulated time ``t``, indexed by robot, columns x and y."""
    def show(self, width: Union[int, str] = "auto", height: Union[int, str] = "auto") -> Any:
        """The run in Rerun's notebook viewer (needs ``rerun-notebook``)."""
    def record(self, path: _Path) -> "Run":
        """Saves the run as a Rerun recording (the same run again)."""
    def __len__(self) -> int: ...

class Scenario:
    @classmethod
    def load(cls, path: _Path) -> "Scenario": ...
    @classmethod
    def from_ron(cls, text: str, name: str = "<string>") -> "Scenario": ...
    def set(self, path: str, value: Union[int, float, bool, str, None]) -> "Scenario":
        """Sets a value by its ``--set`` path; a string is RON text."""
    def copy(self) -> "Scenario": ...
    @property
    def text(self) -> str: ...
    @property
    def file(self) -> str: ...
    @property
    def name(self) -> str: ...
    @property
    def seed(self) -> int: ...
    def run(self, seed: Optional[int] = None, until: Optional[float] = None,
            algorithms: Optional[Mapping[str, Any]] = None,
            rrd: Optional[_Path] = None) -> Run: ...

class SweepResult:
    """The runs.csv and summary.csv of ``nekosim sweep`` as DataFrames and as text."""

    runs: pd.DataFrame
    summary: pd.DataFrame
    runs_csv: str
    summary_csv: str
    @property
    def failing(self) -> pd.DataFrame: ...
    def __iter__(self) -> Any: ...

def sweep(
    sweep: Union[str, "os.PathLike[str]"],
    jobs: Optional[int] = None,
    client: Any = None,
    tasks: Optional[int] = None,
    base: Optional[Union[str, "os.PathLike[str]"]] = None,
) -> SweepResult:
    """Runs a sweep file (or sweep text) as ``nekosim sweep`` does, here ``jobs`` at a
    time or on a Dask ``client``; returns its runs and summary tables."""

class Check:
    """A finished ``nekosim check``: verdicts, state counts, counterexample records."""

    report: str
    code: int
    states: Dict[str, int]
    verdicts: pd.DataFrame
    counterexample: pd.DataFrame
    @property
    def holds(self) -> bool: ...
    def record(self, path: Union[str, "os.PathLike[str]"]) -> "Check": ...
    def show(self, width: Union[int, str] = "auto", height: Union[int, str] = "auto") -> Any:
        """The counterexample in Rerun's notebook viewer (needs ``rerun-notebook``)."""

def check(model: Union[str, "os.PathLike[str]"],
          algorithms: Optional[Mapping[str, Any]] = None, **options: Any) -> Check:
    """Model-checks a scenario's protocol stack or a shipped model as ``nekosim check``
    does; ``options`` are the command's, with underscores."""
