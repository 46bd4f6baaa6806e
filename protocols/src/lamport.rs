//! Lamport's total-order broadcast over FIFO links (Neko's abcast.Lamport).
//!
//! Assumes: reliable FIFO links, no crashes (a crashed process blocks delivery everywhere).
//! Guarantees: every process delivers every broadcast message once, all in the same order:
//! messages are ordered by (Lamport timestamp, origin), and a process delivers the first
//! pending message once it has heard from every other process something stamped at least as
//! late (every receiver acknowledges every message to all, so that always happens). FIFO links
//! make "heard something later from q" mean q will never send anything earlier.

use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Serialize};

use crate::payload::Payload;
use crate::protocol::{FieldError, Microprotocol, NoConfig, Out};
use crate::service::{Ctx, Indication, LayerIx, Request, Service, Shape};
use crate::wire::{MsgId, Pid};

/// Lamport's messages: a timestamped broadcast message, or an acknowledgement carrying a
/// clock.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum LamportMsg {
    Msg {
        ts: u64,
        id: MsgId,
        payload: Payload,
    },
    Ack {
        ts: u64,
    },
}

/// The Lamport total-order broadcast layer.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct LamportAbcast {
    clock: u64,
    count: u64,
    pending: BTreeMap<(u64, MsgId), Payload>,
    /// Latest timestamp heard from each process.
    latest: BTreeMap<Pid, u64>,
    /// Deliver without waiting to hear from every process (the deliberately broken variant).
    eager: bool,
}

impl LamportAbcast {
    /// A broken variant that delivers as soon as a message arrives: total order fails.
    pub fn eager() -> Self {
        Self {
            eager: true,
            ..Self::default()
        }
    }

    fn heard(&mut self, p: Pid, ts: u64) {
        let l = self.latest.entry(p).or_insert(0);
        *l = (*l).max(ts);
    }

    fn try_deliver(&mut self, ctx: &Ctx, out: &mut Out<Self>) {
        while let Some((&(ts, id), _)) = self.pending.first_key_value() {
            let ready = self.eager
                || (0..ctx.n)
                    .all(|q| q == id.origin || self.latest.get(&q).copied().unwrap_or(0) >= ts);
            if !ready {
                break;
            }
            let msg = self.pending.remove(&(ts, id)).expect("first");
            out.up(Indication::BDeliver { id, msg });
        }
    }
}

impl Microprotocol for LamportAbcast {
    type Msg = LamportMsg;
    type Timer = ();
    type Config = NoConfig;
    const NAME: &'static str = "abcast.Lamport";

    fn shape(_: &NoConfig) -> Shape {
        Shape {
            provides: Service::TOTAL_ORDER,
            needs_below: Service::FIFO_P2P,
            needs_uses: vec![],
        }
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Ok(Self::default())
    }

    fn on_request(&mut self, ctx: &Ctx, _from: LayerIx, req: Request, out: &mut Out<Self>) {
        if let Request::Broadcast { msg } = req {
            self.clock += 1;
            let ts = self.clock;
            let id = MsgId {
                origin: ctx.me,
                n: self.count,
            };
            self.count += 1;
            self.heard(ctx.me, ts);
            out.send(
                ctx.others(),
                LamportMsg::Msg {
                    ts,
                    id,
                    payload: msg.clone(),
                },
            );
            self.pending.insert((ts, id), msg);
            self.try_deliver(ctx, out);
        }
    }

    fn on_message(&mut self, ctx: &Ctx, from: Pid, m: LamportMsg, out: &mut Out<Self>) {
        match m {
            LamportMsg::Msg { ts, id, payload } => {
                self.clock = self.clock.max(ts) + 1;
                self.heard(from, ts);
                self.pending.insert((ts, id), payload);
                let ack = self.clock;
                self.heard(ctx.me, ack);
                out.send(ctx.others(), LamportMsg::Ack { ts: ack });
            }
            LamportMsg::Ack { ts } => {
                self.clock = self.clock.max(ts);
                self.heard(from, ts);
            }
        }
        self.try_deliver(ctx, out);
    }

    fn render(m: &LamportMsg, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match m {
            LamportMsg::Msg { ts, id, payload } => write!(f, "LAMPORT(ts {ts}, {id}, {payload})"),
            LamportMsg::Ack { ts } => write!(f, "LAMPORT_ACK(ts {ts})"),
        }
    }
}
