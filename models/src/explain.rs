//! A checker path told as what happened at each step: who received what from whom, what was
//! sent, delivered and decided. Each step is replayed through the same adapter functions the
//! checker ran, so the story is the protocol code's own.

use std::borrow::Cow;
use std::fmt::Write as _;

use nekosim_protocols::{Indication, Pid, Request, Wiring};
use stateright::actor::{ActorModelAction, Id, Out};
use stateright::Path;

use crate::adapter::{Happening, NetMsg, State};
use crate::config::{Action, CheckModel};

/// Something that happened in one step.
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    /// Process `process` did `what`.
    At { process: Pid, what: Happening },
    /// A process crashed.
    Crash(Pid),
    /// The (lossy) network lost a message.
    Drop { from: Pid, to: Pid, msg: NetMsg },
}

/// One step of a path; step 0 is the start of every process.
#[derive(Clone, Debug, PartialEq)]
pub struct Step {
    pub index: usize,
    pub events: Vec<Event>,
}

fn pid(id: Id) -> Pid {
    usize::from(id) as Pid
}

/// Replays `path` of `model` step by step.
pub fn explain(model: &CheckModel, path: &Path<State, Action>) -> Vec<Step> {
    let mut steps = Vec::new();
    let mut start = Vec::new();
    for (i, actor) in model.actors.iter().enumerate() {
        let mut log = Vec::new();
        actor.start(Id::from(i), &mut Out::new(), &mut log);
        start.extend(log.into_iter().map(|what| Event::At {
            process: i as Pid,
            what,
        }));
    }
    steps.push(Step {
        index: 0,
        events: start,
    });
    for (state, action) in path.clone().into_vec() {
        let Some(action) = action else { continue };
        let mut log = Vec::new();
        let events = match action {
            ActorModelAction::Deliver { src, dst, msg } => {
                let i = usize::from(dst);
                let mut s = Cow::Borrowed(&*state.actor_states[i]);
                model.actors[i].receive(dst, &mut s, src, msg, &mut Out::new(), &mut log);
                at(pid(dst), log)
            }
            ActorModelAction::Timeout(id, timer) => {
                let i = usize::from(id);
                let mut s = Cow::Borrowed(&*state.actor_states[i]);
                model.actors[i].fire(id, &mut s, &timer, &mut Out::new(), &mut log);
                at(pid(id), log)
            }
            ActorModelAction::Crash(id) => vec![Event::Crash(pid(id))],
            ActorModelAction::Drop(env) => vec![Event::Drop {
                from: pid(env.src),
                to: pid(env.dst),
                msg: env.msg,
            }],
            // Outside the model's boundary (recovery) or unused (randomness).
            ActorModelAction::Recover(_) | ActorModelAction::SelectRandom { .. } => Vec::new(),
        };
        steps.push(Step {
            index: steps.len(),
            events,
        });
    }
    steps
}

fn at(process: Pid, log: Vec<Happening>) -> Vec<Event> {
    log.into_iter()
        .map(|what| Event::At { process, what })
        .collect()
}

/// The name of layer `ix`.
pub fn layer_name(wiring: &Wiring, ix: u16) -> &str {
    wiring.ids.get(ix as usize).map_or("?", String::as_str)
}

/// One event as a line of text, messages in their protocols' readable forms.
pub fn describe(model: &CheckModel, e: &Event) -> String {
    let w = &model.actors[0].shared.wiring;
    nekosim_protocols::codec::with_codecs(&w.codecs, || describe_in(w, e))
}

fn describe_in(w: &Wiring, e: &Event) -> String {
    let name = |l| layer_name(w, l);
    match e {
        Event::Crash(p) => format!("p{p} crashes"),
        Event::Drop { from, to, msg } => {
            format!("the network loses {} from p{from} to p{to}", msg.msg)
        }
        Event::At { process: p, what } => match what {
            Happening::Request { layer, req } | Happening::Skipped { layer, req } => {
                let skipped = matches!(what, Happening::Skipped { .. });
                let ask = match req {
                    Request::Broadcast { msg } => format!("broadcast {}", msg),
                    Request::Propose { k, value } => {
                        format!("propose {} in instance {k}", value)
                    }
                    Request::Send { to, msg } => format!("send {} to {to:?}", msg),
                    Request::Custom(msg) => format!("request {msg}"),
                };
                if skipped {
                    format!("p{p} does not {ask} (it has seen the instance decided)")
                } else {
                    format!("p{p} asks {} to {ask}", name(*layer))
                }
            }
            Happening::Receive { from, layer, msg } => {
                format!("p{p} receives {} from p{from} at {}", msg, name(*layer))
            }
            Happening::Timer { layer, timer } => {
                format!(
                    "p{p}: timer {} of {} fires",
                    w.render_timer(*layer, timer),
                    name(*layer)
                )
            }
            Happening::Send { layer, to, msg } => {
                let mut s = String::new();
                for (i, d) in to.iter().enumerate() {
                    let _ = write!(s, "{}p{d}", if i > 0 { ", " } else { "" });
                }
                format!("p{p}: {} sends {} to {s}", name(*layer), msg)
            }
            Happening::Flush { to, msg } => {
                format!("p{p}: {} to p{to} leaves for the network", msg.msg)
            }
            Happening::App { layer, ind } => match ind {
                Indication::BDeliver { id, msg } => {
                    format!("p{p} DELIVERS {id} ({}) from {}", msg, name(*layer))
                }
                Indication::Decide { k, value } => {
                    format!("p{p} DECIDES {} in instance {k} ({})", value, name(*layer))
                }
                Indication::Deliver { from, msg } => {
                    format!("p{p} gets {} from p{from} ({})", msg, name(*layer))
                }
                Indication::Suspect(q) => format!("p{p} suspects p{q} ({})", name(*layer)),
                Indication::Trust(q) => format!("p{p} trusts p{q} ({})", name(*layer)),
                Indication::Leader(q) => format!("p{p}'s leader is p{q} ({})", name(*layer)),
                Indication::Custom(msg) => format!("p{p} gets {msg} ({})", name(*layer)),
            },
        },
    }
}
