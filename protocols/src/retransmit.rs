//! Retransmission over lossy links (acknowledgements and resends).
//!
//! Assumes: fair-lossy links (a message sent infinitely often is received infinitely often).
//! Guarantees: every message sent to a correct process is delivered to it exactly once
//! (reliable links, in no particular order; put [`crate::fifo::Fifo`] on top for order).

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;

use serde::{Deserialize, Serialize};

use crate::payload::Payload;
use crate::protocol::{FieldError, Microprotocol, Out, Round, Rounds};
use crate::service::{Ctx, Indication, LayerIx, Request, Service, Shape};
use crate::symmetry::Rename;
use crate::wire::{Pid, Real};

/// The retransmission layer's messages.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum RtMsg {
    /// The payload of layer `up` with its per-link number.
    Data {
        seq: u64,
        up: LayerIx,
        payload: Payload,
    },
    /// The receiver has the message `seq`.
    Ack { seq: u64 },
}

/// `Retransmit(period: 0.5)`.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RetransmitConfig {
    /// Resend period [s].
    pub period: f64,
}

/// The retransmission layer.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Retransmit {
    /// Resend period [s].
    period: Real,
    next: BTreeMap<Pid, u64>,
    unacked: BTreeMap<(Pid, u64), (LayerIx, Payload)>,
    delivered: BTreeSet<(Pid, u64)>,
    timer_on: bool,
}

impl Retransmit {
    /// Resends unacknowledged messages every `period` seconds.
    pub fn with_period(period: f64) -> Self {
        Self {
            period: Real::new(period),
            next: BTreeMap::new(),
            unacked: BTreeMap::new(),
            delivered: BTreeSet::new(),
            timer_on: false,
        }
    }

    fn arm(&mut self, out: &mut Out<Self>) {
        if !self.timer_on && !self.unacked.is_empty() {
            self.timer_on = true;
            out.set_timer((), self.period.get());
        }
    }
}

impl Microprotocol for Retransmit {
    type Msg = RtMsg;
    type Timer = ();
    type Config = RetransmitConfig;
    const NAME: &'static str = "Retransmit";
    const ROUNDS: Rounds = Rounds::Carried;

    fn round(m: &RtMsg) -> Round {
        match m {
            RtMsg::Data { payload, .. } => Round::Carries(payload.clone()),
            RtMsg::Ack { .. } => Round::None,
        }
    }

    fn shape(_: &RetransmitConfig) -> Shape {
        Shape::on_links(Service::P2P)
    }

    fn new(c: RetransmitConfig) -> Result<Self, FieldError> {
        FieldError::positive_seconds("period", c.period)?;
        Ok(Self::with_period(c.period))
    }

    fn on_request(&mut self, _ctx: &Ctx, from: LayerIx, req: Request, out: &mut Out<Self>) {
        if let Request::Send { to, msg } = req {
            for d in to {
                let seq = self.next.entry(d).or_insert(0);
                let data = RtMsg::Data {
                    seq: *seq,
                    up: from,
                    payload: msg.clone(),
                };
                self.unacked.insert((d, *seq), (from, msg.clone()));
                *seq += 1;
                out.send(vec![d], data);
            }
            self.arm(out);
        }
    }

    fn on_message(&mut self, _ctx: &Ctx, from: Pid, m: RtMsg, out: &mut Out<Self>) {
        match m {
            RtMsg::Data { seq, up, payload } => {
                out.send(vec![from], RtMsg::Ack { seq });
                if self.delivered.insert((from, seq)) {
                    out.up_to(up, Indication::Deliver { from, msg: payload });
                }
            }
            RtMsg::Ack { seq } => {
                self.unacked.remove(&(from, seq));
            }
        }
    }

    fn on_timer(&mut self, _ctx: &Ctx, _timer: (), out: &mut Out<Self>) {
        self.timer_on = false;
        for (&(d, seq), (up, msg)) in &self.unacked {
            out.send(
                vec![d],
                RtMsg::Data {
                    seq,
                    up: *up,
                    payload: msg.clone(),
                },
            );
        }
        self.arm(out);
    }

    fn renamed(&self, r: &Rename) -> Option<Self> {
        Some(Self {
            next: self.next.iter().map(|(p, n)| (r.pid(*p), *n)).collect(),
            unacked: self
                .unacked
                .iter()
                .map(|((p, seq), (up, m))| Some(((r.pid(*p), *seq), (*up, r.payload(m)?))))
                .collect::<Option<_>>()?,
            delivered: self
                .delivered
                .iter()
                .map(|(p, seq)| (r.pid(*p), *seq))
                .collect(),
            ..self.clone()
        })
    }

    fn renamed_msg(m: &RtMsg, r: &Rename) -> Option<RtMsg> {
        Some(match m {
            RtMsg::Data { seq, up, payload } => RtMsg::Data {
                seq: *seq,
                up: *up,
                payload: r.payload(payload)?,
            },
            RtMsg::Ack { seq } => RtMsg::Ack { seq: *seq },
        })
    }

    fn render(m: &RtMsg, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match m {
            RtMsg::Data { seq, payload, .. } => write!(f, "RT_DATA#{seq}({payload})"),
            RtMsg::Ack { seq } => write!(f, "RT_ACK#{seq}"),
        }
    }
}
