"""The Python package's overhead (docs/performance.md, "From Python").

1. A run from Python with its trace as a DataFrame against the command line writing the
   JSONL trace: random movement, 1,000 robots (`--set robots[0].count=1000`).
2. A Look-Compute-Move algorithm over 1,000 robots written in Python (centre of gravity)
   against the same algorithm in Rust (`CentreOfGravity`), both run from Python so that
   only the algorithm differs.

The first is timed in pairs: each repetition runs the command line and the run from Python
one after the other, in turn first, so that both see the same load; the figures are medians
over REPS pairs (the ratio is the median of the pairs' ratios). The second is the median of
REPS repetitions of each. Usage, with the package installed (build it with `--release` for
figures worth recording) and the matching command line, pinned to one core:

    taskset -c 1 python python/bench/overhead.py --nekosim target/release/nekosim \
        [--reps 5] [--until 60 600 3000] [--no-cog]
"""

import argparse
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import nekosim

ROOT = Path(__file__).resolve().parents[2]
RANDOM = ROOT / "examples/scenarios/random_movement.ron"
COG = ROOT / "examples/lcm/cog.ron"
SETS = {"robots[0].count": 1000, "world.size": "Bounded(width: 2530.0, height: 2530.0)"}


class PyCog:
    """Cohen and Peleg's centre of gravity, as `CentreOfGravity`."""

    def compute(self, view):
        sx, sy, n = 0.0, 0.0, 1.0
        for s in view.others:
            k = s.multiplicity if isinstance(s.multiplicity, int) else 1
            sx, sy, n = sx + s.at[0] * k, sy + s.at[1] * k, n + k
        return nekosim.Decision(to=(sx / n, sy / n))


def median_time(reps, f):
    times = []
    for _ in range(reps):
        start = time.perf_counter()
        f()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def trace_overhead(nekosim_bin, until, reps):
    """Paired runs of random movement to `until`: the command line writing the JSONL trace,
    and the run from Python with its trace as a DataFrame."""
    sc = nekosim.Scenario.load(RANDOM)
    for k, v in SETS.items():
        sc.set(k, v)
    cli, py, run_only, frame, ratios = [], [], [], [], []
    records = None
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [nekosim_bin, "run", str(RANDOM), "--until", str(until),
               "--trace", f"{tmp}/t.jsonl"]
        for k, v in SETS.items():
            cmd += ["--set", f"{k}={v}"]

        def command_line():
            start = time.perf_counter()
            subprocess.run(cmd, check=True, capture_output=True)
            cli.append(time.perf_counter() - start)

        def from_python():
            nonlocal records
            start = time.perf_counter()
            run = sc.run(until=until)
            ran = time.perf_counter()
            records = len(run.trace)
            end = time.perf_counter()
            py.append(end - start)
            run_only.append(ran - start)
            frame.append(end - ran)

        for r in range(reps):
            for f in (command_line, from_python) if r % 2 == 0 else (from_python, command_line):
                f()
            ratios.append(py[-1] / cli[-1])
    m = statistics.median
    print(f"run + trace to {until:g} s, {records} records: command line (JSONL) {m(cli):.3f} s, "
          f"Python (DataFrame) {m(py):.3f} s (run {m(run_only):.3f} s, DataFrame "
          f"{m(frame):.3f} s): {m(ratios):.2f}x (pairs {min(ratios):.2f}-{max(ratios):.2f}x; "
          f"goal <= 1.2x)")


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nekosim", default=str(ROOT / "target/release/nekosim"))
    p.add_argument("--reps", type=int, default=5)
    p.add_argument("--until", type=float, nargs="+", default=[60.0])
    p.add_argument("--cog-until", type=float, default=5.0)
    p.add_argument("--no-cog", action="store_true", help="only the first figure")
    a = p.parse_args()

    for until in a.until:
        trace_overhead(a.nekosim, until, a.reps)
    if a.no_cog:
        return

    text = COG.read_text().replace("count: 20", "count: 1000")
    text = text.replace("width: 200.0, height: 200.0", "width: 2000.0, height: 2000.0")
    rust = nekosim.Scenario.from_ron(text, "cog.ron")
    python = nekosim.Scenario.from_ron(text.replace("CentreOfGravity()", "PyCog()"), "cog.ron")
    events = {}

    def go(sc, key, **kw):
        run = sc.run(until=a.cog_until, **kw)
        events[key] = run.summary["events"]

    t_rust = median_time(a.reps, lambda: go(rust, "rust"))
    t_py = median_time(a.reps, lambda: go(python, "python", algorithms={"PyCog": PyCog}))
    assert events["rust"] == events["python"], events
    print(f"centre of gravity, 1000 robots, {events['rust']} events: Rust {t_rust:.3f} s, "
          f"Python {t_py:.3f} s: Python at {t_rust / t_py:.2f} of Rust's speed (goal >= 0.10)")


if __name__ == "__main__":
    main()
