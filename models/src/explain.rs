//! A checker path told as what happened at each step: who received what from whom, what was
//! sent, delivered and decided. Each step is replayed through the same adapter functions the
//! checker ran, so the story is the protocol code's own.

use std::borrow::Cow;
use std::fmt::{self, Write as _};

use nekosim_protocols::{Indication, Pid, Request, Wire, Wiring};
use stateright::actor::{ActorModelAction, Id, Out};
use stateright::Path;

use crate::adapter::{Happening, NetMsg};
use crate::model::{Action, CheckModel};
use crate::property::State;

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

/// A message in a short, readable form: headers with their key fields around the
/// application message.
#[derive(Debug)]
pub struct Describe<'a>(pub &'a Wire);

impl<'a> fmt::Display for Describe<'a> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let d = |w: &'a Wire| Describe(w);
        match self.0 {
            Wire::App { kind, content } => write!(f, "{kind} {content}"),
            Wire::Fifo { seq, inner, .. } => write!(f, "FIFO#{seq}({})", d(inner)),
            Wire::RtData { seq, inner, .. } => write!(f, "RT_DATA#{seq}({})", d(inner)),
            Wire::RtAck { seq } => write!(f, "RT_ACK#{seq}"),
            Wire::Rb { id, inner } => write!(f, "RB({id}, {})", d(inner)),
            Wire::LamportMsg { ts, id, inner } => {
                write!(f, "LAMPORT(ts {ts}, {id}, {})", d(inner))
            }
            Wire::LamportAck { ts } => write!(f, "LAMPORT_ACK(ts {ts})"),
            Wire::SeqRequest { id, inner } => write!(f, "SEQ_REQUEST({id}, {})", d(inner)),
            Wire::SeqOrder { gseq, id, inner } => {
                write!(f, "SEQ_ORDER(#{gseq}, {id}, {})", d(inner))
            }
            Wire::Heartbeat => write!(f, "HEARTBEAT"),
            Wire::CtEstimate { k, r, est, ts } => {
                write!(f, "CT_ESTIMATE(k {k}, r {r}, {}, ts {ts})", d(est))
            }
            Wire::CtPropose { k, r, value } => write!(f, "CT_PROPOSE(k {k}, r {r}, {})", d(value)),
            Wire::CtAck { k, r } => write!(f, "CT_ACK(k {k}, r {r})"),
            Wire::CtNack { k, r } => write!(f, "CT_NACK(k {k}, r {r})"),
            Wire::CtDecide { k, value } => write!(f, "CT_DECIDE(k {k}, {})", d(value)),
            Wire::Batch(items) => {
                let ids: Vec<String> = items.iter().map(|(id, _)| id.to_string()).collect();
                write!(f, "batch[{}]", ids.join(","))
            }
            other => write!(f, "{}", other.type_name()),
        }
    }
}

/// The name of layer `ix`.
pub fn layer_name(wiring: &Wiring, ix: u16) -> &str {
    wiring.ids.get(ix as usize).map_or("?", String::as_str)
}

/// One event as a line of text.
pub fn describe(model: &CheckModel, e: &Event) -> String {
    let w = &model.actors[0].shared.wiring;
    let name = |l| layer_name(w, l);
    match e {
        Event::Crash(p) => format!("p{p} crashes"),
        Event::Drop { from, to, msg } => format!(
            "the network loses {} from p{from} to p{to}",
            Describe(&msg.msg)
        ),
        Event::At { process: p, what } => match what {
            Happening::Request { layer, req } | Happening::Skipped { layer, req } => {
                let skipped = matches!(what, Happening::Skipped { .. });
                let ask = match req {
                    Request::Broadcast { msg } => format!("broadcast {}", Describe(msg)),
                    Request::Propose { k, value } => {
                        format!("propose {} in instance {k}", Describe(value))
                    }
                    Request::Send { to, msg } => format!("send {} to {to:?}", Describe(msg)),
                };
                if skipped {
                    format!("p{p} does not {ask} (it has seen the instance decided)")
                } else {
                    format!("p{p} asks {} to {ask}", name(*layer))
                }
            }
            Happening::Receive { from, layer, msg } => format!(
                "p{p} receives {} from p{from} at {}",
                Describe(msg),
                name(*layer)
            ),
            Happening::Timer { layer, timer } => {
                format!("p{p}: timer {timer} of {} fires", name(*layer))
            }
            Happening::Send { layer, to, msg } => {
                let mut s = String::new();
                for (i, d) in to.iter().enumerate() {
                    let _ = write!(s, "{}p{d}", if i > 0 { ", " } else { "" });
                }
                format!("p{p}: {} sends {} to {s}", name(*layer), Describe(msg))
            }
            Happening::Flush { to, msg } => format!(
                "p{p}: {} to p{to} leaves for the network",
                Describe(&msg.msg)
            ),
            Happening::App { layer, ind } => match ind {
                Indication::BDeliver { id, msg } => format!(
                    "p{p} DELIVERS {id} ({}) from {}",
                    Describe(msg),
                    name(*layer)
                ),
                Indication::Decide { k, value } => format!(
                    "p{p} DECIDES {} in instance {k} ({})",
                    Describe(value),
                    name(*layer)
                ),
                Indication::Deliver { from, msg } => format!(
                    "p{p} gets {} from p{from} ({})",
                    Describe(msg),
                    name(*layer)
                ),
                Indication::Suspect(q) => format!("p{p} suspects p{q} ({})", name(*layer)),
                Indication::Trust(q) => format!("p{p} trusts p{q} ({})", name(*layer)),
                Indication::Leader(q) => format!("p{p}'s leader is p{q} ({})", name(*layer)),
            },
        },
    }
}
