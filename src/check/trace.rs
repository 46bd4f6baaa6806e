//! A checker's path as records: the JSONL trace (docs/trace.md, "Model-checker traces") and
//! the Rerun recording of a counterexample or witness, both views of the same records.

use std::io;
use std::path::Path;

use nekosim_actors::protocol_record;
use nekosim_actors::world::observation::{Observation, Record};
use nekosim_models::adapter::Happening;
use nekosim_models::explain::{explain, layer_name, Event, Step};
#[cfg(feature = "rerun")]
use nekosim_models::reason::reason;
use nekosim_models::{CheckModel, Outcome};
use nekosim_protocols::codec::{install, type_word};
use nekosim_protocols::{Payload, Pid};
use serde::Serialize;
use stateright::Expectation;

use crate::log::wire_text;
use crate::output::AtomicFile;
use crate::recording::RecordingError;

/// Distance between two process lanes in a counterexample recording.
#[cfg(feature = "rerun")]
const LANE: f64 = 10.0;
/// The radius of a process's marker in a check recording's world view.
#[cfg(feature = "rerun")]
const MARKER: f64 = 1.0;

/// Where process `p` of `n` stands in a check recording's world view: on a circle of radius
/// [`ring_radius`] around the origin, p0 at the top and the others clockwise, so that no
/// arrow between two processes runs through a third.
#[cfg(feature = "rerun")]
fn ring_position(p: u32, n: usize) -> (f64, f64) {
    let a = std::f64::consts::FRAC_PI_2 - std::f64::consts::TAU * f64::from(p) / n.max(1) as f64;
    let r = ring_radius(n);
    (r * a.cos(), r * a.sin())
}

/// The radius of the circle of [`ring_position`]: `LANE` for up to three processes, growing
/// with their number so neighbours stay about `LANE` apart.
#[cfg(feature = "rerun")]
fn ring_radius(n: usize) -> f64 {
    LANE * (n as f64 / 3.0).max(1.0)
}

/// Saves the traced path (see [`traced`]) as a Rerun recording: process `p` stands still at
/// [`ring_position`]; each step is one simulated second, so a message's arrow goes
/// from the sender's lane to the receiver's and stays from the step that sent it to the step
/// that received it; deliveries, decisions, timers, losses and crashes are log lines (a
/// crashed process turns grey), and the log opens and ends with the verdict. No path, no file.
#[cfg(feature = "rerun")]
pub(super) fn write_recording(
    name: &str,
    model: &CheckModel,
    outcome: &Outcome,
    lasso: Option<(usize, &str)>,
    path: &Path,
) -> Result<(), RecordingError> {
    use crate::recording::rerun_canvas::{Layout, RerunCanvas};
    use crate::recording::{Canvas, Level, Recorder, Stamp, Target};
    use nekosim_actors::world::geometry::Point;
    use nekosim_actors::world::motion::{Kinematics, Pose};
    use nekosim_actors::world::virtual_world::WorldSize;

    let Some(v) = traced(outcome) else {
        return Ok(());
    };
    let steps = explain(model, v.path.as_ref().expect("traced paths exist"));
    let _codecs = install(&model.actors[0].shared.wiring.codecs);
    let n = model.actors.len();
    let lane = |p: u32| {
        let (x, y) = ring_position(p, n);
        Point::new(x, y)
    };
    // The ring with a marker's diameter around it.
    let edge = ring_radius(n) + 2.0 * MARKER;
    let (min, max) = (Point::new(-edge, -edge), Point::new(edge, edge));
    let size = WorldSize::Bounded { min, max };
    let target = Target {
        rrd: Some(path.to_path_buf()),
        connect: None,
    };
    let title = format!("check {name}");
    let id = format!("{title} {:?} {} steps", v.name, steps.len());
    let layout = Layout::check((min, max), n, steps.len(), MARKER);
    let canvas = RerunCanvas::start(&title, &id, &target, &layout)?;
    let mut rec = Recorder::new(canvas, &size, 0.0);
    for p in 0..n as u32 {
        rec.record(&Record {
            t: 0.0,
            seq: 0,
            obs: Observation::Spawn {
                robot: p,
                pos: lane(p),
                angle: 90.0,
                radius: MARKER,
            },
        });
    }
    let verdict = format!(
        "{} {:?} ({}): {} in {} steps",
        if v.holds {
            "witness of"
        } else {
            "counterexample of"
        },
        v.name,
        name,
        if v.holds { "reached" } else { "violated" },
        steps.len()
    );
    let start = Stamp {
        t: 0.0,
        seq: Some(0),
    };
    let verdict_level = if v.holds { Level::Info } else { Level::Error };
    // The verdict in full, beside the diagram.
    let statement = nekosim_models::property::statement(v.name)
        .map(|s| format!("\n\n> **{}**: {s}", v.name))
        .unwrap_or_default();
    let why = v
        .path
        .as_ref()
        .filter(|_| !v.holds)
        .and_then(|p| reason(model, v.name, p))
        .map(|r| format!("\n\n{r}"))
        .unwrap_or_default();
    // A lasso's path is its stem and its cycle once: say where the cycle begins, and why.
    let statement = match lasso {
        Some((stem, reason)) => {
            let temporal = nekosim_models::temporal::temporal_properties(model)
                .into_iter()
                .find(|t| t.name == v.name)
                .map(|t| format!("\n\n> **{}**: {}", t.name, t.kind.formula(t.predicate)))
                .unwrap_or_default();
            format!(
                "{temporal}\n\nA lasso: the cycle begins after step {stem} and repeats for ever.\n\n{reason}"
            )
        }
        None => format!("{statement}{why}"),
    };
    rec.canvas_mut().note(&format!("### {verdict}{statement}"));
    rec.canvas_mut().log(start, verdict_level, &verdict);
    let items = path_items(model, &steps);
    let dropped = dropped_copies(&items);
    for (item, dropped) in items.into_iter().zip(dropped) {
        match item {
            Item::Obs(r) => rec.record_dropping(&r, &dropped),
            Item::Check(x) => match x.event {
                CheckEvent::Crash { robot } => rec.record(&Record {
                    t: x.t,
                    seq: x.seq,
                    obs: Observation::Crash {
                        robot,
                        state: Kinematics::at_rest(Pose {
                            pos: lane(robot),
                            angle: 90.0,
                        }),
                    },
                }),
                _ => rec.canvas_mut().log(
                    Stamp {
                        t: x.t,
                        seq: Some(x.seq),
                    },
                    Level::Info,
                    &x.line(),
                ),
            },
        }
    }
    let end = steps.len() as f64;
    rec.finish(end);
    let last = steps.len() as u64;
    rec.canvas_mut().log(
        Stamp {
            t: end,
            seq: Some(last),
        },
        verdict_level,
        &verdict,
    );
    rec.canvas_mut().finish()
}

