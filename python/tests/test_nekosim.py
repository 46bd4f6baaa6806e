"""The nekosim package against the command line: the same scenario and seed give, through
Python, the trace `nekosim run --trace` writes (record for record), its log, its summary
figures, and positions that follow the trace's motion formulas; a Python centre of gravity
gives the Rust one's trace; bad input raises at its location.

Run by tests/integration/python_package.rs with NEKOSIM_BIN naming the command line.
"""

import json
import math
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pytest

import nekosim

ROOT = Path(__file__).resolve().parents[2]
BIN = os.environ.get("NEKOSIM_BIN", str(ROOT / "target" / "debug" / "nekosim"))

# (scenario, --until): motion, collisions, messages over a random network, a stack with
# deliveries, obstacles, Look-Compute-Move robots with and without lights.
SCENARIOS = [
    ("examples/scenarios/collision.ron", None),
    ("examples/scenarios/ask_for_help.ron", 30),
    ("examples/scenarios/abcast_lamport.ron", 15),
    ("examples/scenarios/obstacles.ron", 30),
    ("examples/lcm/cog.ron", 10),
    ("examples/lcm/viglietta_3.ron", 20),
]


def cli(scenario, tmp_path, until=None, sets=()):
    """`nekosim run` with --trace and --log: (records, log lines, stdout)."""
    trace, log = tmp_path / "t.jsonl", tmp_path / "t.log"
    cmd = [BIN, "run", str(ROOT / scenario), "--trace", str(trace), "--log", str(log)]
    if until is not None:
        cmd += ["--until", str(until)]
    for path, value in sets:
        cmd += ["--set", f"{path}={value}"]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True)
    records = [json.loads(line) for line in trace.read_text().splitlines()]
    return records, log.read_text().splitlines(), out.stdout


MISSING = object()


def plain(v):
    """A DataFrame cell as plain Python (MISSING for a null), for comparing with JSON."""
    if v is None or v is pd.NA or (isinstance(v, float) and math.isnan(v)):
        return MISSING
    if isinstance(v, np.ndarray) or isinstance(v, list):
        return [plain(x) for x in v]
    if isinstance(v, dict):
        return {k: plain(x) for k, x in v.items() if plain(x) is not MISSING}
    if isinstance(v, np.generic):
        return v.item()
    return v


def same(cell, value):
    """Whether DataFrame cell `cell` holds JSON value `value`."""
    cell = plain(cell)
    if isinstance(value, dict):
        value = {k: x for k, x in value.items() if x is not None}
    if value is None:
        return cell is MISSING
    if isinstance(cell, str) and not isinstance(value, str):
        # A column whose values mix kinds holds each value's JSON text.
        return json.loads(cell) == value
    if isinstance(value, list) and isinstance(cell, list):
        return len(cell) == len(value) and all(same(c, v) for c, v in zip(cell, value))
    if isinstance(value, dict) and isinstance(cell, dict):
        return cell.keys() == value.keys() and all(same(cell[k], value[k]) for k in value)
    return cell == value and type(cell) is not bool or cell is value


@pytest.mark.parametrize("scenario,until", SCENARIOS)
def test_trace_dataframe_equals_the_jsonl_trace_record_for_record(scenario, until, tmp_path):
    records, log, _ = cli(scenario, tmp_path, until)
    run = nekosim.Scenario.load(ROOT / scenario).run(until=until)
    df = run.trace
    assert len(df) == len(records) == len(run)
    assert list(df.columns[:3]) == ["t", "seq", "kind"]
    assert df["seq"].dtype == "Int64" and df["t"].dtype == "float64"
    fields = set()
    for i, rec in enumerate(records):
        row = df.iloc[i]
        for k, v in rec.items():
            fields.add(k)
            assert same(row[k], v), f"{scenario} record {i} field {k}: {row[k]!r} != {v!r}"
        for k in df.columns:
            if k not in rec:
                assert plain(row[k]) is MISSING, f"{scenario} record {i}: {k} = {row[k]!r}"
    assert fields == set(df.columns)
    assert run.log == log


# Scenarios that make the record kinds SCENARIOS do not: sensors outside Look-Compute-Move,
# crashes with and without a motion, decisions, deliveries over a stack with crashes.
MORE_KINDS = [
    ("examples/scenarios/crossing.ron", 30),
    ("examples/scenarios/gathering.ron", 30),
    ("examples/scenarios/meeting_point.ron", None),
    ("examples/scenarios/consensus_abcast.ron", None),
    ("examples/scenarios/path_reservation.ron", 30),
]

