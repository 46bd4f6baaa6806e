"""Seed-style robot algorithms written in Python: functions that call their robot's motions,
sensors and messages and block on the results. The seed's random movement written in Python
gives the Rust built-in's trace record for record; messages, sensors and virtual time behave
as the engine's records say; errors raise; a run that ends while algorithms wait ends them.

Run by tests/integration/python_package.rs.
"""

import math
from pathlib import Path

import pytest

import nekosim

ROOT = Path(__file__).resolve().parents[2]


def random_movement(robot, move_speed=(3.0, 10.0), retry=1.0):
    """Seed 5.1 as nekosim's built-in RandomMovement runs it (actors/src/algorithm.rs),
    drawing from the same stream in the same order: move speed ``min + spread * U``, turn
    speed ``min + move_speed * U``, a destination uniform over the area, and a wait of
    ``retry`` after a move that took no time."""
    (lox, loy), (hix, hiy) = robot.area
    low, spread = move_speed
    while True:
        ms = low + spread * robot.random()
        ts = low + ms * robot.random()
        u, v = robot.random(), robot.random()
        started = robot.now()
        robot.move_to((lox + (hix - lox) * u, loy + (hiy - loy) * v), ms, ts)
        if robot.now() - started < 1e-9:
            robot.sleep(retry)


def frames_equal(a, b):
    a, b = a.map(repr), b.map(repr)
    assert list(a.columns) == list(b.columns)
    differ = (a != b).any(axis=1)
    assert not differ.any(), f"first difference at record {differ.idxmax()}"


@pytest.mark.parametrize("sets", [[], [("arbiters", 2)]])
def test_python_random_movement_gives_the_rust_trace(sets):
    rust = nekosim.Scenario.load(ROOT / "examples/scenarios/random_movement.ron")
    rust.set("robots[0].count", 30)
    for path, value in sets:
        rust.set(path, value)
    py = nekosim.Scenario.from_ron(
        rust.text.replace("RandomMovement()", "PyRandom()"), "random.ron")
    a = rust.run(until=150)
    b = py.run(until=150, algorithms={"PyRandom": random_movement})
    assert a.summary["collisions"] > 10 and len(a) > 500
    frames_equal(a.trace, b.trace)
    assert a.log == b.log


SCENE = """Scenario(name: "courier", seed: 7, until: 40.0,
  world: (size: Bounded(width: 200.0, height: 200.0), origin: (0.0, 0.0)),
  network: Reliable(delay: 0.5),
  robots: [Robot(id: 0, radius: 2.0, at: (20.0, 20.0), algorithm: Boss(goal: [150.0, 60.0])),
           Robot(id: 1, radius: 2.0, at: (60.0, 20.0), algorithm: Courier())])"""


def test_messages_motions_and_sensors_block_in_virtual_time():
    seen = {}

    def boss(robot, goal):
        robot.sleep(1.25)
        seen["boss woke"] = robot.now()
        robot.send([1], {"goto": goal, "note": "fast"})
        sender, msg = robot.receive()
        seen["boss got"] = (robot.now(), sender, msg)
        seen["all"] = robot.all_positions()
        seen["view"] = robot.robots_in_view(1000.0)

    class Courier:
        def __init__(self, speed=10.0):
            self.speed = speed

        def run(self, robot):
            sender, msg = robot.receive()
            seen["courier got"] = (robot.now(), sender, msg)
            end = robot.move_to(tuple(msg["goto"]), self.speed, 90.0)
            seen["arrived"] = (robot.now(), end.outcome, end.at, robot.position())
            robot.log(f"at {end.at}")
            robot.send([sender], "done")

    run = nekosim.Scenario.from_ron(SCENE, "courier.ron").run(
        algorithms={"Boss": boss, "Courier": Courier})
    # The sleep ends at its exact instant; the message takes the network's 0.5 s.
    assert seen["boss woke"] == 1.25
    assert seen["courier got"] == (1.75, 0, {"goto": [150.0, 60.0], "note": "fast"})
    t, outcome, at, gps = seen["arrived"]
    assert outcome == "arrived" and at == (150.0, 60.0) and gps == at
    # MOVETO: a turn at 90 degrees a second, then 10 units a second over the distance.
    df = run.trace
    start_forward = df[(df["kind"] == "start_forward") & (df["robot"] == 1)]["t"].iloc[0]
    assert start_forward == pytest.approx(1.75 + math.degrees(math.atan2(40, 90)) / 90.0,
                                          rel=1e-12)
    assert t == pytest.approx(start_forward + ((150 - 60) ** 2 + 40 ** 2) ** 0.5 / 10.0,
                              rel=1e-12)
    assert seen["boss got"] == (t + 0.5, 1, "done")
    assert dict(seen["all"]) == {0: (20.0, 20.0), 1: (150.0, 60.0)}
    assert seen["view"] == [(1, (150.0, 60.0))]
    # The trace has the exchange as the engine recorded it.
    sends = df[df["kind"] == "send"]
    receives = df[df["kind"] == "receive"]
    assert list(sends["robot"]) == [0, 1] and list(receives["robot"]) == [1, 0]
    assert list(receives["t"]) == [1.75, t + 0.5]
    assert any(line.endswith("at (150.0, 60.0)") for line in run.log), run.log
    # The same scenario and seed give the same run.
    again = nekosim.Scenario.from_ron(SCENE, "courier.ron").run(
        algorithms={"Boss": boss, "Courier": Courier})
    frames_equal(run.trace, again.trace)


def test_a_run_that_ends_ends_the_algorithms_that_wait():
    ended = []

    def waits(robot):
        try:
            if robot.id == 0:
                robot.sleep(2.5)
            robot.receive()
        except Exception:  # a RunEnded is no Exception: this does not catch it
            ended.append("caught")
        except nekosim.RunEnded:
            ended.append(robot.id)
            raise

    text = """Scenario(name: "wait", until: 3.0, world: (size: Infinite),
      robots: [Group(count: 3, radius: 1.0, born: Points([(0.0, 0.0), (5.0, 0.0), (10.0, 0.0)]),
                     algorithm: Waits())])"""
    run = nekosim.Scenario.from_ron(text, "wait.ron").run(algorithms={"Waits": waits})
    # No event is left after robot 0's sleep: the run ends there, its robots still waiting.
    assert run.summary["end_time"] == 2.5
    assert sorted(ended) == [0, 1, 2]


def test_errors_of_a_seed_style_algorithm_end_the_run_and_raise():
    text = """Scenario(name: "bad", until: 30.0, world: (size: Infinite),
      robots: [Group(count: 2, radius: 1.0, born: Points([(0.0, 0.0), (5.0, 0.0)]),
                     algorithm: Bad())])"""
    sc = nekosim.Scenario.from_ron(text, "bad.ron")

    def divides(robot):
        robot.sleep(2.0)
        return 1 / 0

    def bad_speed(robot):
        robot.move_to((1.0, 1.0), -3.0, 1.0)

    with pytest.raises(ZeroDivisionError):
        sc.run(algorithms={"Bad": divides})
    with pytest.raises(ValueError, match="move_speed must be a finite number > 0"):
        sc.run(algorithms={"Bad": bad_speed})

    class NoRun:
        pass

    with pytest.raises(nekosim.ScenarioError, match="neither `compute` nor `run`"):
        sc.run(algorithms={"Bad": NoRun})
    # An unknown field of the configuration is located as the scenario's other errors are.
    with pytest.raises(nekosim.ScenarioError, match="Bad"):
        nekosim.Scenario.from_ron(text.replace("Bad()", "Bad(speed: 3)"), "bad.ron").run(
            algorithms={"Bad": divides})
