"""Checks a nekosim .rrd recording with the official Rerun reader (rerun-sdk 0.36.3).

Usage: verify_rrd.py RECORDING.rrd TRACE.jsonl FRAMERATE

Independently of nekosim's code, it checks that:
- `rerun rrd verify` accepts the file;
- the recording loads with `rerun.experimental.RrdReader` and has the `sim_time` and `event`
  timelines;
- robots are drawn in groups of 16 (`world/robots/0-15`, ...: robot `i` is instance `i % 16`);
  every kinematic record (spawn, motion step or finish, crash) has a `world/poses` row at its
  event naming its robot (`nekosim.Pose:robot`) with the exact pose (`nekosim.Pose:pose`,
  64-bit) equal to the trace's within 1e-6, and no other rows; every drawn 32-bit marker, on
  every row (events and animation frames), is where the path rebuilt from the trace puts the
  robot at that row's instant, to float precision; read back with latest-at semantics at
  event and frame instants, the markers and the heading arrows' origins still are;
- every leg of a robot's path (from one kinematic record to the next where it moved) is a
  `world/paths` row at the event that ended it, from the earlier position to the later one;
- while a push proximity sensor is active, the robot's group has a circle of its reach
  (radius + range) around it, and none once it is switched off;
- the number of collision markers (`world/collisions`, one row each, a cross of two strokes
  centred on the contact point) equals the number of `collision` records of the trace; the
  markers are unlabelled and in a colour no robot has;
- a crashed robot is grey from its crash on;
- every view or proximity query is a circle of its range around the robot from its request
  to its reply; the last metric samples count the trace's collisions and deliveries, and every
  `events_per_second` sample the trace's records in the simulated second before it;
- robot markers have a static `show_labels: false`; with 20 robots or fewer, each robot's
  name is drawn in world units beside it, smaller than it, on every row of its group;
- every `send` record has a message-arrow row at its event with at least one arrow per copy
  on its way, and a row of lost marks with a stub and a cross per copy the network lost
  (`arrive` null);
- counted from the trace's sends, receives and losses alone: at every `messages_in_flight`
  sample the figure is the number of copies in flight (sent, not lost, and neither received
  nor past their arrival time), each layer draws that many arrows, and the lost marks are the
  copies lost in the last 2 s, each a stub from the sender towards the receiver ending in a
  cross;
- the text log has one line per trace record (but an arrival right after the step that
  finished its motion, which the seed's log has no line for), at level WARN for collisions and suspicions,
  ERROR for crashes and INFO otherwise;
- the default blueprint reaches, from its viewport, a 2D view of `/world`, a text log of `/log`
  and one time-series view per metric logged, each over an entity the recording has, with the
  trails' (last 10 s) and collision markers' (last 3 s) visible time ranges; the metrics are
  collisions and the event rate, plus messages in flight and deliveries when the trace has
  sends; the plots' legends are hidden, the log hides its entity-path column, the blueprint
  and selection panels are collapsed, and the 2D view's bounds are the world's box with a
  3 % margin.

Prints one summary line and exits 0, or prints what differs and exits 1.
"""

from __future__ import annotations

import bisect
import json
import math
import os
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import pyarrow as pa
import rerun as rr
import rerun.experimental as rrx

TOLERANCE = 1e-6
GROUP = 16
# Runs with more robots than this have no marker labels (src/recording/rerun_canvas/layout.rs).
LABELLED_ROBOTS = 20
# A robot's name (src/recording/names.rs) ends at most this many radii right of its centre:
# 1.25 + 0.75 per character after the first + 0.5 for the last, for names up to p99.
NAME_REACH = 1.25 + 2 * 0.75 + 0.5
# The 2D view frames the world with this margin, a fraction of its larger side.
WORLD_MARGIN = 0.03
# Collision markers stay this long [s].
COLLISION_SECONDS = 3
# A lost copy stays drawn this long after its send [s] (src/recording/flights.rs).
LOST_SECONDS = 2.0
# Blueprint panel states (rerun.blueprint.components.PanelState).
COLLAPSED = 2
# Text log column kinds (TextLogColumnKind).
ENTITY_PATH = 1


def group(robot: int) -> tuple[str, int]:
    """The robot's group entity suffix (`0-31`) and its instance in the group."""
    first = robot - robot % GROUP
    return f"{first}-{first + GROUP - 1}", robot % GROUP
EXPECTED_VERSION = "0.36.3"


def fail(msg: str) -> None:
    print(f"verify_rrd: FAIL: {msg}", file=sys.stderr)
    sys.exit(1)


def load_trace(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines() if line]


def rebuild(trace: list[dict]) -> dict[int, list[tuple[float, float, float, float, float]]]:
    """Each robot's path as (t, x, y, vx, vy) pieces, from the kinematic records only."""
    paths: dict[int, list] = defaultdict(list)
    for r in trace:
        kind = r["kind"]
        if kind == "spawn" or kind in ("motion_finish", "crash"):
            x, y = r["pos"]
            paths[r["robot"]].append((r["t"], x, y, 0.0, 0.0))
        elif "vel" in r:
            x, y = r["pos"]
            vx, vy = r["vel"]
            paths[r["robot"]].append((r["t"], x, y, vx, vy))
    return paths


def pos_at(path, t: float) -> tuple[float, float]:
    last = None
    for seg in path:
        if seg[0] <= t:
            last = seg
        else:
            break
    t0, x, y, vx, vy = last
    return (x + vx * (t - t0), y + vy * (t - t0))


def ns(t: float) -> int:
    return int(round(t * 1e9))


