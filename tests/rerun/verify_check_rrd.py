"""Checks a `nekosim check --rrd` counterexample recording with the official Rerun reader
(rerun-sdk 0.36.3), against the JSONL trace `nekosim check --trace` wrote for the same path.

Usage: verify_check_rrd.py RECORDING.rrd TRACE.jsonl PROPERTY PROCESSES

Checks that `rerun rrd verify` accepts the file; it has the `sim_time` and `event` timelines;
process p stands at its place on a ring (radius 10 max(1, n/3), p0 at the top, clockwise) at
every step; every `send` of the trace has an arrow per receiver at its step, from the sender's
rim to the receiver's (markers of radius 1; no arrowhead under a marker), shifted to the right
of its direction so the two directions between a pair stay apart, and labelled with the whole
message; a crashed process is grey from its crash on; the text log has one
line per lane's birth and per trace record plus the verdict naming PROPERTY, at the start and
at the end, an ERROR for a counterexample and INFO for a witness; the default blueprint is
the layout of `nekosim run` recordings (verify_rrd.py) with message plots only, the
space-time diagram (every receive an arrow between the lanes, labelled with the whole message)
and the verdict document stating the property in full.
Prints one summary line and exits 0, or prints what differs and exits 1.
"""

from __future__ import annotations

import math
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
MARKER = 1.0


def place(p: int, n: int) -> tuple[float, float]:
    """Process p's place on the ring: p0 at the top, the others clockwise."""
    r = LANE * max(1.0, n / 3)
    a = math.pi / 2 - 2 * math.pi * p / n
    return r * math.cos(a), r * math.sin(a)


def check_world_arrows(rows: "Rows", trace: list[dict], n: int) -> int:
    """Each send's world arrows: tail on the sender's rim, tip on the receiver's, both off
    the centre line by half a radius to the right of the direction; labels whole messages."""
    checked = 0
    for s in (r for r in trace if r["kind"] == "send"):
        entity = f"/world/messages/{s['layer']}"
        rows_at = [cols for _, ev, _, cols in rows.by_entity.get(entity, []) if ev == s["seq"]]
        cols = rows_at[-1]
        pairs = list(zip(cols["Arrows2D:origins"], cols["Arrows2D:vectors"], cols.get("Arrows2D:labels", [])))
        for to in s["to"]:
            a, b = place(s["robot"], n), place(to, n)
            d = math.dist(a, b)
            ux, uy = (b[0] - a[0]) / d, (b[1] - a[1]) / d
            found = False
            for (ox, oy), (vx, vy), label in pairs:
                tip = (ox + vx, oy + vy)
                on_rims = abs(math.dist((ox, oy), a) - MARKER) < 1e-3 and abs(math.dist(tip, b) - MARKER) < 1e-3
                # Right of the direction (ux, uy) is (uy, -ux): the shift's sign.
                side = (ox - a[0]) * uy - (oy - a[1]) * ux
                if on_rims and abs(side - MARKER / 2) < 1e-3 and "(" in label:
                    found = True
            if not found:
                fail(f"send #{s['seq']} p{s['robot']} -> p{to}: no rim-to-rim arrow with a whole label in {pairs}")
            checked += 1
    return checked


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
            want = place(p, processes)
            if math.dist((x, y), want) > 1e-4:
                fail(f"{entity} at step {step}: process {p} at {(x, y)}, expected its place {want}")
    spawned = {
        cols["nekosim.Pose:robot"][0]: cols["nekosim.Pose:pose"]
        for sim, _, _, cols in rows.by_entity.get("/world/poses", [])
        if sim == 0 and "nekosim.Pose:pose" in cols
    }
    for p in range(processes):
        pose = spawned.get(p)
        want = place(p, processes)
        if pose is None or math.dist(pose[:2], want) > TOLERANCE:
            fail(f"process {p}: exact pose at step 0 is {pose}, expected its place {want}")

    sends = check_sends(rows, trace)
    world_arrows = check_world_arrows(rows, trace, processes)
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
        f"{len(sends)} sends with {world_arrows} rim-to-rim arrows, {arrows} space-time arrows, {len(crashes)} crashes grey, {len(texts)} log lines, "
        f"{views} blueprint views"
    )


if __name__ == "__main__":
    main()
