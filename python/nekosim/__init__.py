"""nekosim from Python: load, edit and run scenarios, read their traces as pandas
DataFrames, and write robot algorithms in Python: Look-Compute-Move ones, and seed-style
ones that block on their robot's motions, sensors and messages (docs/python.md).

>>> import nekosim
>>> run = nekosim.Scenario.load("examples/lcm/cog.ron").run(seed=3, until=10)
>>> run.summary["events"]  # doctest: +SKIP
>>> run.trace.head()       # doctest: +SKIP
"""

import os
import tempfile
from typing import Any, Dict, List, Mapping, Optional, Union

import pandas as pd
import pyarrow as pa

from . import _frame, _nekosim
from ._errors import ScenarioError
from ._nekosim import Decision, MotionResult, RunEnded, Seen, View
from ._nekosim import RobotHandle as Robot
from ._check import Check, check
from ._sweep import SweepResult, sweep

__all__ = [
    "Check",
    "Decision",
    "MotionResult",
    "Robot",
    "Run",
    "RunEnded",
    "Scenario",
    "ScenarioError",
    "Seen",
    "SweepResult",
    "View",
    "check",
    "register",
    "registered",
    "sweep",
]

_REGISTERED: Dict[str, Any] = {}


def register(name: str, algorithm: Any) -> None:
    """Registers a Python robot algorithm under ``name`` for every run.

    A **Look-Compute-Move** algorithm is a class, built with the scenario's configuration
    as keyword arguments (``algorithm: Name(step: 0.5)`` calls ``Class(step=0.5)``), or an
    object (then the scenario names it with no configuration). It has
    ``compute(self, view: View) -> Decision``, and optionally ``colours`` (how many
    colours its lights take, default 1) and ``colour_name(self, light) -> str``.

    A **seed-style** algorithm is a function ``algorithm(robot: Robot, **config)``, or a
    class built from the configuration whose ``run(self, robot: Robot)`` does the work.
    It calls the robot (``robot.move_to(...)``, ``robot.sleep(...)``,
    ``robot.all_positions()``, ``robot.send(...)``, ``robot.receive()``, ...), and each call
    returns when its result is there in virtual time, as the seed's Java algorithms do.
    """
    _REGISTERED[name] = algorithm


def registered() -> Dict[str, Any]:
    """The algorithms :func:`register` registered, by name."""
    return dict(_REGISTERED)


def _viewer(rrd: str, width: Union[int, str], height: Union[int, str]) -> Any:
    """Rerun's notebook viewer widget holding the recording at ``rrd``."""
    try:
        from rerun_notebook import Viewer
    except ImportError as e:
        raise ImportError(
            "showing a run inline needs Rerun's notebook viewer: "
            'pip install "rerun-notebook==0.36.3"') from e
    with open(rrd, "rb") as f:
        data = f.read()
    viewer = Viewer(width=width, height=height)
    viewer.send_rrd(data)
    return viewer