class Rows:
    """All rows of every entity: entity -> list of (sim_time ns, event or None, row id, columns)."""

    def __init__(self, path: Path):
        reader = rrx.RrdReader(str(path))
        if not reader.recordings():
            fail("no recording store in the file")
        self.timelines: set[str] = set()
        self.by_entity: dict[str, list] = defaultdict(list)
        # Static components: entity -> component -> value.
        self.static: dict[str, dict] = defaultdict(dict)
        for chunk in reader.store().stream():
            if chunk.is_static:
                self.by_entity[chunk.entity_path].append((None, None, b"", {}))
                batch = chunk.to_record_batch()
                for n in batch.schema.names:
                    if ":" in n:
                        self.static[chunk.entity_path][n] = batch.column(n).to_pylist()[-1]
                continue
            self.timelines.update(chunk.timeline_names)
            batch: pa.RecordBatch = chunk.to_record_batch()
            names = batch.schema.names
            sim = batch.column("sim_time").cast(pa.int64()).to_pylist() if "sim_time" in names else None
            if sim is None:
                continue
            event = batch.column("event").to_pylist() if "event" in names else [None] * batch.num_rows
            row_ids = batch.column("rerun.controls.RowId").to_pylist()
            data = {n: batch.column(n).to_pylist() for n in names if ":" in n}
            for i in range(batch.num_rows):
                cols = {n: v[i] for n, v in data.items() if v[i] is not None}
                self.by_entity[chunk.entity_path].append((sim[i], event[i], row_ids[i], cols))

    def latest_at(self, entity: str, component: str, t_ns: int):
        """The component's value at `t_ns` on sim_time: the last row at or before it."""
        best = None
        for sim, _, row_id, cols in self.by_entity.get(entity, []):
            if sim is None or sim > t_ns or component not in cols:
                continue
            key = (sim, row_id)
            if best is None or key > best[0]:
                best = (key, cols[component])
        return None if best is None else best[1]


    def latest_at_event(self, entity: str, component: str, seq: int):
        """The component's value at event `seq` on the `event` timeline."""
        best = None
        for _, event, row_id, cols in self.by_entity.get(entity, []):
            if event is None or event > seq or component not in cols:
                continue
            key = (event, row_id)
            if best is None or key > best[0]:
                best = (key, cols[component])
        return None if best is None else best[1]


def rrd_verify(rrd: Path) -> None:
    """The SDK is the pinned version and `rerun rrd verify` accepts the file."""
    if rr.__version__ != EXPECTED_VERSION:
        fail(f"rerun-sdk {rr.__version__}, expected {EXPECTED_VERSION}")
    cli = Path(sys.executable).parent / "rerun"
    # Rerun's tools send no usage data when `CI` is set; a test has no business sending any.
    env = dict(os.environ, CI="1")
    verify = subprocess.run(
        [str(cli), "rrd", "verify", str(rrd)], capture_output=True, text=True, env=env
    )
    if verify.returncode != 0:
        fail(f"rerun rrd verify: {verify.stdout}{verify.stderr}")


def message_copies(trace: list[dict]) -> list[dict]:
    """Every copy a `send` record hands to the network, in send order: its layer, sender,
    receiver, send time, arrival time (`arrive`, aligned with `to`: null when the network lost
    it; the whole list absent where unknown, a model checker's path) and the time of the
    `receive` that took it, if any. A receive takes the copy with its sender, receiver, layer
    and message that arrives at the receive's instant (copies of one message may overtake each
    other), or where no arrival is known the oldest such copy; a receive that takes no copy
    fails the check. Each copy gets `end`, the instant it stops being in flight: its receive,
    or else its arrival (a copy reaching a crashed robot is received by no one), or never."""
    copies: list[dict] = []
    receives: list[dict] = []
    waiting: dict[tuple, list[dict]] = defaultdict(list)
    for r in trace:
        if r["kind"] == "send":
            arrive = r.get("arrive")
            for k, to in enumerate(r["to"]):
                c = {
                    "seq": r["seq"], "layer": r["layer"], "from": r["robot"], "to": to, "sent": r["t"],
                    "known": arrive is not None, "arrive": None if arrive is None else arrive[k],
                    "received": None,
                }
                c["lost"] = c["known"] and c["arrive"] is None
                copies.append(c)
                if not c["lost"]:
                    waiting[(r["robot"], to, r["layer"], r.get("msg"))].append(c)
        elif r["kind"] == "receive":
            queue = waiting.get((r["from"], r["robot"], r["layer"], r.get("msg"))) or []
            match = next((c for c in queue if c["known"] and c["arrive"] == r["t"]), None)
            match = match or next((c for c in queue if not c["known"]), None)
            if match is None:
                fail(f"receive #{r['seq']} at {r['t']}: no copy of its message from p{r['from']} arrives then")
            queue.remove(match)
            match["received"] = r["t"]
            match["receive"] = (len(receives), r)
            receives.append(r)
    for c in copies:
        c["end"] = (
            None if c["lost"]
            else c["received"] if c["received"] is not None
            else c["arrive"] if c["known"]
            else math.inf
        )
    return copies


def check_sends(rows: "Rows", trace: list[dict], lost_of=None) -> list[dict]:
    """Every `send` record with a copy on its way has a message-arrow row at its event with at
    least one arrow per such copy; every `send` whose copies the network lost (`arrive` null,
    or as many as `lost_of(send)` says where the send cannot say) has a row of lost marks at
    its event with a stub and a cross per lost copy."""
    sends = [r for r in trace if r["kind"] == "send"]
    at_event: dict[str, dict] = {}

    def row_at(entity: str, seq: int) -> dict:
        if entity not in at_event:
            at_event[entity] = {ev: cols for _, ev, _, cols in rows.by_entity.get(entity, []) if ev is not None}
        return at_event[entity].get(seq) or {}

    for s in sends:
        arrive = s.get("arrive")
        lost = sum(1 for a in arrive if a is None) if arrive is not None else lost_of(s) if lost_of else 0
        flying = len(s["to"]) - lost
        entity = f"/world/messages/{s['layer']}"
        if flying and len(row_at(entity, s["seq"]).get("Arrows2D:vectors", [])) < flying:
            fail(f"send #{s['seq']} on {s['layer']}: no arrow per copy on its way in {entity}")
        entity = f"/world/lost/{s['layer']}"
        if lost and len(row_at(entity, s["seq"]).get("LineStrips2D:strips", [])) < 3 * lost:
            fail(f"send #{s['seq']} on {s['layer']}: no stub and cross per lost copy in {entity}")
    return sends


def received_copies(trace: list[dict], with_arrival: bool = False):
    """Each `receive` record with the time of the `send` it answers ([`message_copies`]); with
    `with_arrival`, only copies whose send gave an arrival time."""
    taken = [c for c in message_copies(trace) if c["received"] is not None and (c["known"] or not with_arrival)]
    for c in sorted(taken, key=lambda c: c["receive"][0]):
        yield c["receive"][1], c["sent"]


def sweep_latest(rows: "Rows", entity: str, component: str, times_ns: list[int]) -> list:
    """The component's latest-at value on sim_time at each of the sorted `times_ns` (None
    before its first row), in one pass over the entity's rows."""
    rs = sorted(
        (sim, row_id, cols[component])
        for sim, _, row_id, cols in rows.by_entity.get(entity, [])
        if sim is not None and component in cols
    )
    out, i, current = [], 0, None
    for t in times_ns:
        while i < len(rs) and rs[i][0] <= t:
            current = rs[i][2]
            i += 1
        out.append(current)
    return out


