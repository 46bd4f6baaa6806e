//! `nekosim check MODEL`: model-check a protocol stack with stateright (the protocol code the
//! simulator runs), print the checker's figures and each property's verdict, explain every
//! counterexample step by step, and optionally write it (or a witness) as a JSONL trace with
//! `seq` as the step number. Models and properties: docs/model-checking.md.

use std::io::{self, Write};
use std::path::{Path, PathBuf};

use nekosim_actors::world::observation::{Observation, Record};
use nekosim_models::adapter::Happening;
use nekosim_models::explain::{describe, explain, layer_name, Event, Step};
use nekosim_models::{
    build, find, run, CheckModel, Exploration, ModelError, NetworkKind, Options, Outcome, MODELS,
};
use nekosim_protocols::{Indication, Request};
use serde_json::{json, Map, Value};
use stateright::Expectation;

use crate::log::wire_text;
use crate::output::AtomicFile;
use crate::recording::RecordingError;
use nekosim_protocols::payload::{install, type_word};

/// What the command was asked to check.
#[derive(Clone, Debug, PartialEq)]
pub struct CheckArgs {
    pub model: String,
    pub processes: u32,
    pub requests: u32,
    pub crashes: u32,
    pub network: NetworkKind,
    pub depth: Option<usize>,
    pub threads: usize,
    pub trace: Option<PathBuf>,
    /// Save the counterexample (or witness) as a Rerun recording here.
    pub rrd: Option<PathBuf>,
    /// Protocol timer firings per process; the model's default when `None`.
    pub timers: Option<u32>,
    /// Last Chandra-Toueg round explored.
    pub rounds: Option<u64>,
}

