"""Sweeps from Python (docs/sweeps.md, docs/python.md): the runs of a sweep file, here or
on a Dask cluster, and its runs and summary tables as DataFrames."""

import io
import os
from typing import Any, List, Optional, Tuple, Union

import pandas as pd

from . import _nekosim

PathLike = Union[str, "os.PathLike[str]"]
_Row = Tuple[int, List[Optional[float]], Optional[str]]


class SweepResult:
    """A finished sweep: ``runs`` and ``summary`` are the DataFrames of the runs.csv and
    summary.csv that ``nekosim sweep SWEEP --out DIR`` writes (as ``pandas.read_csv``
    reads them); ``runs_csv`` and ``summary_csv`` are those files' very texts."""

    def __init__(self, runs_csv: str, summary_csv: str) -> None:
        self.runs_csv = runs_csv
        self.summary_csv = summary_csv
        self.runs = pd.read_csv(io.StringIO(runs_csv))
        self.summary = pd.read_csv(io.StringIO(summary_csv))

    @property
    def failing(self) -> pd.DataFrame:
        """The runs that ended with an error or failed a check."""
        return self.runs[~self.runs["ok"]]

    def __iter__(self):
        # `runs, summary = nekosim.sweep(...)`
        return iter((self.runs, self.summary))

    def __repr__(self) -> str:
        return (f"SweepResult({len(self.runs)} runs, {len(self.summary)} points, "
                f"{len(self.failing)} failing)")


def _spec(sweep: Union[PathLike, str], base: Optional[PathLike]) -> Tuple[str, ...]:
    """How a worker loads the sweep: ("path", absolute path) or ("text", text, name,
    where it stands)."""
    if isinstance(sweep, os.PathLike) or ("\n" not in sweep and "(" not in sweep):
        return ("path", os.path.abspath(os.fspath(sweep)))
    where = os.path.abspath(os.path.join(os.fspath(base or "."), "<string>"))
    return ("text", sweep, "<string>", where)


def _load(spec: Tuple[str, ...]) -> Any:
    if spec[0] == "path":
        return _nekosim.SweepCore.load(spec[1])
    return _nekosim.SweepCore.parse(spec[1], spec[2], spec[3])


def _run_part(spec: Tuple[str, ...], index: int, count: int) -> List[_Row]:
    """A Dask task: the runs of the sweep whose number is ``index`` modulo ``count``."""
    return _load(spec).execute(jobs=1, shard=(index, count))


def sweep(sweep: Union[PathLike, str], jobs: Optional[int] = None, client: Any = None,
          tasks: Optional[int] = None, base: Optional[PathLike] = None) -> SweepResult:
    """Runs a sweep as ``nekosim sweep`` does and returns its tables.

    ``sweep`` is a sweep file's path, or sweep text (its ``scenario`` is then relative to
    ``base``, by default the working directory). A bad sweep raises
    :class:`nekosim.ScenarioError` at its FILE:LINE:COL before any run.

    Without ``client`` the runs run here, ``jobs`` at a time (default: the machine's
    cores). With a Dask ``distributed.Client`` they run on its workers as ``tasks`` tasks
    (default: one per run), task I running the runs whose number is I modulo ``tasks``;
    the workers must see the sweep and its scenario at the same paths and have this
    package installed. Either way the tables are the same, in run order.
    """
    spec = _spec(sweep, base)
    core = _load(spec)
    if client is None:
        rows = core.execute(jobs=jobs or os.cpu_count() or 1)
    else:
        count = max(1, min(tasks or core.runs, core.runs))
        futures = client.map(_run_part, [spec] * count, range(count), [count] * count,
                             pure=False)
        rows = [row for part in client.gather(futures) for row in part]
    runs, summary = core.tables(rows)
    return SweepResult(runs.decode(), summary.decode())