def check_in_flight(rows: "Rows", trace: list[dict], paths, copies=None) -> tuple[int, int]:
    """Counted from the trace alone ([`message_copies`], or the `copies` given): at every `messages_in_flight`
    sample, the figure is the number of copies in flight then (sent at or before, ending
    after), lost copies never among them; on each layer the arrows drawn are those copies; and
    the lost marks are the copies lost in the last LOST_SECONDS, each a stub from the sender
    towards the receiver (both where they were at the send) ending in a cross. Samples within
    a microsecond of a send, receive, arrival or expiry are skipped: the file keeps times to
    the nanosecond. Returns (samples checked, lost copies)."""
    if copies is None:
        copies = message_copies(trace)
    layers = sorted({c["layer"] for c in copies})

    def span_counter(spans):
        starts = sorted(a for a, _ in spans)
        ends = sorted(b for _, b in spans)
        return lambda t: bisect.bisect_right(starts, t) - bisect.bisect_right(ends, t)

    flying = [(c["sent"], c["end"]) for c in copies if not c["lost"]]
    lost = [(c["sent"], c["sent"] + LOST_SECONDS) for c in copies if c["lost"]]
    count = span_counter(flying)
    per_layer = {
        l: (
            span_counter([(c["sent"], c["end"]) for c in copies if c["layer"] == l and not c["lost"]]),
            span_counter([(c["sent"], c["sent"] + LOST_SECONDS) for c in copies if c["layer"] == l and c["lost"]]),
        )
        for l in layers
    }
    boundaries = sorted({t for span in flying + lost for t in span if t != math.inf})

    def near_boundary(t: float) -> bool:
        i = bisect.bisect_left(boundaries, t - 1e-6)
        return i < len(boundaries) and boundaries[i] <= t + 1e-6

    samples = [
        (sim, cols["Scalars:scalars"])
        for sim, _, _, cols in rows.by_entity.get("/metrics/messages_in_flight", [])
        if sim is not None and "Scalars:scalars" in cols
    ]
    if copies and not samples:
        fail("the trace has sends but no messages_in_flight sample")
    samples = [(sim, v) for sim, v in sorted(samples) if not near_boundary(sim / 1e9)]
    times = [sim for sim, _ in samples]
    arrows = {l: sweep_latest(rows, f"/world/messages/{l}", "Arrows2D:vectors", times) for l in layers}
    marks = {l: sweep_latest(rows, f"/world/lost/{l}", "LineStrips2D:strips", times) for l in layers}
    for k, (sim, value) in enumerate(samples):
        t = sim / 1e9
        if value != [float(count(t))]:
            fail(f"messages_in_flight at {t}: {value}, the trace has {count(t)} copies in flight")
        for l in layers:
            in_flight, recently_lost = per_layer[l]
            drawn = len(arrows[l][k] or [])
            if drawn != in_flight(t):
                fail(f"/world/messages/{l} at {t}: {drawn} arrows, the trace has {in_flight(t)} copies in flight")
            strips = len(marks[l][k] or [])
            if strips != 3 * recently_lost(t):
                fail(f"/world/lost/{l} at {t}: {strips} strokes, the trace has {recently_lost(t)} copies lost in the last {LOST_SECONDS} s")

    # Each lost copy's mark at its send: a stub from the sender's position towards the
    # receiver's, shorter than the way, and a cross of two strokes centred on its end.
    for c in (c for c in copies if c["lost"]):
        strips = [
            cols.get("LineStrips2D:strips") or []
            for _, ev, _, cols in rows.by_entity.get(f"/world/lost/{c['layer']}", [])
            if ev == c["seq"]
        ]
        strips = strips[-1] if strips else []
        start, target = pos_at(paths[c["from"]], c["sent"]), pos_at(paths[c["to"]], c["sent"])
        way = math.dist(start, target)
        tol = 2**-18 * max(1.0, *map(abs, start), *map(abs, target))

        def marks_copy(k: int) -> bool:
            stub, d1, d2 = strips[k : k + 3]
            (sx, sy), (ex, ey) = stub
            if math.dist((sx, sy), start) > tol or math.dist((ex, ey), (sx, sy)) > way + tol:
                return False
            if way > tol:
                ux, uy = (target[0] - start[0]) / way, (target[1] - start[1]) / way
                if abs((ex - sx) * uy - (ey - sy) * ux) > tol or (ex - sx) * ux + (ey - sy) * uy < 0:
                    return False
            centres = [((a[0] + b[0]) / 2, (a[1] + b[1]) / 2) for a, b in (d1, d2)]
            return all(math.dist(m, (ex, ey)) <= tol for m in centres)

        if not any(marks_copy(k) for k in range(0, len(strips) - 2, 3)):
            fail(f"send #{c['seq']}: no stub from p{c['from']} at {start} towards p{c['to']} at {target} ending in a cross in /world/lost/{c['layer']}")
    return len(samples), len(lost)


def check_spacetime(rows: "Rows", trace: list[dict]) -> int:
    """The space-time diagram: each receive of the trace is an arrow at its event from the
    sender's lane (x = 10 * sender) at the send to the receiver's lane at the receive, with
    time running down at one scale for the whole diagram; each delivery a mark on its lane at
    its event. Returns the number of arrows checked."""
    if not any(r["kind"] == "send" for r in trace):
        if any(e.startswith("/spacetime/messages") and any(s is not None for s, *_ in rs) for e, rs in rows.by_entity.items()):
            fail("a space-time arrow without any send in the trace")
        return 0
    arrows = {ev: cols for _, ev, _, cols in rows.by_entity.get("/spacetime/messages", []) if ev is not None}
    scale = None
    checked = 0
    for r, sent in received_copies(trace):
        cols = arrows.get(r["seq"])
        if not cols or "Arrows2D:origins" not in cols:
            fail(f"receive #{r['seq']}: no space-time arrow at its event")
        (ox, oy), (vx, vy) = cols["Arrows2D:origins"][0], cols["Arrows2D:vectors"][0]
        if abs(ox - 10 * r["from"]) > 1e-4 or abs(ox + vx - 10 * r["robot"]) > 1e-4:
            fail(f"receive #{r['seq']}: arrow from x={ox} to x={ox + vx}, lanes {r['from']} -> {r['robot']}")
        if r["t"] > 0:
            k = (oy + vy) / r["t"]
            scale = scale or k
            if abs(k - scale) > 1e-4 * scale or abs(oy - scale * sent) > 1e-3 * max(1.0, oy):
                fail(f"receive #{r['seq']}: arrow from y={oy} to y={oy + vy}, sent {sent}, received {r['t']}, scale {scale}")
        checked += 1
    marks = {ev: cols for _, ev, _, cols in rows.by_entity.get("/spacetime/marks", []) if ev is not None}
    for r in trace:
        if r["kind"] in ("deliver", "decide", "crash"):
            cols = marks.get(r["seq"])
            if not cols or abs(cols["Points2D:positions"][0][0] - 10 * r["robot"]) > 1e-4:
                fail(f"{r['kind']} #{r['seq']} of p{r['robot']}: no mark on its lane: {cols}")
    return checked