/// Why a check could not run.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CheckError {
    /// Bad arguments (exit 2).
    #[error("unknown model {name:?}; expected one of {known}")]
    UnknownModel { name: String, known: String },
    /// Bad arguments (exit 2).
    #[error("{0}")]
    Model(#[from] ModelError),
    /// The trace file could not be written (exit 2, like any output the user names).
    #[error("cannot write the trace {}: {source}", path.display())]
    Trace { path: PathBuf, source: io::Error },
    /// The recording could not be made (exit 2 when the user's input is at fault).
    #[error(transparent)]
    Recording(#[from] RecordingError),
}

/// The model names, one per line.
pub fn list() -> String {
    MODELS.iter().map(|m| format!("{}\n", m.name)).collect()
}

/// Runs a check and prints its report on `out`; `Ok(true)` when every property holds.
pub fn check(args: &CheckArgs, out: &mut dyn Write) -> Result<bool, CheckError> {
    let def = find(&args.model).ok_or_else(|| CheckError::UnknownModel {
        name: args.model.clone(),
        known: MODELS.iter().map(|m| m.name).collect::<Vec<_>>().join(", "),
    })?;
    let defaults = Options::default();
    let opts = Options {
        processes: args.processes,
        requests: args.requests,
        crashes: args.crashes,
        network: args.network,
        timer_budget: args.timers.unwrap_or(defaults.timer_budget),
        max_round: args.rounds.unwrap_or(defaults.max_round),
        partial_multicasts: defaults.partial_multicasts,
    };
    let model = build(&def.target(), &opts, |_, _| {})?;
    // Outputs that can never be written are refused before the search, which may be long.
    let is_dir = || io::Error::new(io::ErrorKind::InvalidInput, "is a directory");
    if let Some(path) = args.trace.as_ref().filter(|p| p.is_dir()) {
        return Err(CheckError::Trace {
            path: path.clone(),
            source: is_dir(),
        });
    }
    if let Some(path) = args.rrd.as_ref().filter(|p| p.is_dir()) {
        return Err(RecordingError::Create {
            path: path.display().to_string(),
            message: is_dir().to_string(),
        }
        .into());
    }
    // The command times the checker; the models crate never reads the wall clock.
    let start = std::time::Instant::now();
    let outcome = run(
        model.clone(),
        Exploration {
            threads: args.threads,
            depth: args.depth,
            first_counterexample: false,
        },
    );
    let seconds = start.elapsed().as_secs_f64();
    let network = NetworkKind::NAMES[match args.network {
        NetworkKind::Unordered => 0,
        NetworkKind::Ordered => 1,
        NetworkKind::Lossy => 2,
    }];
    let w = |out: &mut dyn Write, s: String| {
        let _ = writeln!(out, "{s}");
    };
    w(
        out,
        format!(
            "model: {} ({}): {} processes, {} requests, {} crashes, {network} network, timer budget {}, last round {}{}",
            def.name,
            def.about,
            opts.processes,
            opts.requests,
            opts.crashes,
            opts.timer_budget,
            opts.max_round,
            args.depth.map_or(String::new(), |d| format!(", depth bound {d}")),
        ),
    );
    w(
        out,
        format!(
            "states: {}, unique states: {}, depth: {}, seconds: {:.3}, states/s: {:.0}",
            outcome.states,
            outcome.unique_states,
            outcome.max_depth,
            seconds,
            outcome.states as f64 / seconds.max(1e-9)
        ),
    );
    for v in &outcome.verdicts {
        let how = match v.expectation {
            Expectation::Always => "always",
            Expectation::Sometimes => "sometimes",
            Expectation::Eventually => "eventually",
        };
        let detail = match (&v.expectation, &v.path) {
            (Expectation::Sometimes, Some(p)) => {
                format!(": witness in {} steps", p.clone().into_actions().len())
            }
            (Expectation::Sometimes, None) => ": never reached".to_string(),
            (_, Some(p)) => format!(
                ": counterexample in {} steps",
                p.clone().into_actions().len()
            ),
            (_, None) => String::new(),
        };
        w(
            out,
            format!(
                "  {} {} ({how}){detail}",
                if v.holds { "holds " } else { "FAILS " },
                v.name
            ),
        );
    }
    for v in outcome.verdicts.iter().filter(|v| !v.holds) {
        if let Some(path) = &v.path {
            w(out, format!("counterexample of {:?}:", v.name));
            for step in explain(&model, path) {
                for (i, e) in step.events.iter().enumerate() {
                    let head = if i == 0 {
                        format!("step {:>3}:", step.index)
                    } else {
                        " ".repeat(9)
                    };
                    w(out, format!("  {head} {}", describe(&model, e)));
                }
            }
        }
    }
    if let Some(path) = &args.trace {
        write_trace(&model, &outcome, path).map_err(|source| CheckError::Trace {
            path: path.clone(),
            source,
        })?;
    }
    if let Some(path) = &args.rrd {
        write_recording(&args.model, &model, &outcome, path)?;
    }
    Ok(outcome.all_hold())
}

/// Distance between two process lanes in a counterexample recording.
#[cfg(feature = "rerun")]
const LANE: f64 = 10.0;

/// Saves the traced path (see [`traced`]) as a Rerun recording: process `p` stands still at
/// `(LANE * p, 0)`, its lane; each step is one simulated second, so a message's arrow goes
/// from the sender's lane to the receiver's and stays from the step that sent it to the step
/// that received it; deliveries, decisions, timers, losses and crashes are log lines (a
/// crashed process turns grey), and the log opens and ends with the verdict. No path, no file.
#[cfg(feature = "rerun")]
fn write_recording(
    name: &str,
    model: &CheckModel,
    outcome: &Outcome,
    path: &Path,
) -> Result<(), RecordingError> {
    use crate::recording::rerun_canvas::RerunCanvas;
    use crate::recording::{Canvas, Recorder, Stamp, Target};
    use nekosim_actors::world::geometry::Point;
    use nekosim_actors::world::motion::{Kinematics, Pose};
    use nekosim_actors::world::virtual_world::WorldSize;

    let Some(v) = traced(outcome) else {
        return Ok(());
    };
    let steps = explain(model, v.path.as_ref().expect("traced paths exist"));
    let _codecs = install(&model.actors[0].shared.wiring.codecs);
    let n = model.actors.len();
    let lane = |p: u32| Point::new(LANE * p as f64, 0.0);
    let size = WorldSize::Bounded {
        min: Point::new(-LANE, -LANE),
        max: Point::new(LANE * n as f64, LANE),
    };
    let target = Target {
        rrd: Some(path.to_path_buf()),
        connect: None,
    };
    let title = format!("check {name}");
    let id = format!("{title} {:?} {} steps", v.name, steps.len());
    let canvas = RerunCanvas::start(&title, &id, &target, n)?;
    let mut rec = Recorder::new(canvas, &size, 0.0);
    for p in 0..n as u32 {
        rec.record(&Record {
            t: 0.0,
            seq: 0,
            obs: Observation::Spawn {
                robot: p,
                pos: lane(p),
                angle: 90.0,
                radius: 1.0,
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
    rec.canvas_mut().log(start, &verdict);
    for item in path_items(model, &steps) {
        match item {
            Item::Obs(r) => rec.record(&r),
            Item::Extra(x) => {
                let (t, seq) = (
                    x["t"].as_f64().unwrap_or(0.0),
                    x["seq"].as_u64().unwrap_or(0),
                );
                if x["kind"] == "crash" {
                    let p = x["robot"].as_u64().unwrap_or(0) as u32;
                    rec.record(&Record {
                        t,
                        seq,
                        obs: Observation::Crash {
                            robot: p,
                            state: Kinematics::at_rest(Pose {
                                pos: lane(p),
                                angle: 90.0,
                            }),
                        },
                    });
                } else {
                    rec.canvas_mut()
                        .log(Stamp { t, seq: Some(seq) }, &x.to_string());
                }
            }
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
        &verdict,
    );
    rec.canvas_mut().finish()
}

#[cfg(not(feature = "rerun"))]
fn write_recording(_: &str, _: &CheckModel, _: &Outcome, _: &Path) -> Result<(), RecordingError> {
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

/// Writes the traced path as JSONL (schema: docs/trace.md); no path, no file.
fn write_trace(model: &CheckModel, outcome: &Outcome, path: &Path) -> io::Result<()> {
    let Some(v) = traced(outcome) else {
        return Ok(());
    };
    let steps = explain(model, v.path.as_ref().expect("traced paths exist"));
    let mut file = AtomicFile::create(path)?;
    for line in trace_lines(model, &steps) {
        file.line(&line);
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
            Item::Extra(v) => v.to_string(),
        })
        .collect()
}

/// An event of a path: a simulator observation, or a kind only model-checking traces have
/// (`timer`, `drop`, `crash` without a position; docs/trace.md).
enum Item {
    Obs(Record),
    Extra(Value),
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
        let custom = |kind: &str, fields: Vec<(&str, Value)>| {
            let mut m = Map::new();
            m.insert("t".into(), json!(t));
            m.insert("seq".into(), json!(seq));
            m.insert("kind".into(), json!(kind));
            for (k, v) in fields {
                m.insert(k.into(), v);
            }
            Item::Extra(Value::Object(m))
        };
        for e in &step.events {
            let line = match e {
                Event::Crash(p) => Some(custom("crash", vec![("robot", json!(p))])),
                Event::Drop { from, to, msg } => Some(custom(
                    "drop",
                    vec![
                        ("robot", json!(from)),
                        ("to", json!([to])),
                        ("layer", json!(name(msg.layer))),
                        ("msg", json!(wire_text(&msg.msg))),
                        ("type", json!(type_word(&wire_text(&msg.msg)))),
                    ],
                )),
                Event::At { process: p, what } => match what {
                    Happening::Request { layer, req } => {
                        let (op, msg) = match req {
                            Request::Broadcast { msg } => ("broadcast", msg.clone()),
                            Request::Propose { value, .. } => ("propose", value.clone()),
                            Request::Send { msg, .. } => ("send", msg.clone()),
                            Request::Custom(msg) => ("request", msg.clone()),
                        };
                        Some(record(Observation::Request {
                            robot: *p,
                            layer: name(*layer),
                            op: op.into(),
                            msg,
                        }))
                    }
                    Happening::Skipped { .. } => None,
                    Happening::Receive { from, layer, msg } => Some(record(Observation::Receive {
                        robot: *p,
                        from: *from,
                        layer: name(*layer),
                        msg: msg.clone(),
                    })),
                    Happening::Timer { layer, timer } => Some(custom(
                        "timer",
                        vec![
                            ("robot", json!(p)),
                            ("layer", json!(name(*layer))),
                            ("timer", json!(timer)),
                        ],
                    )),
                    Happening::Send { layer, to, msg } if !staged => {
                        Some(record(Observation::Send {
                            robot: *p,
                            to: to.clone(),
                            layer: name(*layer),
                            msg: msg.clone(),
                        }))
                    }
                    Happening::Send { .. } => None,
                    Happening::Flush { to, msg } => Some(record(Observation::Send {
                        robot: *p,
                        to: vec![*to],
                        layer: name(msg.layer),
                        msg: msg.msg.clone(),
                    })),
                    Happening::App { layer, ind } => {
                        let layer = name(*layer);
                        match ind {
                            Indication::BDeliver { id, msg } => {
                                Some(record(Observation::Deliver {
                                    robot: *p,
                                    layer,
                                    id: *id,
                                    msg: msg.clone(),
                                }))
                            }
                            Indication::Decide { k, value } => Some(record(Observation::Decide {
                                robot: *p,
                                layer,
                                k: *k,
                                value: value.clone(),
                            })),
                            Indication::Suspect(q) => Some(record(Observation::Suspect {
                                robot: *p,
                                layer,
                                process: *q,
                            })),
                            Indication::Trust(q) => Some(record(Observation::Trust {
                                robot: *p,
                                layer,
                                process: *q,
                            })),
                            Indication::Leader(q) => Some(record(Observation::Leader {
                                robot: *p,
                                layer,
                                process: *q,
                            })),
                            Indication::Deliver { .. } | Indication::Custom(_) => None,
                        }
                    }
                },
            };
            lines.extend(line);
        }
    }
    lines
}