# The trace's record kinds that no example scenario makes (failure detector indications
# reach only algorithms written for them).
NOT_IN_EXAMPLES = {"suspect", "trust", "leader"}


def test_every_record_kind_has_the_jsonl_fields_in_its_columns(tmp_path):
    """Each record kind the examples make, field by field against the JSONL trace; every kind
    docs/trace.md lists for a run is among them but for NOT_IN_EXAMPLES."""
    kinds = set()
    for scenario, until in SCENARIOS + MORE_KINDS:
        records, log, _ = cli(scenario, tmp_path, until)
        run = nekosim.Scenario.load(ROOT / scenario).run(until=until)
        df = run.trace
        assert len(df) == len(records)
        assert df["kind"].tolist() == [r["kind"] for r in records]
        for kind in sorted({r["kind"] for r in records} - kinds):
            kinds.add(kind)
            rows = [i for i, r in enumerate(records) if r["kind"] == kind]
            fields = {k for i in rows for k in records[i]}
            for i in rows:
                row = df.iloc[i]
                for k in fields:
                    v = records[i].get(k)
                    assert same(row[k], v), f"{scenario} {kind} {i} {k}: {row[k]!r} != {v!r}"
        assert run.log == log
    # The first cell of each row of the tables under "Kinds" (a run's kinds; the model
    # checker's own come after).
    text = (ROOT / "docs/trace.md").read_text()
    tables = text.split("\n## Kinds\n")[1].split("\n## ")[0]
    documented = {k for line in tables.splitlines() if line.startswith("| `")
                  for k in re.findall(r"`([a-z_]+)`", line.split("|")[1])}
    assert "spawn" in documented and "look" in documented
    assert documented - NOT_IN_EXAMPLES <= kinds, documented - NOT_IN_EXAMPLES - kinds


def test_arrays_in_the_trace_are_typed_columns(tmp_path):
    """Positions are Arrow lists of float64 (no Python object per cell); their elements read
    as a column of their own."""
    records, _, _ = cli("examples/scenarios/collision.ron", tmp_path)
    df = nekosim.Scenario.load(ROOT / "examples/scenarios/collision.ron").run().trace
    assert df["pos"].dtype == pd.ArrowDtype(pa.list_(pa.float64()))
    xs = df["pos"].list[0]
    assert xs.tolist() == [r["pos"][0] if "pos" in r else pd.NA for r in records]
    assert df["pos"].iloc[0] == records[0]["pos"]


def test_summary_gives_the_printed_figures(tmp_path):
    _, _, out = cli("examples/scenarios/ask_for_help.ron", tmp_path, 30)
    s = nekosim.Scenario.load(ROOT / "examples/scenarios/ask_for_help.ron").run(until=30).summary
    line = next(l for l in out.splitlines() if l.startswith("robots: "))
    printed = dict(part.split(": ") for part in line.split(", "))
    assert int(printed["robots"]) == s["robots"]
    assert int(printed["events"]) == s["events"]
    assert int(printed["collisions"]) == s["collisions"]
    assert int(printed["cancelled events"]) == s["cancelled"]
    assert printed["simulated time"] == f"{s['end_time']:.3f} s"
    assert s["counts"]["sent"] > 0


def test_set_edits_as_the_command_line_does(tmp_path):
    records, _, _ = cli("examples/scenarios/random_movement.ron", tmp_path, 5,
                        [("robots[0].count", 7), ("world.size", "Infinite")])
    sc = nekosim.Scenario.load(ROOT / "examples/scenarios/random_movement.ron")
    sc.set("robots[0].count", 7).set("world.size", "Infinite")
    run = sc.run(until=5)
    assert run.summary["robots"] == 7
    assert len(run.trace) == len(records)
    assert run.trace["seq"].tolist() == [r["seq"] for r in records]
    assert run.trace["t"].tolist() == [r["t"] for r in records]


def kinematic(records):
    """Each robot's kinematic records (spawn, motion events, motion_finish, crash) in order:
    (t, pos, vel)."""
    states = {}
    for r in records:
        if r["kind"] == "spawn" or "vel" in r or r["kind"] in ("motion_finish", "crash"):
            if "pos" in r:
                states.setdefault(r["robot"], []).append((r["t"], r["pos"], r.get("vel", [0, 0])))
    return states


