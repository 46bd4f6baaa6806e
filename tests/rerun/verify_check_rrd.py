"""Checks a `nekosim check --rrd` counterexample recording with the official Rerun reader
(rerun-sdk 0.36.3), against the JSONL trace `nekosim check --trace` wrote for the same path.

Usage: verify_check_rrd.py RECORDING.rrd TRACE.jsonl PROPERTY PROCESSES

Checks that `rerun rrd verify` accepts the file; it has the `sim_time` and `event` timelines;
process p stands on its lane, (10 p, 0), at every step; every `send` of the trace has an arrow
per receiver at its step; a crashed process is grey from its crash on; the text log has one
line per lane's birth and per trace record plus the verdict naming PROPERTY, at the start and
at the end, an ERROR for a counterexample and INFO for a witness; the default blueprint is
the layout of `nekosim run` recordings (verify_rrd.py) with message plots only, the
space-time diagram (every receive an arrow between the lanes, labelled with the whole message)
and the verdict document stating the property in full.
Prints one summary line and exits 0, or prints what differs and exits 1.
"""

from __future__ import annotations

import sys
from pathlib import Path

from verify_rrd import (
    TOLERANCE,
    Rows,
    check_blueprint,
    check_crashes_grey,
    check_sends,
    check_spacetime,
    fail,
    group,
    load_trace,
    ns,
    rrd_verify,
)

LANE = 10.0


def main() -> None:
    if len(sys.argv) != 5:
        fail(__doc__)
    rrd, trace_path = Path(sys.argv[1]), Path(sys.argv[2])
    prop, processes = sys.argv[3], int(sys.argv[4])
    rrd_verify(rrd)

    trace = load_trace(trace_path)
    rows = Rows(rrd)
    for timeline in ("sim_time", "event"):
        if timeline not in rows.timelines:
            fail(f"timeline {timeline} missing; have {sorted(rows.timelines)}")

    steps = int(trace[-1]["seq"])
    # Each lane is drawn where it stands at every step, and its exact pose is there.
    for p in range(processes):
        name, j = group(p)
        entity = f"/world/robots/{name}"
        for step in range(steps + 1):
            drawn = rows.latest_at(entity, "Points2D:positions", ns(step))
            if drawn is None or len(drawn) <= j:
                fail(f"{entity}: no marker of process {p} at step {step}")
            x, y = drawn[j]
            if abs(x - LANE * p) > 1e-4 or abs(y) > 1e-4:
                fail(f"{entity} at step {step}: process {p} at {(x, y)}, expected its lane ({LANE * p}, 0)")
    spawned = {
        cols["nekosim.Pose:robot"][0]: cols["nekosim.Pose:pose"]
        for sim, _, _, cols in rows.by_entity.get("/world/poses", [])
        if sim == 0 and "nekosim.Pose:pose" in cols
    }
    for p in range(processes):
        pose = spawned.get(p)
        if pose is None or abs(pose[0] - LANE * p) > TOLERANCE or abs(pose[1]) > TOLERANCE:
            fail(f"process {p}: exact pose at step 0 is {pose}, expected its lane ({LANE * p}, 0)")

    sends = check_sends(rows, trace)
    arrows = check_spacetime(rows, trace)
    crashes = check_crashes_grey(rows, trace)
    # The verdict beside the diagram, stated in full.
    doc = rows.static.get("/verdict", {}).get("TextDocument:text")
    if not doc or f'"{prop}"' not in doc[0] or f"**{prop}**:" not in doc[0]:
        fail(f"the verdict document is {doc}, expected it to name and state {prop!r}")
    # Full payloads on the arrows: each a whole rendering, not only its type.
    labels = [
        label
        for _, ev, _, cols in rows.by_entity.get("/spacetime/messages", [])
        if ev is not None
        for label in cols.get("Arrows2D:labels", [])
    ]
    if arrows and not all("(" in label for label in labels):
        fail(f"space-time labels are not whole messages: {labels[:3]}")
    views = check_blueprint(rrd, rows, trace, check=True)

    texts = [
        text
        for _, _, _, cols in rows.by_entity.get("/log", [])
        for text in (cols.get("TextLog:text") or [])
    ]
    verdicts = [t for t in texts if f'"{prop}"' in t and ("counterexample of" in t or "witness of" in t)]
    if len(verdicts) != 2:
        fail(f"{len(verdicts)} verdict lines naming {prop!r} in the log; expected 2: {texts[:3]}")
    # A violated property is an error in the log, a witness information.
    verdict_levels = [
        level
        for _, _, _, cols in rows.by_entity.get("/log", [])
        for text, level in zip(cols.get("TextLog:text") or [], cols.get("TextLog:level") or [])
        if text in verdicts
    ]
    want_level = "ERROR" if "counterexample of" in verdicts[0] else "INFO"
    if verdict_levels != [want_level, want_level]:
        fail(f"verdict lines at levels {verdict_levels}, expected {want_level}")
    # The lanes' birth lines, one line per trace record, the verdict twice.
    if len(texts) != processes + len(trace) + 2:
        fail(f"{len(texts)} log lines, expected {processes} births, the trace's {len(trace)} records and 2 verdicts")

    print(
        f"verify_check_rrd: ok: {rrd.name}: {processes} lanes over {steps} steps, "
        f"{len(sends)} sends with arrows, {arrows} space-time arrows, {len(crashes)} crashes grey, {len(texts)} log lines, "
        f"{views} blueprint views"
    )


if __name__ == "__main__":
    main()