#[cfg(not(feature = "rerun"))]
pub(super) fn write_recording(
    _: &str,
    _: &CheckModel,
    _: &Outcome,
    _: Option<(usize, &str)>,
    _: &Path,
) -> Result<(), RecordingError> {
    Err(RecordingError::Unsupported)
}

/// The path the trace shows: the first counterexample, else the first witness.
fn traced(outcome: &Outcome) -> Option<&nekosim_models::Verdict> {
    outcome
        .verdicts
        .iter()
        .find(|v| !v.holds && v.path.is_some())
        .or_else(|| {
            outcome
                .verdicts
                .iter()
                .find(|v| v.expectation == Expectation::Sometimes && v.path.is_some())
        })
}

/// Writes the traced path as JSONL (schema: docs/trace.md); no path, no file. A lasso's path
/// (its stem, then its cycle once) ends with a record `{"kind":"lasso","cycle_from":K,
/// "reason":...}`: the cycle runs from the state after step `K` back to it and repeats for
/// ever.
pub(super) fn write_trace(
    model: &CheckModel,
    outcome: &Outcome,
    lasso: Option<(usize, &str)>,
    path: &Path,
) -> io::Result<()> {
    let Some(v) = traced(outcome) else {
        return Ok(());
    };
    let steps = explain(model, v.path.as_ref().expect("traced paths exist"));
    let mut file = AtomicFile::create(path)?;
    for line in trace_lines(model, &steps) {
        file.line(&line);
    }
    if let Some((cycle_from, reason)) = lasso {
        let last = serde_json::json!({
            "kind": "lasso",
            "property": v.name,
            "cycle_from": cycle_from,
            "reason": reason,
        });
        file.line(&last.to_string());
    }
    file.commit()
}

/// One JSON object per event; `t` and `seq` are the step number.
pub fn trace_lines(model: &CheckModel, steps: &[Step]) -> Vec<String> {
    let _codecs = install(&model.actors[0].shared.wiring.codecs);
    path_items(model, steps)
        .into_iter()
        .map(|item| match item {
            Item::Obs(r) => crate::trace::to_line(&r),
            Item::Check(r) => r.line(),
        })
        .collect()
}

/// What names a copy on its way in a path: sender, receiver, layer and message.
#[cfg_attr(not(feature = "rerun"), allow(dead_code))]
type CopyKey<'a> = (Pid, Pid, &'a str, &'a Payload);

