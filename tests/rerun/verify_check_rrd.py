"""Checks a `nekosim check --rrd` counterexample recording with the official Rerun reader
(rerun-sdk 0.36.3), against the JSONL trace `nekosim check --trace` wrote for the same path.

Usage: verify_check_rrd.py RECORDING.rrd TRACE.jsonl PROPERTY PROCESSES

Checks that `rerun rrd verify` accepts the file; it has the `sim_time` and `event` timelines;
process p stands at its place on a ring (radius 10 max(1, n/3), p0 at the top, clockwise) at
every step; every `send` of the trace has an arrow per receiver at its step, from the sender's
rim to the receiver's (markers of radius 1; no arrowhead under a marker), shifted to the right
of its direction so the two directions between a pair stay apart, and labelled with the whole
message, but for the copies the path drops, which have a lost mark (a stub ending in a cross)
instead; counted from the trace's sends, receives and drops alone, as for a run
(verify_rrd.py): a copy a `drop` record ends is lost from its send, never in flight, and
marked for 2 s (two steps); the others are in flight until their receive, and every
`messages_in_flight` sample, each layer's arrows and lost marks agree; a crashed process is
grey from its crash on; the text log has one
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

from collections import defaultdict

from verify_rrd import (
    TOLERANCE,
    Rows,
    check_blueprint,
    check_crashes_grey,
    check_in_flight,
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


def path_copies(trace: list[dict]) -> list[dict]:
    """Every copy a `send` of a checker's path hands to the network, in send order, in the form
    of verify_rrd.message_copies: its layer, sender, receiver and step, no arrival time. A
    `receive` ends the oldest copy on its way with its sender, receiver, layer and message, and
    so does a `drop`, which makes that copy lost from its send (such copies are alike, so which
    one is lost changes nothing of what is shown). A receive or drop that ends no copy fails
    the check."""
    copies: list[dict] = []
    waiting: dict[tuple, list[dict]] = defaultdict(list)
    for r in trace:
        if r["kind"] == "send":
            for to in r["to"]:
                c = {
                    "seq": r["seq"], "layer": r["layer"], "from": r["robot"], "to": to, "sent": r["t"],
                    "known": False, "arrive": None, "received": None, "lost": False,
                }
                copies.append(c)
                waiting[(r["robot"], to, r["layer"], r.get("msg"))].append(c)
        elif r["kind"] in ("receive", "drop"):
            if r["kind"] == "receive":
                key = (r["from"], r["robot"], r["layer"], r.get("msg"))
            else:
                key = (r["robot"], r["to"][0], r["layer"], r.get("msg"))
            queue = waiting.get(key)
            if not queue:
                fail(f"{r['kind']} #{r['seq']}: no copy of its message from p{key[0]} to p{key[1]} on its way")
            c = queue.pop(0)
            if r["kind"] == "receive":
                c["received"] = r["t"]
            else:
                c["lost"] = True
    for c in copies:
        c["end"] = None if c["lost"] else c["received"] if c["received"] is not None else math.inf
    return copies


def check_world_arrows(rows: "Rows", trace: list[dict], n: int, copies: list[dict]) -> int:
    """Each send's world arrows for its copies not lost: tail on the sender's rim, tip on the
    receiver's, both off the centre line by half a radius to the right of the direction;
    labels whole messages."""
    checked = 0
    lost = {(c["seq"], c["to"]) for c in copies if c["lost"]}
    for s in (r for r in trace if r["kind"] == "send"):
        entity = f"/world/messages/{s['layer']}"
        rows_at = [cols for _, ev, _, cols in rows.by_entity.get(entity, []) if ev == s["seq"]]
        cols = rows_at[-1] if rows_at else {}
        pairs = list(zip(cols.get("Arrows2D:origins", []), cols.get("Arrows2D:vectors", []), cols.get("Arrows2D:labels", [])))
        for to in (to for to in s["to"] if (s["seq"], to) not in lost):
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
    # A liveness counterexample ends with its lasso record: where the cycle begins.
    lasso = trace.pop() if trace and trace[-1]["kind"] == "lasso" else None
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

    copies = path_copies(trace)
    lost_at = defaultdict(int)
    for c in copies:
        lost_at[c["seq"]] += c["lost"]
    sends = check_sends(rows, trace, lambda s: lost_at[s["seq"]])
    world_arrows = check_world_arrows(rows, trace, processes, copies)
    # Processes stand still at their places: the lost marks' stubs start and aim there.
    paths = {p: [(0.0, *place(p, processes), 0.0, 0.0)] for p in range(processes)}
    samples, lost = check_in_flight(rows, trace, paths, copies)
    arrows = check_spacetime(rows, trace)
    crashes = check_crashes_grey(rows, trace)
    # The verdict beside the diagram, stated in full.
    doc = rows.static.get("/verdict", {}).get("TextDocument:text")
    if not doc or f'"{prop}"' not in doc[0] or f"**{prop}**:" not in doc[0]:
        fail(f"the verdict document is {doc}, expected it to name and state {prop!r}")
    if lasso is not None:
        begins = f"the cycle begins after step {lasso['cycle_from']} and repeats for ever"
        if begins not in doc[0] or lasso["reason"] not in doc[0]:
            fail(f"the verdict document is {doc}, expected the lasso's cycle and reason")
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
        f"{len(sends)} sends with {world_arrows} rim-to-rim arrows, {samples} in-flight samples, {lost} lost copies, "
        f"{arrows} space-time arrows, {len(crashes)} crashes grey, {len(texts)} log lines, "
        f"{views} blueprint views"
    )


if __name__ == "__main__":
    main()
