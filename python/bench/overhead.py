"""The Python package's overhead (docs/performance.md, "From Python").

1. A run from Python with its trace as a DataFrame against the command line writing the
   JSONL trace: random movement, 1,000 robots (`--set robots[0].count=1000`).
2. A Look-Compute-Move algorithm over 1,000 robots written in Python (centre of gravity)
   against the same algorithm in Rust (`CentreOfGravity`), both run from Python so that
   only the algorithm differs.

Each figure is the median wall time of REPS repetitions. Usage, with the package installed
(build it with `--release` for figures worth recording) and the matching command line:

    python python/bench/overhead.py --nekosim target/release/nekosim [--reps 5]
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


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nekosim", default=str(ROOT / "target/release/nekosim"))
    p.add_argument("--reps", type=int, default=5)
    p.add_argument("--until", type=float, default=60.0)
    p.add_argument("--cog-until", type=float, default=5.0)
    a = p.parse_args()

    with tempfile.TemporaryDirectory() as tmp:
        cmd = [a.nekosim, "run", str(RANDOM), "--until", str(a.until),
               "--trace", f"{tmp}/t.jsonl"]
        for k, v in SETS.items():
            cmd += ["--set", f"{k}={v}"]
        cli = median_time(a.reps, lambda: subprocess.run(cmd, check=True, capture_output=True))
    sc = nekosim.Scenario.load(RANDOM)
    for k, v in SETS.items():
        sc.set(k, v)
    records = []

    def from_python():
        run = sc.run(until=a.until)
        records.append(len(run.trace))

    py = median_time(a.reps, from_python)
    print(f"run + trace: command line (JSONL) {cli:.3f} s, Python (DataFrame) {py:.3f} s, "
          f"{records[-1]} records: {py / cli:.2f}x (goal <= 1.2x)")

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