/// For each item of a path, which copies of its send (by index in its `to`) the network
/// drops at a later step. A loss, like a receive, ends the oldest copy on its way with the
/// same sender, receiver, layer and message: such copies are alike, so which one is lost
/// changes nothing of what is shown, and a receive never takes a copy that a loss ends.
#[cfg_attr(not(feature = "rerun"), allow(dead_code))]
fn dropped_copies(items: &[Item]) -> Vec<Vec<bool>> {
    use std::collections::{HashMap, VecDeque};

    let mut dropped: Vec<Vec<bool>> = items.iter().map(|_| Vec::new()).collect();
    // Per sender, receiver, layer and message, the copies on their way (item, copy), oldest
    // first.
    let mut waiting: HashMap<CopyKey, VecDeque<(usize, usize)>> = HashMap::new();
    for (i, item) in items.iter().enumerate() {
        match item {
            Item::Obs(Record {
                obs:
                    Observation::Send {
                        robot,
                        to,
                        layer,
                        msg,
                        ..
                    },
                ..
            }) => {
                dropped[i] = vec![false; to.len()];
                for (k, dest) in to.iter().enumerate() {
                    let key = (*robot, *dest, layer.as_str(), msg);
                    waiting.entry(key).or_default().push_back((i, k));
                }
            }
            Item::Obs(Record {
                obs:
                    Observation::Receive {
                        robot,
                        from,
                        layer,
                        msg,
                    },
                ..
            }) => {
                let key = (*from, *robot, layer.as_str(), msg);
                waiting.get_mut(&key).and_then(VecDeque::pop_front);
            }
            Item::Check(CheckRecord {
                event:
                    CheckEvent::Drop {
                        robot,
                        to: [to],
                        layer,
                        payload,
                        ..
                    },
                ..
            }) => {
                let key = (*robot, *to, layer.as_str(), payload);
                if let Some((j, k)) = waiting.get_mut(&key).and_then(VecDeque::pop_front) {
                    dropped[j][k] = true;
                }
            }
            _ => {}
        }
    }
    dropped
}

/// An event of a path: a simulator observation, or a kind only model-checking traces have.
enum Item {
    Obs(Record),
    Check(CheckRecord),
}

/// A record only model-checking traces have (docs/trace.md, "Model-checker traces"): `t`
/// and `seq` are the step number.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CheckRecord {
    pub t: f64,
    pub seq: u64,
    #[serde(flatten)]
    pub event: CheckEvent,
}

/// What happened in a model that a simulation has no record for.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum CheckEvent {
    /// The process crashed (no position: processes have none in a model).
    Crash { robot: Pid },
    /// The lossy network lost a message of `robot` for `to`.
    Drop {
        robot: Pid,
        to: [Pid; 1],
        layer: String,
        msg: String,
        /// The message's type, the first word of `msg`.
        #[serde(rename = "type")]
        ty: String,
        /// The message itself, which finds the copy the loss ends (the trace shows `msg`).
        #[serde(skip)]
        payload: Payload,
    },
    /// A protocol timer fired (the checker fires timers whenever it likes).
    Timer {
        robot: Pid,
        layer: String,
        timer: Payload,
    },
}

impl CheckRecord {
    /// Its JSON line.
    pub fn line(&self) -> String {
        serde_json::to_string(self).expect("check records serialize")
    }
}

/// The events of a path in order; `t` and `seq` are the step number.
fn path_items(model: &CheckModel, steps: &[Step]) -> Vec<Item> {
    let wiring = &model.actors[0].shared.wiring;
    let staged = model.actors[0].shared.staged_sends;
    let name = |l: u16| layer_name(wiring, l).to_string();
    let mut lines = Vec::new();
    for step in steps {
        let seq = step.index as u64;
        let t = step.index as f64;
        let record = |obs: Observation| Item::Obs(Record { t, seq, obs });
        let check = |event: CheckEvent| Item::Check(CheckRecord { t, seq, event });
        for e in &step.events {
            let line = match e {
                Event::Crash(p) => Some(check(CheckEvent::Crash { robot: *p })),
                Event::Drop { from, to, msg } => {
                    let text = wire_text(&msg.msg);
                    Some(check(CheckEvent::Drop {
                        robot: *from,
                        to: [*to],
                        layer: name(msg.layer),
                        ty: type_word(&text).to_string(),
                        msg: text,
                        payload: msg.msg.clone(),
                    }))
                }
                Event::At { process: p, what } => match what {
                    Happening::Request { layer, req } => {
                        Some(record(protocol_record::request(*p, name(*layer), req)))
                    }
                    Happening::Skipped { .. } => None,
                    Happening::Receive { from, layer, msg } => Some(record(
                        protocol_record::receive(*p, name(*layer), *from, msg),
                    )),
                    Happening::Timer { layer, timer } => Some(check(CheckEvent::Timer {
                        robot: *p,
                        layer: name(*layer),
                        timer: timer.clone(),
                    })),
                    Happening::Send { layer, to, msg } if !staged => {
                        Some(record(Observation::Send {
                            robot: *p,
                            to: to.clone(),
                            layer: name(*layer),
                            msg: msg.clone(),
                            arrive: Vec::new(),
                        }))
                    }
                    Happening::Send { .. } => None,
                    Happening::Flush { to, msg } => Some(record(Observation::Send {
                        robot: *p,
                        to: vec![*to],
                        layer: name(msg.layer),
                        msg: msg.msg.clone(),
                        arrive: Vec::new(),
                    })),
                    Happening::App { layer, ind } => {
                        protocol_record::indication(*p, name(*layer), ind).map(record)
                    }
                },
            };
            lines.extend(line);
        }
    }
    lines
}