def check_message_ends(rows: "Rows", trace: list[dict], paths) -> int:
    """In the world, the last arrow drawn for a copy before its receive runs from the sender's
    position at the send to the receiver's position at the receive (the trace's `arrive`
    times let the recording know the receive instant at the send). Returns the copies
    checked."""
    checked = 0
    for r, sent in received_copies(trace, with_arrival=True):
        entity = f"/world/messages/{r['layer']}"
        origins = rows.latest_at_event(entity, "Arrows2D:origins", r["seq"] - 1) or []
        vectors = rows.latest_at_event(entity, "Arrows2D:vectors", r["seq"] - 1) or []
        start = pos_at(paths[r["from"]], sent)
        end = pos_at(paths[r["robot"]], r["t"])
        tol = 2**-18 * max(1.0, *map(abs, start), *map(abs, end))
        if not any(
            max(abs(o[0] - start[0]), abs(o[1] - start[1]), abs(o[0] + v[0] - end[0]), abs(o[1] + v[1] - end[1])) <= tol
            for o, v in zip(origins, vectors)
        ):
            fail(f"receive #{r['seq']}: no arrow from {start} (send at {sent}) to {end} (receive at {r['t']}) in {entity}")
        checked += 1
    return checked


def check_crashes_grey(rows: "Rows", trace: list[dict]) -> list[dict]:
    """Crashed robots are grey from their crash on."""
    grey = 0x808080FF
    crashes = [r for r in trace if r["kind"] == "crash"]
    for c in crashes:
        name, j = group(c["robot"])
        entity = f"/world/robots/{name}"
        colour = rows.latest_at(entity, "Points2D:colors", ns(c["t"]))
        if colour is None or colour[j] != grey:
            fail(f"robot {c['robot']} crashed at {c['t']} but its colour is {colour}")
    return crashes


LIGHTS = [(40, 40, 40), (240, 240, 240), (220, 40, 40), (240, 210, 40), (40, 180, 70)]


