"""Checks from Python against `nekosim check`: the same model and options give the verdicts
and state counts the command reports, and a counterexample DataFrame that equals the
`--trace` JSONL record for record; a bad scenario raises at its location.

Run by tests/integration/python_package.rs with NEKOSIM_BIN naming the command line.
"""

import json
import os
import re
import subprocess
from pathlib import Path

import pytest

import nekosim
from test_nekosim import MISSING, plain, same

ROOT = Path(__file__).resolve().parents[2]
BIN = os.environ.get("NEKOSIM_BIN", str(ROOT / "target" / "debug" / "nekosim"))
LOSSY = str(ROOT / "tests/check/sequencer_on_lossy.ron")


def cli(tmp_path, model, *args):
    """`nekosim check` with --trace: (exit code, verdict lines, state counts, records)."""
    trace = tmp_path / "check.jsonl"
    done = subprocess.run([BIN, "check", model, "--quiet", "--trace", str(trace), *args],
                          capture_output=True, text=True)
    operators = {"<>[]": "eventually always", "[]<>": "always eventually", "<>": "eventually"}

    def verdict(line):
        m = re.match(r"  (\S+)\s+ (.*?) (<>\[\]|\[\]<>|<>) \(", line)
        if m:
            return m.group(1), m.group(2), operators[m.group(3)]
        return re.match(r"  (\S+)\s+ (.*) \((\w+)\)", line).groups()

    verdicts = [verdict(l) for l in done.stdout.splitlines()
                if re.match(r"  (holds|FAILS|open) ", l)]
    m = re.search(r"^states: (\d+), unique states: (\d+), depth: (\d+),", done.stdout, re.M)
    states = dict(zip(["states", "unique_states", "depth"], map(int, m.groups())))
    records = [json.loads(l) for l in trace.read_text().splitlines()] if trace.exists() else []
    return done.returncode, verdicts, states, records


def same_records(df, records):
    assert len(df) == len(records)
    for i, rec in enumerate(records):
        row = df.iloc[i]
        for k, v in rec.items():
            assert same(row[k], v), f"record {i} field {k}: {row[k]!r} != {v!r}"
        for k in df.columns:
            if k not in rec:
                assert plain(row[k]) is MISSING, f"record {i}: {k} = {row[k]!r}"


@pytest.mark.parametrize("model,options,args,code", [
    (LOSSY, {}, [], 1),
    (LOSSY, {"keep_going": True}, ["--keep-going"], 1),
    (LOSSY, {"network": "ordered"}, ["--network", "ordered"], 0),
    ("sequencer-abcast", {"requests": 1}, ["--requests", "1"], 0),
])
def test_a_check_reports_as_the_command_line(tmp_path, model, options, args, code):
    cli_code, verdicts, states, records = cli(tmp_path, model, *args)
    c = nekosim.check(model, **options)
    assert c.code == cli_code == code and c.holds == (code == 0)
    mark = {"holds": "holds", "fails": "FAILS", "open": "open"}
    assert [(mark[v], p, e) for p, v, e in
            zip(c.verdicts.property, c.verdicts.verdict, c.verdicts.expectation)] == verdicts
    assert c.states == states
    same_records(c.counterexample, records)
    if code == 1:
        failing = c.verdicts[c.verdicts.verdict == "fails"]
        assert "uniform agreement" in list(failing.property)
        assert list(c.counterexample.kind)[:2] == ["request", "send"]
        assert (c.counterexample.kind == "drop").sum() == 2


def test_a_counterexample_records_itself(tmp_path):
    c = nekosim.check(LOSSY)
    again = c.record(tmp_path / "cx.rrd")
    assert (tmp_path / "cx.rrd").stat().st_size > 1_000
    assert list(again.verdicts.verdict) == list(c.verdicts.verdict)


def test_a_bad_check_raises_at_its_place(tmp_path):
    bad = tmp_path / "bad.ron"
    bad.write_text(Path(LOSSY).read_text().replace("Scenario(", "Scenario(\n    nonsense: 3,", 1))
    with pytest.raises(nekosim.ScenarioError) as e:
        nekosim.check(bad)
    assert e.value.file == str(bad) and e.value.line is not None
    with pytest.raises(ValueError, match="strategy"):
        nekosim.check(LOSSY, strategy="sideways")


THREE = """Scenario(seed: 11, until: 10.0, world: (size: Infinite, ghost_mode: true),
  lcm: (synchrony: Ssync, movement: NonRigid(delta: 1.0)),
  robots: [Group(count: 3, radius: 0.5,
                 born: Points([(0.0, 0.0), (40.0, 10.0), (12.0, -31.0)]),
                 algorithm: CentreOfGravity())])"""


class PyCog:
    """Cohen and Peleg's centre of gravity, in Python."""

    def __init__(self, reach=1.0):
        self.reach = reach

    def compute(self, view):
        sx, sy, n = 0.0, 0.0, 1.0
        for s in view.others:
            sx, sy, n = sx + s.at[0], sy + s.at[1], n + 1
        return nekosim.Decision(to=(self.reach * sx / n, self.reach * sy / n))


def test_a_python_algorithm_is_searched_as_the_rust_one_is(tmp_path):
    """The search runs a Python Look-Compute-Move algorithm through the hosts a run uses:
    the Python centre of gravity gives the Rust one's report, counterexample and replay, and
    a Python one that overshoots is caught growing the diameter."""
    rust_file = tmp_path / "three.ron"
    rust_file.write_text(THREE)
    py_file = tmp_path / "three_py.ron"
    py_file.write_text(THREE.replace("CentreOfGravity()", "PyCog()"))
    for goals in (["collision-free"], ["diameter-never-grows"]):
        a = nekosim.check(rust_file, depth=2, goals=goals)
        b = nekosim.check(py_file, depth=2, goals=goals, algorithms={"PyCog": PyCog})
        assert a.report == b.report
        assert a.code == b.code
        assert list(a.counterexample.columns) == list(b.counterexample.columns)
        assert a.counterexample.map(repr).equals(b.counterexample.map(repr))
    assert a.code == 0 and "holds on every schedule searched (depth 2)" in a.report
    over = nekosim.check(py_file, depth=2, goals=["diameter-never-grows"],
                         algorithms={"PyCog": Overshoot})
    assert over.code == 1, over.report
    assert "diameter never grows: fails" in over.report
    # The counterexample replays in the simulator: its trace has the rounds' Looks.
    looks = over.counterexample[over.counterexample["kind"] == "look"]
    assert len(looks) >= 1


class Overshoot(PyCog):
    """The seeded bug: four times as far as the centre of gravity."""

    def __init__(self):
        super().__init__(reach=4.0)