@pytest.mark.parametrize("scenario,until", [
    ("examples/scenarios/random_movement.ron", 15),
    ("examples/lcm/cog.ron", 10),
])
def test_positions_follow_the_motion_formulas_of_the_trace(scenario, until, tmp_path):
    records, _, _ = cli(scenario, tmp_path, until)
    run = nekosim.Scenario.load(ROOT / scenario).run(until=until)
    states = kinematic(records)
    checked = 0
    for robot, seq in states.items():
        for k, (t, pos, vel) in enumerate(seq):
            # At a record's instant, the last state of that instant is where the robot is.
            last = max(j for j, s in enumerate(seq) if s[0] == t)
            at = run.positions(t).loc[robot]
            assert (at["x"], at["y"]) == tuple(seq[last][1]), (robot, t)
            # Between two records, the straight line of the earlier one (docs/trace.md).
            if k + 1 < len(seq) and seq[k + 1][0] > t and k == last:
                mid = (t + seq[k + 1][0]) / 2
                at = run.positions(mid).loc[robot]
                want = (pos[0] + vel[0] * (mid - t), pos[1] + vel[1] * (mid - t))
                assert (at["x"], at["y"]) == want, (robot, mid)
                checked += 1
    assert checked > 20
    # Every robot is somewhere at the end.
    assert len(run.positions(until)) == run.summary["robots"]


class PyCog:
    """Cohen and Peleg's centre of gravity, in Python: the robot and every robot it sees,
    each point counted once per robot where multiplicity is known."""

    def compute(self, view):
        sx, sy, n = 0.0, 0.0, 1.0
        for s in view.others:
            k = s.multiplicity if isinstance(s.multiplicity, int) else 1
            sx += s.at[0] * k
            sy += s.at[1] * k
            n += k
        return nekosim.Decision(to=(sx / n, sy / n))


def frames_equal(a, b):
    a, b = a.map(repr), b.map(repr)
    assert list(a.columns) == list(b.columns)
    differ = (a != b).any(axis=1)
    assert not differ.any(), f"first difference at record {differ.idxmax()}"


@pytest.mark.parametrize("sets", [
    [],
    # Two arbiters: the engine calls compute from its own threads.
    [("arbiters", 2)],
    # Strong multiplicity detection, SSYNC, rigid moves.
    [("lcm.multiplicity", "Strong"), ("lcm.synchrony", "Ssync"), ("lcm.movement", "Rigid")],
])
def test_python_centre_of_gravity_gives_the_rust_trace(sets):
    rust = nekosim.Scenario.load(ROOT / "examples/lcm/cog.ron")
    for path, value in sets:
        rust.set(path, value)
    py = nekosim.Scenario.from_ron(rust.text.replace("CentreOfGravity()", "PyCog()"), "cog.ron")
    a = rust.run(until=15)
    b = py.run(until=15, algorithms={"PyCog": PyCog})
    assert len(a) > 1000
    frames_equal(a.trace, b.trace)
    assert a.log == b.log
    # Registered once, by an object instead of a class.
    nekosim.register("PyCog", PyCog())
    try:
        frames_equal(a.trace, py.run(until=15).trace)
    finally:
        nekosim._REGISTERED.clear()


def test_a_python_algorithm_with_lights_and_configuration():
    """A rule of two colours configured from the scenario: to the other robot's point and
    back to black."""

    class Flip:
        colours = 2

        def __init__(self, share=1.0):
            self.share = share

        def colour_name(self, light):
            return ["black", "white"][light]

        def compute(self, view):
            other = view.others[0]
            if view.light == 0:
                return nekosim.Decision(to=(other.at[0] * self.share, other.at[1] * self.share),
                                        light=1)
            return nekosim.Decision(light=0)

    text = """Scenario(name: "flip", seed: 5, until: 6.0, world: (size: Infinite, ghost_mode: true),
      lcm: (synchrony: Fsync, lights: Internal),
      robots: [Group(count: 2, radius: 0.5, born: Points([(0.0, 0.0), (10.0, 0.0)]),
                     algorithm: Flip(share: 0.5))])"""
    run = nekosim.Scenario.from_ron(text, "flip.ron").run(algorithms={"Flip": Flip})
    df = run.trace
    lights = df[df["kind"] == "light"]
    assert set(lights["light"].dropna()) <= {0, 1} and len(lights) > 2
    moves = df[df["kind"] == "move"]
    assert len(moves) > 0


