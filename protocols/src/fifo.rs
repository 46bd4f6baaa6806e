//! FIFO channels over a point-to-point service (Neko's FIFO layer): per-link sequence numbers
//! and a reordering buffer.
//!
//! Assumes: links that deliver every message exactly once (reliable, possibly reordering).
//! Guarantees: messages from one process to another are delivered in the order they were
//! sent. A multicast is split into one message per destination (each link has its own
//! sequence).

use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Serialize};

use crate::payload::Payload;
use crate::protocol::{FieldError, Microprotocol, NoConfig, Out, Round, Rounds};
use crate::service::{Ctx, Indication, LayerIx, Request, Service, Shape};
use crate::symmetry::Rename;
use crate::wire::Pid;

/// The FIFO layer's message: the payload of layer `up` with its per-link number.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct FifoMsg {
    pub seq: u64,
    pub up: LayerIx,
    pub payload: Payload,
}

/// The FIFO layer.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct Fifo {
    next: BTreeMap<Pid, u64>,
    expected: BTreeMap<Pid, u64>,
    held: BTreeMap<(Pid, u64), (LayerIx, Payload)>,
}

impl Microprotocol for Fifo {
    type Msg = FifoMsg;
    type Timer = ();
    type Config = NoConfig;
    const NAME: &'static str = "Fifo";
    const ROUNDS: Rounds = Rounds::Carried;
    // An early arrival only waits in `held`, which nothing but `on_message` reads.
    const HOLDS_EARLY: bool = true;

    fn round(m: &FifoMsg) -> Round {
        Round::Carries(m.payload.clone())
    }

    fn shape(_: &NoConfig) -> Shape {
        Shape::on_links(Service::FIFO_P2P)
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Ok(Self::default())
    }

    fn on_request(&mut self, _ctx: &Ctx, from: LayerIx, req: Request, out: &mut Out<Self>) {
        if let Request::Send { to, msg } = req {
            for d in to {
                let seq = self.next.entry(d).or_insert(0);
                out.send(
                    vec![d],
                    FifoMsg {
                        seq: *seq,
                        up: from,
                        payload: msg.clone(),
                    },
                );
                *seq += 1;
            }
        }
    }

    fn on_message(&mut self, _ctx: &Ctx, from: Pid, m: FifoMsg, out: &mut Out<Self>) {
        self.held.insert((from, m.seq), (m.up, m.payload));
        let expected = self.expected.entry(from).or_insert(0);
        while let Some((up, msg)) = self.held.remove(&(from, *expected)) {
            out.up_to(up, Indication::Deliver { from, msg });
            *expected += 1;
        }
    }

    fn renamed(&self, r: &Rename) -> Option<Self> {
        let by_peer = |m: &BTreeMap<Pid, u64>| m.iter().map(|(p, n)| (r.pid(*p), *n)).collect();
        Some(Self {
            next: by_peer(&self.next),
            expected: by_peer(&self.expected),
            held: self
                .held
                .iter()
                .map(|((p, seq), (up, m))| Some(((r.pid(*p), *seq), (*up, r.payload(m)?))))
                .collect::<Option<_>>()?,
        })
    }

    fn renamed_msg(m: &FifoMsg, r: &Rename) -> Option<FifoMsg> {
        Some(FifoMsg {
            payload: r.payload(&m.payload)?,
            ..m.clone()
        })
    }

    fn render(m: &FifoMsg, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "FIFO#{}({})", m.seq, m.payload)
    }
}
