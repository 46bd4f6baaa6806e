"""Checks from Python (docs/check.md, docs/python.md): ``nekosim check`` of a scenario's
protocol stack, its verdicts and state counts, and its counterexample as a DataFrame."""

import os
import re
import tempfile
from typing import Any, Dict, Optional, Union

import pandas as pd
from . import _frame, _nekosim

# The report's lines `nekosim check` prints: "  FAILS  name (always): detail".
_VERDICT = re.compile(r"^  (holds|FAILS|open)\s+ (.*) \((always|sometimes|eventually)\)(?:: (.*))?$")
# Temporal properties checked on the whole graph: "  FAILS  name <>[] (predicate): detail".
_TEMPORAL = re.compile(r"^  (holds|FAILS|open)\s+ (.*?) (<>\[\]|\[\]<>|<>) \((.*)\)(?:: (.*))?$")
_OPERATORS = {"<>[]": "eventually always", "[]<>": "always eventually", "<>": "eventually"}
_STATES = re.compile(r"^states: (\d+), unique states: (\d+), depth: (\d+),")


class Check:
    """A finished check.

    ``verdicts``: one row per property (``property``, ``verdict`` — ``"holds"``,
    ``"fails"`` or ``"open"`` (not settled) —, ``expectation`` and ``detail``), as the
    report lists them, the temporal properties last (``expectation`` ``"eventually"``,
    ``"eventually always"`` or ``"always eventually"``, ``detail`` their predicate); ``states``: the states generated, the unique states and the depth
    reached; ``counterexample``: the records ``nekosim check --trace`` writes for the first
    counterexample (else a witness; empty when there is neither), one row per record as
    :attr:`nekosim.Run.trace` has them; ``report``: the command's report; ``code``: its
    exit code (0 every property holds, 1 one fails, 3 a budget stopped the search).
    """

    def __init__(self, core: Any, model: str, options: Dict[str, Any]) -> None:
        self._core = core
        self._model = model
        self._options = options
        self.report: str = core.report
        self.code: int = core.code
        rows = []
        self.states: Dict[str, int] = {}
        for line in self.report.splitlines():
            m = _VERDICT.match(line)
            if m:
                verdict = {"holds": "holds", "FAILS": "fails", "open": "open"}[m.group(1)]
                rows.append((m.group(2), verdict, m.group(3), m.group(4) or ""))
            m = _TEMPORAL.match(line)
            if m:
                verdict = {"holds": "holds", "FAILS": "fails", "open": "open"}[m.group(1)]
                rows.append((m.group(2), verdict, _OPERATORS[m.group(3)],
                             m.group(4) + (f": {m.group(5)}" if m.group(5) else "")))
            m = _STATES.match(line)
            if m:
                self.states = {"states": int(m.group(1)), "unique_states": int(m.group(2)),
                               "depth": int(m.group(3))}
        self.verdicts = pd.DataFrame(
            rows, columns=["property", "verdict", "expectation", "detail"])
        self.counterexample: pd.DataFrame = _frame.frame(_frame.table(core.trace()))

    @property
    def holds(self) -> bool:
        """Whether every property holds on the whole space (exit code 0)."""
        return self.code == 0

    def record(self, path: Union[str, "os.PathLike[str]"]) -> "Check":
        """Saves the counterexample (or witness) as a Rerun recording at ``path``: the same
        check again with ``rrd``; returns that check."""
        again = check(self._model, **dict(self._options, rrd=os.fspath(path)))
        if again.report.splitlines()[-len(self.verdicts):] != \
                self.report.splitlines()[-len(self.verdicts):]:
            raise RuntimeError("the check recorded did not end as this one")
        return again

    def show(self, width: Union[int, str] = "auto", height: Union[int, str] = "auto") -> Any:
        """Shows the counterexample (or witness) inline in Jupyter with Rerun's notebook
        viewer: records it (as :meth:`record` does) and returns the viewer widget. Needs
        ``rerun-notebook`` (see :meth:`nekosim.Run.show`)."""
        from . import _viewer

        with tempfile.TemporaryDirectory() as d:
            path = os.path.join(d, "check.rrd")
            self.record(path)
            return _viewer(path, width, height)

    def __repr__(self) -> str:
        failing = list(self.verdicts.property[self.verdicts.verdict == "fails"])
        return f"Check({self._model!r}, code={self.code}, fails={failing})"


def check(model: Union[str, "os.PathLike[str]"],
          algorithms: Optional[Dict[str, Any]] = None, **options: Any) -> Check:
    """Model-checks a scenario's protocol stack (a .ron file) or a shipped model (a name of
    ``nekosim check --list``) as ``nekosim check`` does; on a Look-Compute-Move scenario,
    checks its rule table or searches its algorithms' schedules (docs/model-checking.md).

    ``options`` are the command's, with underscores: ``layer``, ``processes``,
    ``requests``, ``crashes``, ``network`` (``"unordered"``, ``"ordered"``, ``"lossy"``),
    ``strategy`` (``"bfs"``, ``"dfs"``, ``"simulation"``), ``seed``, ``max_states``,
    ``max_memory`` (``"512MiB"``), ``depth``, ``threads``, ``timers``, ``rounds``,
    ``symmetry``, ``keep_going``, ``goals`` (a list of ``--goal`` values, such as
    ``"diameter-never-grows"``) and ``rrd`` (save the counterexample as a recording).
    ``algorithms`` maps names the scenario uses to Python Look-Compute-Move algorithms
    (beside those :func:`nekosim.register` registered), which the search then runs.
    A bad scenario raises :class:`nekosim.ScenarioError` at its place.
    """
    from . import _REGISTERED

    model = os.fspath(model)
    algos = dict(_REGISTERED)
    algos.update(algorithms or {})
    core = _nekosim.check_core(model, algorithms=list(algos.items()), **options)
    options = {k: v for k, v in options.items() if k != "rrd"}
    return Check(core, model, dict(options, algorithms=algorithms))