class Run:
    """A finished run: its summary, trace, log and trajectories."""

    def __init__(self, core: Any, scenario: "Scenario", seed: Optional[int],
                 until: Optional[float], algorithms: Dict[str, Any]) -> None:
        self._core = core
        self._scenario = scenario
        self._seed = seed
        self._until = until
        self._algorithms = algorithms
        self._table: Optional[pa.Table] = None
        self._trace: Optional[pd.DataFrame] = None

    @property
    def summary(self) -> Dict[str, Any]:
        """The figures ``nekosim run`` prints: name, seed, robots, events, cancelled,
        collisions, end_time, wall_seconds, events_per_second, interrupted, counts (a dict),
        latency (a dict or None) and predicates (their report lines)."""
        return self._core.summary

    @property
    def log(self) -> List[str]:
        """The Neko log's lines, as ``nekosim run --log`` writes them."""
        return self._core.log

    @property
    def trace_table(self) -> pa.Table:
        """The trace as an Arrow table: one row per record, one column per field."""
        if self._table is None:
            self._table = _frame.table(self._core.trace())
        return self._table

    @property
    def trace(self) -> pd.DataFrame:
        """The trace as a DataFrame: one row per record of ``nekosim run --trace``, one
        column per field (docs/trace.md), null where a record has no such field. Arrays
        (``pos``, ``vel``, ...) and nested values are Arrow-backed columns
        (``pandas.ArrowDtype``) whose cells read as lists and dicts."""
        if self._trace is None:
            self._trace = _frame.frame(self.trace_table)
        return self._trace

    def positions(self, t: float) -> pd.DataFrame:
        """Every robot's exact position at simulated time ``t`` (from the motion formulas:
        the last kinematic state at or before ``t``, moved on at its velocity), indexed
        by robot id, with columns ``x`` and ``y``."""
        robots, xs, ys = self._core.positions(float(t))
        return pd.DataFrame(
            {"x": pd.Series(xs, dtype="float64"), "y": pd.Series(ys, dtype="float64")},
            index=pd.Index(robots, name="robot", dtype="int64"),
        )

    def record(self, path: Union[str, "os.PathLike[str]"]) -> "Run":
        """Saves the run as a Rerun recording at ``path``: the same run again (same
        scenario, seed and algorithms) with its recording; returns that run."""
        again = self._scenario.run(seed=self._seed, until=self._until,
                                   algorithms=self._algorithms, rrd=path)
        if len(again) != len(self):
            raise RuntimeError(
                f"the run recorded made {len(again)} records, not {len(self)}: "
                "an algorithm is not deterministic")
        return again

    def show(self, width: Union[int, str] = "auto", height: Union[int, str] = "auto") -> Any:
        """Shows the run inline in Jupyter with Rerun's notebook viewer: records it (as
        :meth:`record` does, to a temporary file) and returns the viewer widget holding the
        recording; a notebook displays it as a cell's value. Needs ``rerun-notebook``
        (``pip install "rerun-notebook==0.36.3"``, the Rerun version nekosim writes)."""
        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "run.rrd")
            self.record(path)
            return _viewer(path, width, height)

    def __len__(self) -> int:
        return len(self._core)

    def __repr__(self) -> str:
        s = self.summary
        return (f"Run({s['name']!r}, seed={s['seed']}, robots={s['robots']}, "
                f"events={s['events']}, end_time={s['end_time']:.3f})")


class Scenario:
    """A scenario file (docs/scenario.md), checked when loaded and after each ``set``."""

    def __init__(self, core: Any) -> None:
        self._core = core

    @classmethod
    def load(cls, path: Union[str, "os.PathLike[str]"]) -> "Scenario":
        """Reads the scenario file at ``path``; a bad file raises :class:`ScenarioError`
        at its FILE:LINE:COL."""
        return cls(_nekosim.Scenario.load(os.fspath(path)))

    @classmethod
    def from_ron(cls, text: str, name: str = "<string>") -> "Scenario":
        """Reads scenario text; ``name`` names it in errors."""
        return cls(_nekosim.Scenario.from_ron(text, name))

    def set(self, path: str, value: Any) -> "Scenario":
        """Sets the value at ``path`` as ``nekosim run --set PATH=VALUE`` does
        (``"robots[0].count"``, ``"network.lambda"``); numbers, booleans and None are
        converted, a string is RON text (``"Infinite"``, ``'"a name"'``). Returns the
        scenario."""
        self._core.set(path, value)
        return self

    def copy(self) -> "Scenario":
        """An independent copy (``set`` on one leaves the other as it is)."""
        return Scenario.from_ron(self.text, self.file)

    @property
    def text(self) -> str:
        """The scenario's RON text, with every ``set`` applied."""
        return self._core.text

    @property
    def file(self) -> str:
        """The file's name in errors."""
        return self._core.file

    @property
    def name(self) -> str:
        """The scenario's name."""
        return self._core.name

    @property
    def seed(self) -> int:
        """The scenario's seed."""
        return self._core.seed

    def run(self, seed: Optional[int] = None, until: Optional[float] = None,
            algorithms: Optional[Mapping[str, Any]] = None,
            rrd: Optional[Union[str, "os.PathLike[str]"]] = None) -> Run:
        """Runs the scenario as ``nekosim run`` does.

        ``seed`` and ``until`` override the file's; ``algorithms`` maps names the scenario
        uses to Python algorithms (beside those :func:`register` registered; see there);
        ``rrd`` also saves a Rerun recording. An exception raised by an algorithm ends the
        run and is raised here. When the run ends, a seed-style algorithm still waiting for
        a call gets :class:`RunEnded` (not an ``Exception``) raised in its thread.
        """
        algos = dict(_REGISTERED)
        algos.update(algorithms or {})
        core = self._core.run_core(
            seed=seed,
            until=None if until is None else float(until),
            algorithms=list(algos.items()),
            rrd=None if rrd is None else os.fspath(rrd),
        )
        return Run(core, self.copy(), seed, until, algos)

    def __repr__(self) -> str:
        return f"Scenario({self.name!r}, file={self.file!r})"