def light_rgba(light: int, pending) -> int:
    """A Look-Compute-Move light's colour as docs/lcm.md gives it: spin-light's colours in its
    order, the mean of the old and the new while a new light is written."""
    a = LIGHTS[light]
    b = LIGHTS[light if pending is None else pending]
    r, g, bl = ((x + y) // 2 for x, y in zip(a, b))
    return (r << 24) | (g << 16) | (bl << 8) | 0xFF


def check_lcm(rows: "Rows", trace: list[dict]) -> tuple[int, int]:
    """Look-Compute-Move robots show their light as their colour from each light record on,
    and their snapshot (lines from where they looked to each robot they saw) from each Look to
    the end of the cycle."""
    lights = 0
    for r in trace:
        if r["kind"] != "light" or r["light"] >= len(LIGHTS) or (r.get("pending") or 0) >= len(LIGHTS):
            continue
        name, j = group(r["robot"])
        colour = rows.latest_at_event(f"/world/robots/{name}", "Points2D:colors", r["seq"])
        want = light_rgba(r["light"], r.get("pending"))
        if colour is None or colour[j] != want:
            fail(f"light #{r['seq']} of robot {r['robot']}: colour {colour}, expected {want:#010x}")
        lights += 1
    looks = 0
    for r in trace:
        if r["kind"] not in ("look", "wait"):
            continue
        strips = rows.latest_at_event(f"/world/looks/{r['robot']}", "LineStrips2D:strips", r["seq"])
        if r["kind"] == "wait":
            if strips:
                fail(f"wait #{r['seq']} of robot {r['robot']}: its snapshot is still drawn: {strips}")
            continue
        want = [[r["me"], s["at"]] for s in r["seen"]]
        got = strips or []
        if len(got) != len(want) or any(
            max(abs(a - b) for p, q in zip(g, w) for a, b in zip(p, q)) > 2**-20 * max(1.0, *(abs(c) for p in w for c in p))
            for g, w in zip(got, want)
        ):
            fail(f"look #{r['seq']} of robot {r['robot']}: drawn {got}, expected {want}")
        looks += 1
    return lights, looks


def check_blueprint(rrd: Path, rows: "Rows", trace: list[dict], check: bool = False) -> int:
    """The default blueprint lays out, from its viewport's root container, a 2D view of
    `/world`, a text log of `/log` and one time-series view per metric entity of the recording;
    every view shows an entity the recording has, and the trails and collision markers have
    their visible time ranges. Returns the number of views."""
    reader = rrx.RrdReader(str(rrd))
    blueprints = reader.blueprints()
    if len(blueprints) != 1:
        fail(f"{len(blueprints)} blueprint stores, expected 1")
    entities: dict[str, dict] = {}
    for chunk in reader.store(store=blueprints[0]).stream():
        batch = chunk.to_record_batch()
        for n in batch.schema.names:
            if ":" in n:
                value = batch.column(n).to_pylist()[-1]
                entities.setdefault(chunk.entity_path, {})[n] = value
    def path_of(uuid_bytes: list[int], kind: str) -> str:
        h = bytes(uuid_bytes).hex()
        return f"/{kind}/{h[0:8]}-{h[8:12]}-{h[12:16]}-{h[16:20]}-{h[20:32]}"
    root = entities.get("/viewport", {}).get("ViewportBlueprint:root_container")
    if not root:
        fail("the blueprint has no viewport root container")
    views = []
    todo = [path_of(root[0], "container")]
    while todo:
        node = todo.pop()
        cols = entities.get(node)
        if cols is None:
            fail(f"blueprint: {node} is referenced but not defined")
        if "ContainerBlueprint:contents" in cols:
            todo.extend(cols["ContainerBlueprint:contents"])
        elif "ViewBlueprint:class_identifier" in cols:
            views.append(
                (cols["ViewBlueprint:class_identifier"][0], cols["ViewBlueprint:space_origin"][0], node)
            )
        else:
            fail(f"blueprint: {node} is neither a container nor a view: {cols}")
    metric_entities = sorted(e for e in rows.by_entity if e.startswith("/metrics/"))
    messages = check or "/metrics/messages_in_flight" in metric_entities
    want = sorted(
        [("2D", "/world"), ("TextLog", "/log")]
        + [("TimeSeries", e) for e in metric_entities]
        + ([("2D", "/spacetime")] if messages else [])
        + ([("TextDocument", "/verdict")] if check else [])
    )
    got = sorted((c, o) for c, o, _ in views)
    if got != want or not metric_entities:
        fail(f"blueprint views {got}, expected {want}")
    # A simulated run plots collisions and its event rate; messages only when robots send.
    # A model checker's path plots its messages only.
    sends = any(r["kind"] == "send" for r in trace)
    layered = any(r["kind"] == "send" and r["layer"] != "app" for r in trace)
    must = {"/metrics/collisions", "/metrics/events_per_second"}
    if sends:
        must.add("/metrics/messages_in_flight")
    if layered:
        must.add("/metrics/deliveries")
    if check:
        must = {"/metrics/messages_in_flight", "/metrics/deliveries"}
    if set(metric_entities) != must and (check or sends or not set(metric_entities) >= must):
        fail(f"plots {metric_entities}, expected {sorted(must)} (sends in the trace: {sends})")
    for cls, origin, node in views:
        if cls == "TimeSeries" and entities.get(f"{node}/PlotLegend", {}).get("PlotLegend:visible") != [False]:
            fail(f"blueprint: the legend of {node} is not hidden")
        if cls == "TimeSeries":
            # A metric that kept one value gets a y range around it (not a lone tick);
            # one that moved keeps the viewer's automatic range.
            values = {
                v
                for _, _, _, cols in rows.by_entity.get(origin, [])
                for v in cols.get("Scalars:scalars") or []
            }
            axis = entities.get(f"{node}/ScalarAxis", {}).get("ScalarAxis:range")
            if len(values) == 1:
                (v,) = values
                want_axis = [max(v - 1, min(0.0, v)), v + 1]
                if not axis or max(abs(a - w) for a, w in zip(axis[0], want_axis)) > 1e-9:
                    fail(f"blueprint: {origin} stays at {v} but its y axis is {axis}, expected {want_axis}")
            elif axis:
                fail(f"blueprint: {origin} takes {len(values)} values but has a fixed y axis {axis}")
        if cls == "TextLog":
            columns = entities.get(f"{node}/TextLogColumns", {}).get("TextLogColumns:text_log_columns")
            shown = [c["kind"] for c in columns or [] if c["visible"]]
            if not columns or ENTITY_PATH in shown:
                fail(f"blueprint: the log shows its entity path column: {columns}")
    for panel in ("/blueprint_panel", "/selection_panel"):
        if entities.get(panel, {}).get("PanelBlueprint:state") != [COLLAPSED]:
            fail(f"blueprint: {panel} is {entities.get(panel)}, expected collapsed")
    if entities.get("/time_panel", {}).get("TimePanelBlueprint:state") != [COLLAPSED]:
        fail(f"blueprint: the time panel is {entities.get('/time_panel')}, expected collapsed")
    for cls, origin, node in views:
        if not any(e == origin or e.startswith(origin + "/") for e in rows.by_entity) and origin != "/spacetime":
            fail(f"blueprint: the {cls} view of {origin} shows no entity of the recording")
        if entities.get(f"{node}/ViewContents", {}).get("ViewContents:query") != ["$origin/**"]:
            fail(f"blueprint: the {cls} view of {origin} does not show its origin's subtree")
    world = next(node for cls, origin, node in views if cls == "2D" and origin == "/world")
    ranges = {
        e: entities.get(f"{world}/ViewContents/overrides/world/{e}/visualizers", {}).get("VisibleTimeRanges:ranges")
        for e in ("paths", "collisions")
    }
    if ranges["paths"] != [{"timeline": "sim_time", "range": {"start": -10 * 10**9, "end": 0}}]:
        fail(f"blueprint: trails are visible over {ranges['paths']}, expected the last 10 s")
    if ranges["collisions"] != [{"timeline": "sim_time", "range": {"start": -COLLISION_SECONDS * 10**9, "end": 0}}]:
        fail(f"blueprint: collision markers are visible over {ranges['collisions']}, expected the last {COLLISION_SECONDS} s")
    # The 2D view frames the world (its static box) with the margin.
    box = rows.static.get("/world/bounds", {})
    bounds = entities.get(f"{world}/VisualBounds2D", {}).get("VisualBounds2D:range")
    if box:
        (cx, cy), (hx, hy) = box["Boxes2D:centers"][0], box["Boxes2D:half_sizes"][0]
        m = WORLD_MARGIN * 2 * max(hx, hy)
        want_bounds = [cx - hx - m, cx + hx + m, cy - hy - m, cy + hy + m]
        got_bounds = None if not bounds else [*bounds[0]["x_range"], *bounds[0]["y_range"]]
        if got_bounds is None or max(abs(g - w) for g, w in zip(got_bounds, want_bounds)) > 1e-3 * max(1.0, hx, hy):
            fail(f"blueprint: the 2D view's bounds are {bounds}, expected {want_bounds}")
    elif bounds:
        fail(f"blueprint: an infinite world has view bounds {bounds}")
    return len(views)


def main() -> None:
    if len(sys.argv) != 4:
        fail(__doc__)
    rrd, trace_path, framerate = Path(sys.argv[1]), Path(sys.argv[2]), float(sys.argv[3])
    rrd_verify(rrd)

    trace = load_trace(trace_path)
    rows = Rows(rrd)
    for timeline in ("sim_time", "event"):
        if timeline not in rows.timelines:
            fail(f"timeline {timeline} missing; have {sorted(rows.timelines)}")
    if "/world/robots/0-15" not in rows.by_entity:
        fail(f"no robots entity; have {sorted(rows.by_entity)}")
    views = check_blueprint(rrd, rows, trace)

    # Every kinematic record has its exact pose at its event, and nothing else does.
    paths = rebuild(trace)
    exact = {}
    for sim, ev, _, cols in rows.by_entity.get("/world/poses", []):
        if "nekosim.Pose:pose" in cols:
            exact[ev] = (sim, cols["nekosim.Pose:robot"], cols["nekosim.Pose:pose"])
    kinematic_records = [
        r for r in trace if r["kind"] == "spawn" or "pos" in r and r["kind"] != "collision"
    ]
    for r in kinematic_records:
        got = exact.get(r["seq"])
        if got is None:
            fail(f"{r['kind']} #{r['seq']} of robot {r['robot']}: no exact pose row")
        sim, robot, pose = got
        if robot != [r["robot"]] or sim != ns(r["t"]) or len(pose) != 3:
            fail(f"#{r['seq']}: exact pose row {got}, expected robot {r['robot']} at {r['t']}")
        if max(abs(pose[0] - r["pos"][0]), abs(pose[1] - r["pos"][1])) > TOLERANCE:
            fail(f"#{r['seq']}: exact pose {pose}, trace {r['pos']}")
    if len(exact) != len(kinematic_records):
        fail(f"{len(exact)} exact pose rows, the trace has {len(kinematic_records)} kinematic records")
    rows_checked = len(exact)

    # Every drawn marker (event rows and animation frames) is on the trace's path, to the
    # precision of 32-bit floats.
    drawn_checked = 0
    for entity, rs in rows.by_entity.items():
        if not entity.startswith("/world/robots/"):
            continue
        first = int(entity.rsplit("/", 1)[1].split("-")[0])
        for sim, _, _, cols in rs:
            for j, d in enumerate(cols.get("Points2D:positions") or []):
                path = paths.get(first + j)
                if path is None or path[0][0] > sim / 1e9:
                    continue
                want = pos_at(path, sim / 1e9)
                if max(abs(a - b) for a, b in zip(d, want)) > 2**-22 * max(1.0, *map(abs, want)):
                    fail(f"robot {first + j} drawn at {d} at sim_time {sim} ns, trace {want}")
                drawn_checked += 1

    # Read back with latest-at: at animation frames and at event instants of a robot's group,
    # every robot of the group is where the trace puts it.
    end = trace[-1]["t"]
    instants: list[tuple[float, object]] = []
    if framerate > 0:
        frames = int(end * framerate)
        for k in sorted({frames * j // 7 for j in range(1, 8)} | {1, 3}):
            instants.append((k / framerate, None))
    kinematic = [r for r in trace if r["kind"] == "spawn" or "pos" in r and r["kind"] != "collision"]
    for r in kinematic[:: max(1, len(kinematic) // 25)]:
        instants.append((r["t"], r["robot"]))
    checked = 0
    for t, only in instants:
        for robot, path in paths.items():
            if only is not None and group(robot)[0] != group(only)[0]:
                continue
            want = pos_at(path, t)
            name, j = group(robot)
            entity = f"/world/robots/{name}"
            drawn = rows.latest_at(entity, "Points2D:positions", ns(t))[j]
            origin = rows.latest_at(f"/world/headings/{name}", "Arrows2D:origins", ns(t))[j]
            for d, o, w in zip(drawn, origin, want):
                # 32-bit floats: 24 bits of mantissa.
                if abs(d - w) > 2**-22 * max(1.0, abs(w)) or o != d:
                    fail(f"{entity} at {t}: robot {robot} drawn {drawn}, arrow {origin}, trace {want}")
            checked += 1

    # Legs: one row per move, from the previous corner to the new one.
    legs = {ev: cols for _, ev, _, cols in rows.by_entity.get("/world/paths", [])}
    corner: dict[int, tuple[float, float]] = {}
    moves = 0
    for r in trace:
        if not (r["kind"] == "spawn" or "pos" in r and r["kind"] != "collision"):
            continue
        pos = tuple(r["pos"])
        before = corner.get(r["robot"])
        corner[r["robot"]] = pos
        if before is None or before == pos:
            continue
        moves += 1
        strip = (legs.get(r["seq"]) or {}).get("LineStrips2D:strips")
        if strip is None or len(strip) != 1 or len(strip[0]) != 2:
            fail(f"move of robot {r['robot']} at #{r['seq']}: no leg in /world/paths ({strip})")
        for got, want in zip(strip[0], (before, pos)):
            if max(abs(g - w) for g, w in zip(got, want)) > 2**-22 * max(1.0, *map(abs, want)):
                fail(f"leg of robot {r['robot']} at #{r['seq']}: {strip[0]}, expected {before} -> {pos}")
    if len(legs) != moves:
        fail(f"{len(legs)} legs in /world/paths, the trace has {moves} moves")

    # Trails grow behind the robots: on every row of a group's trails, robot j's strip runs
    # from where it was at one of its kinematic records at or before the row to where the
    # rebuilt path puts it at the row's instant.
    trail_points = 0
    for entity, rs in rows.by_entity.items():
        if not entity.startswith("/world/trails/"):
            continue
        first = int(entity.rsplit("/", 1)[1].split("-")[0])
        for sim, _, _, cols in rs:
            if sim is None:
                continue
            t = sim / 1e9
            for j, strip in enumerate(cols.get("LineStrips2D:strips", [])):
                path = paths.get(first + j)
                if path is None:
                    continue
                (sx, sy), (ex, ey) = strip
                want_end = pos_at(path, t)
                corners = [(x, y) for (t0, x, y, _, _) in path if t0 <= t + 1e-9]
                tol = 2**-20 * max(1.0, abs(ex), abs(ey), abs(sx), abs(sy))
                if max(abs(ex - want_end[0]), abs(ey - want_end[1])) > tol * 4:
                    fail(f"trail of robot {first + j} at {t}: ends at {(ex, ey)}, the path is at {want_end}")
                if not any(max(abs(sx - x), abs(sy - y)) <= tol * 4 for x, y in corners):
                    fail(f"trail of robot {first + j} at {t}: starts at {(sx, sy)}, not a corner of its path before {t}")
                trail_points += 2
    if framerate > 0 and any(r["kind"] == "motion_finish" for r in trace) and trail_points == 0:
        fail("robots moved but no trail was drawn")

    # Obstacles: static outlines in `world/obstacles`, strip K for obstacle K; every contact
    # point the trace gives for a collision with obstacle K lies on strip K (to 32-bit floats).
    outlines = rows.static.get("/world/obstacles", {}).get("LineStrips2D:strips") or []
    obstacle_hits = 0
    for r in trace:
        other = r.get("other")
        if r["kind"] != "collision" or not (isinstance(other, str) and other.startswith("obstacle:")):
            continue
        k = int(other.split(":")[1])
        if k >= len(outlines):
            fail(f"collision #{r['seq']} with {other}: only {len(outlines)} obstacle outlines drawn")
        (px, py) = r["other_pos"]

        def seg_dist(a, b):
            (ax, ay), (bx, by) = a, b
            dx, dy = bx - ax, by - ay
            u = 0.0 if dx == dy == 0 else max(0.0, min(1.0, ((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy)))
            return ((ax + u * dx - px) ** 2 + (ay + u * dy - py) ** 2) ** 0.5

        d = min(seg_dist(a, b) for a, b in zip(outlines[k], outlines[k][1:]))
        # A circle is drawn by 64 chords: its rim is up to r (1 - cos(pi / 64)) inside them.
        xs = [x for x, _ in outlines[k]]
        tol = 2**-20 * max(1.0, abs(px), abs(py)) + (max(xs) - min(xs)) / 2 * (1 - math.cos(math.pi / 64))
        if d > tol:
            fail(f"collision #{r['seq']} with {other}: contact {r['other_pos']} is {d} from its outline")
        obstacle_hits += 1

    collisions = sum(1 for r in trace if r["kind"] == "collision")
    # One marker per row of world/collisions, at the collision's event: a cross of two
    # strokes, in a colour no robot has, without labels.
    markers = sum(
        len(cols["LineStrips2D:strips"]) // 2
        for sim, _, _, cols in rows.by_entity.get("/world/collisions", [])
        if sim is not None and "LineStrips2D:strips" in cols
    )
    if markers != collisions:
        fail(f"{markers} collision markers, the trace has {collisions} collisions")
    style = rows.static.get("/world/collisions", {})
    robot_colours = {
        c
        for e, rs in rows.by_entity.items()
        if e.startswith("/world/robots/")
        for _, _, _, cols in rs
        for c in cols.get("Points2D:colors", [])
    }
    if collisions and (
        style.get("LineStrips2D:show_labels") != [False]
        or not style.get("LineStrips2D:colors")
        or style["LineStrips2D:colors"][0] in robot_colours
    ):
        fail(f"collision markers are styled {style}; robots are coloured {sorted(robot_colours)[:5]}...")
    # Each marker is at its collision's event, at the contact point: on the boundary, or
    # between the two centres in the ratio of the radii.
    at_event = {ev: cols for _, ev, _, cols in rows.by_entity.get("/world/collisions", []) if ev is not None}
    radius = {r["robot"]: r["radius"] for r in trace if r["kind"] == "spawn"}
    for c in (r for r in trace if r["kind"] == "collision"):
        (x, y), (ox, oy) = c["pos"], c["other_pos"]
        if isinstance(c["other"], int):
            k = radius[c["robot"]] / (radius[c["robot"]] + radius[c["other"]])
            want = (x + (ox - x) * k, y + (oy - y) * k)
        else:
            want = (ox, oy)
        strips = (at_event.get(c["seq"]) or {}).get("LineStrips2D:strips")
        got = None
        if strips and len(strips) == 2:
            (ax, ay), (bx, by) = strips[0]
            got = ((ax + bx) / 2, (ay + by) / 2)
        if not got or max(abs(g - w) for g, w in zip(got, want)) > 2**-20 * max(1.0, *map(abs, want)):
            fail(f"collision #{c['seq']}: marker centred at {got}, contact point {want}")

    sends = check_sends(rows, trace)
    flight_samples, lost_copies = check_in_flight(rows, trace, paths)
    spacetime = check_spacetime(rows, trace)
    ends = check_message_ends(rows, trace, paths)
    check_crashes_grey(rows, trace)
    lcm_lights, lcm_looks = check_lcm(rows, trace)

    # Push sensors: at each switch, the group's circles are those of its active sensors, in
    # robot order, around the robots.
    radius = {r["robot"]: r["radius"] for r in trace if r["kind"] == "spawn"}
    reach: dict[int, float] = {}
    switches = 0
    switch_log: list[tuple[float, dict[int, float]]] = []
    for r in trace:
        if r["kind"] != "sensor_request":
            continue
        query = (r["value"] or {}).get("query") if isinstance(r["value"], dict) else None
        if query == "activate_proximity":
            reach[r["robot"]] = radius[r["robot"]] + r["value"]["range"]
        elif query == "deactivate_proximity":
            reach.pop(r["robot"], None)
        else:
            continue
        switches += 1
        name, _ = group(r["robot"])
        active = sorted(p for p in reach if group(p)[0] == name)
        entity = f"/world/sensors/{name}"
        centers = rows.latest_at_event(entity, "Ellipses2D:centers", r["seq"]) or []
        half = rows.latest_at_event(entity, "Ellipses2D:half_sizes", r["seq"]) or []
        if len(centers) != len(active) or len(half) != len(active):
            fail(f"{entity} at {r['t']}: {len(centers)} circles, active sensors {active}")
        for p, c, h in zip(active, centers, half):
            want = pos_at(paths[p], r["t"])
            if max(abs(c[0] - want[0]), abs(c[1] - want[1])) > 1e-3 or abs(h[0] - reach[p]) > 1e-3:
                fail(f"{entity} at {r['t']}: circle {c} r {h} for robot {p}, want {want} r {reach[p]}")
        switch_log.append((r["t"], dict(reach)))
    # Between switches, at animation frames, the circles have moved with their robots.
    frames_checked = 0
    if framerate > 0:
        for (t0, active), (t1, _) in zip(switch_log, switch_log[1:] + [(end, {})]):
            k = int(t0 * framerate) + 1
            while k / framerate < t1:
                t = k / framerate
                k += 1
                for name in {group(p)[0] for p in active}:
                    mine = sorted(p for p in active if group(p)[0] == name)
                    centers = rows.latest_at(f"/world/sensors/{name}", "Ellipses2D:centers", ns(t))
                    for p, c in zip(mine, centers or []):
                        want = pos_at(paths[p], t)
                        if max(abs(c[0] - want[0]), abs(c[1] - want[1])) > 1e-3:
                            fail(f"sensor of robot {p} at frame {t}: circle at {c}, robot at {want}")
                    if centers is None or len(centers) != len(mine):
                        fail(f"sensors {name} at frame {t}: {centers}, active {mine}")
                    frames_checked += 1

    # View and proximity queries: a circle of their range around the robot from the request
    # (`world/queries/<robot>`, at its event) to the reply (cleared).
    queries = 0
    for r in trace:
        if r["kind"] == "sensor_request" and isinstance(r["value"], dict) and r["value"].get("query") in ("view", "proximity"):
            reach = r["value"]["range"] + (radius[r["robot"]] if r["value"]["query"] == "proximity" else 0.0)
            cols = rows.latest_at_event(f"/world/queries/{r['robot']}", "Ellipses2D:centers", r["seq"])
            half = rows.latest_at_event(f"/world/queries/{r['robot']}", "Ellipses2D:half_sizes", r["seq"])
            want = pos_at(paths[r["robot"]], r["t"])
            if not cols or not half or max(abs(c - w) for c, w in zip(cols[0], want)) > 1e-3 or abs(half[0][0] - reach) > 1e-3:
                fail(f"query #{r['seq']} of robot {r['robot']}: circle {cols} {half}, expected {want} r {reach}")
            queries += 1
        elif r["kind"] == "sensor_reply" and r["sensor"] in ("view", "proximity") and not r["interrupt"]:
            cols = rows.latest_at_event(f"/world/queries/{r['robot']}", "Ellipses2D:centers", r["seq"])
            if cols:
                fail(f"reply #{r['seq']} of robot {r['robot']}: the query circle is still drawn: {cols}")

    # Metrics: the last samples (at the run's end, which may follow the last record) count the
    # trace's collisions and deliveries.
    for entity, want in (
        ("/metrics/collisions", sum(1 for r in trace if r["kind"] == "collision")),
        ("/metrics/deliveries", sum(1 for r in trace if r["kind"] == "deliver")),
    ):
        if entity not in rows.by_entity and want == 0:
            continue
        last = rows.latest_at(entity, "Scalars:scalars", 2**62)
        if last != [float(want)]:
            fail(f"{entity} ends at {last}, the trace has {want}")

    # Names: robot markers never show Rerun's labels (a fixed screen size); runs of at most
    # LABELLED_ROBOTS robots draw each robot's name as strokes in world units beside it and
    # smaller than it: on every row of a group's names, every stroke lies between one and
    # NAME_REACH radii right of a robot of the group (at the row's instant, on the rebuilt
    # path) and within half a radius (descender: 0.8) above or below its centre.
    robots = sum(1 for r in trace if r["kind"] == "spawn")
    radius = {r["robot"]: r["radius"] for r in trace if r["kind"] == "spawn"}
    markers_entities = [e for e in rows.by_entity if e.startswith("/world/robots/")]
    hidden = [e for e in markers_entities if rows.static.get(e, {}).get("Points2D:show_labels") == [False]]
    if sorted(hidden) != sorted(markers_entities):
        fail(f"labels shown on {sorted(set(markers_entities) - set(hidden))}")
    names = [e for e in rows.by_entity if e.startswith("/world/names/")]
    if robots > LABELLED_ROBOTS and names:
        fail(f"{robots} robots: names drawn in {names}")
    if robots <= LABELLED_ROBOTS and len(names) != len(markers_entities):
        fail(f"{robots} robots: names {names}, marker groups {markers_entities}")
    name_strokes = 0
    for entity in names:
        first = int(entity.rsplit("/", 1)[1].split("-")[0])
        members = [k for k in paths if first <= k < first + GROUP]
        for sim, _, _, cols in rows.by_entity[entity]:
            if sim is None:
                continue
            t = sim / 1e9
            centres = [(k, pos_at(paths[k], t)) for k in members if paths[k][0][0] <= t]
            for stroke in cols.get("LineStrips2D:strips", []):
                def beside(k, c):
                    r = radius[k]
                    return all(
                        r * (1 - 1e-3) <= x - c[0] <= NAME_REACH * r and -0.5 * r - 1e-3 <= y - c[1] <= 0.8 * r + 1e-3
                        for x, y in stroke
                    )
                if not any(beside(k, c) for k, c in centres):
                    fail(f"{entity} at {t}: stroke {stroke} is beside no robot")
                name_strokes += 1
    if robots <= LABELLED_ROBOTS and name_strokes == 0:
        fail("no robot name drawn")

    # Events per second: at each sample, the trace's records in the last simulated second.
    times = sorted(r["t"] for r in trace)
    rate_samples = 0
    for sim, _, _, cols in rows.by_entity.get("/metrics/events_per_second", []):
        if "Scalars:scalars" not in cols:
            continue
        t = sim / 1e9
        # Skip the rare sample whose window starts within a nanosecond of a record.
        lo = bisect.bisect_right(times, t - 1.0 - 1e-9)
        if lo < len(times) and times[lo] <= t - 1.0 + 1e-9:
            continue
        want = bisect.bisect_right(times, t + 1e-9) - bisect.bisect_right(times, t - 1.0)
        if cols["Scalars:scalars"] != [float(want)]:
            fail(f"events_per_second at {t}: {cols['Scalars:scalars']}, the trace has {want} records in the last second")
        rate_samples += 1
    if rate_samples == 0:
        fail("no events_per_second sample checked")

    # One log line per trace record, but for an arrival right after the step that finished
    # its motion (the seed's log has no line for it; src/log.rs).
    last_kind: dict[int, tuple[str, float]] = {}
    silent = 0
    for r in trace:
        before = last_kind.get(r["robot"])
        if (
            r["kind"] == "motion_finish"
            and r.get("outcome") == "arrived"
            and before is not None
            and before[0] in ("finish_turn", "finish_forward")
            and before[1] == r["t"]
        ):
            silent += 1
        last_kind[r["robot"]] = (r["kind"], r["t"])
    log_rows = sum(1 for _, ev, _, cols in rows.by_entity.get("/log", []) if "TextLog:text" in cols)
    if log_rows != len(trace) - silent:
        fail(f"{log_rows} log lines, the trace has {len(trace)} records of which {silent} arrivals after a finishing step")
    # Levels: collisions and suspicions warn, crashes are errors, the rest is information.
    levels = defaultdict(int)
    for _, _, _, cols in rows.by_entity.get("/log", []):
        for level in cols.get("TextLog:level", []):
            levels[level] += 1
    want_levels = {
        "WARN": sum(1 for r in trace if r["kind"] in ("collision", "suspect")),
        "ERROR": sum(1 for r in trace if r["kind"] == "crash"),
    }
    want_levels["INFO"] = len(trace) - silent - want_levels["WARN"] - want_levels["ERROR"]
    if {k: v for k, v in levels.items() if v} != {k: v for k, v in want_levels.items() if v}:
        fail(f"log levels {dict(levels)}, expected {want_levels}")

    print(
        f"verify_rrd: ok: {rrd.name}: {rows_checked} exact poses at their records, "
        f"{drawn_checked} drawn positions, "
        f"{checked} latest-at positions at {len(instants)} instants, "
        f"{moves} legs, {trail_points} trail points, {markers} collision markers, {spacetime} space-time arrows, {ends} arrows ending at the receive, {len(sends)} sends with arrows, "
        f"{flight_samples} in-flight samples, {lost_copies} lost copies, {switches} sensor switches, "
        f"{frames_checked} sensor frames, {queries} queries, {lcm_lights} lights, {lcm_looks} looks, "
        f"{rate_samples} event-rate samples, {log_rows} log lines, {views} blueprint views, "
        f"{name_strokes} name strokes, {len(outlines)} obstacles with {obstacle_hits} contacts on them, "
        f"plots {','.join(sorted(e.rsplit('/', 1)[1] for e in rows.by_entity if e.startswith('/metrics/')))}"
    )


if __name__ == "__main__":
    main()