def test_bad_input_raises_with_its_location(tmp_path):
    with pytest.raises(nekosim.ScenarioError) as e:
        nekosim.Scenario.from_ron(
            "Scenario(world: (size: Infinite),\n  robots: [Group(count: 2, radius: -1.0)])", "bad.ron"
        ).run()
    assert (e.value.file, e.value.line) == ("bad.ron", 2)
    assert e.value.col is not None and str(e.value).startswith(f"bad.ron:2:{e.value.col}: ")
    assert isinstance(e.value, ValueError)

    bad = tmp_path / "syntax.ron"
    bad.write_text("Scenario(\n  world: (size: Infinite),\n  robots: [Group(count: 2,, )],\n)")
    with pytest.raises(nekosim.ScenarioError) as e:
        nekosim.Scenario.load(bad)
    assert (e.value.file, e.value.line) == (str(bad), 3)

    with pytest.raises(nekosim.ScenarioError) as e:
        nekosim.Scenario.load(tmp_path / "missing.ron")
    assert e.value.line is None and "cannot read the scenario file" in str(e.value)

    sc = nekosim.Scenario.load(ROOT / "examples/scenarios/collision.ron")
    with pytest.raises(nekosim.ScenarioError, match="set robots\\[7\\].count=3: no value at"):
        sc.set("robots[7].count", 3)
    with pytest.raises(nekosim.ScenarioError) as e:
        sc.copy().set("until", -5.0).run()
    assert e.value.line is not None

    # An algorithm nobody registered: located at its name in the scenario.
    text = "Scenario(world: (size: Infinite),\n  robots: [Group(count: 2, radius: 1.0, algorithm: Nobody())])"
    with pytest.raises(nekosim.ScenarioError) as e:
        nekosim.Scenario.from_ron(text, "n.ron").run()
    col = text.splitlines()[1].index("Nobody") + 1
    assert (e.value.line, e.value.col) == (2, col), str(e.value)


def test_errors_of_a_python_algorithm_end_the_run_and_raise():
    text = (ROOT / "examples/lcm/cog.ron").read_text().replace("CentreOfGravity()", "Bad()")
    sc = nekosim.Scenario.from_ron(text, "cog.ron")

    class Raises:
        def compute(self, view):
            return 1 / 0

    class Wrong:
        def compute(self, view):
            return (1.0, 2.0)

    with pytest.raises(ZeroDivisionError):
        sc.run(until=5, algorithms={"Bad": Raises})
    with pytest.raises(TypeError, match="expected a nekosim.Decision"):
        sc.run(until=5, algorithms={"Bad": Wrong})
    with pytest.raises(nekosim.ScenarioError, match="Bad"):
        nekosim.Scenario.from_ron(text.replace("Bad()", "Bad(speed: 3)"), "cog.ron").run(
            algorithms={"Bad": Raises})


def test_a_run_records_itself(tmp_path):
    run = nekosim.Scenario.load(ROOT / "examples/scenarios/collision.ron").run()
    again = run.record(tmp_path / "run.rrd")
    assert (tmp_path / "run.rrd").stat().st_size > 10_000
    assert again.summary["events"] == run.summary["events"]


def test_a_run_and_a_counterexample_show_in_rerun_notebook_viewer(tmp_path, monkeypatch):
    """``show`` hands the run's recording to Rerun's notebook widget, which holds it until
    a notebook's browser side connects; without the widget's package it says what to
    install."""
    from rerun_notebook import Viewer

    run = nekosim.Scenario.load(ROOT / "examples/scenarios/collision.ron").run()
    run.record(tmp_path / "run.rrd")
    recorded = (tmp_path / "run.rrd").read_bytes()
    viewer = run.show(width=640, height=360)
    assert isinstance(viewer, Viewer)
    [(event, [data])] = viewer._event_queue
    assert event == {"type": "rrd"}
    # The same run recorded again: the same size, only ids and clocks differ.
    assert data[:4] == b"RRF2" and len(data) == len(recorded)

    c = nekosim.check(ROOT / "tests/check/sequencer_on_lossy.ron")
    [(event, [data])] = c.show()._event_queue
    assert event == {"type": "rrd"} and data[:4] == b"RRF2" and len(data) > 1000

    monkeypatch.setitem(sys.modules, "rerun_notebook", None)
    with pytest.raises(ImportError, match="rerun-notebook==0.36.3"):
        run.show()
