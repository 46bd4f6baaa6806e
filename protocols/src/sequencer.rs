//! Fixed-sequencer total-order broadcast (Neko's FixedSequencer).
//!
//! Assumes: reliable links (any order), the sequencer does not crash.
//! Guarantees: total order, agreement, integrity, validity: every message goes to the
//! sequencer, which numbers it and sends the numbered message to all; processes deliver in
//! number order.

use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Serialize};

use crate::payload::Payload;
use crate::protocol::{FieldError, Microprotocol, Out};
use crate::service::{Ctx, Indication, LayerIx, Request, Service, Shape};
use crate::wire::{MsgId, Pid};

/// The fixed sequencer's messages: a message sent to the sequencer, and its ordering.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum SeqMsg {
    Request {
        id: MsgId,
        payload: Payload,
    },
    Order {
        gseq: u64,
        id: MsgId,
        payload: Payload,
    },
}

/// `FixedSequencer` or `FixedSequencer(sequencer: 2)`.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SequencerConfig {
    /// The process that orders every message (default 0).
    #[serde(default)]
    pub sequencer: Pid,
}

/// The fixed-sequencer layer.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct FixedSequencer {
    sequencer: Pid,
    count: u64,
    /// Next number to hand out (at the sequencer).
    next_gseq: u64,
    /// Next number to deliver.
    expected: u64,
    held: BTreeMap<u64, (MsgId, Payload)>,
    /// Every process numbers its own messages (the deliberately broken variant: two
    /// sequencers act at once).
    rogue: bool,
}

impl FixedSequencer {
    /// Process `sequencer` orders all messages.
    pub fn with_sequencer(sequencer: Pid) -> Self {
        Self {
            sequencer,
            ..Self::default()
        }
    }

    /// A broken variant in which every process acts as a sequencer for its own messages.
    pub fn rogue(sequencer: Pid) -> Self {
        Self {
            sequencer,
            rogue: true,
            ..Self::default()
        }
    }

    fn order(&mut self, ctx: &Ctx, id: MsgId, msg: Payload, out: &mut Out<Self>) {
        let gseq = self.next_gseq;
        self.next_gseq += 1;
        out.send(
            ctx.others(),
            SeqMsg::Order {
                gseq,
                id,
                payload: msg.clone(),
            },
        );
        self.receive_order(gseq, id, msg, out);
    }

    fn receive_order(&mut self, gseq: u64, id: MsgId, msg: Payload, out: &mut Out<Self>) {
        self.held.insert(gseq, (id, msg));
        while let Some((id, msg)) = self.held.remove(&self.expected) {
            self.expected += 1;
            out.up(Indication::BDeliver { id, msg });
        }
    }
}

impl Microprotocol for FixedSequencer {
    type Msg = SeqMsg;
    type Timer = ();
    type Config = SequencerConfig;
    const NAME: &'static str = "FixedSequencer";

    fn shape(_: &SequencerConfig) -> Shape {
        Shape::on_links(Service::TOTAL_ORDER)
    }

    fn new(c: SequencerConfig) -> Result<Self, FieldError> {
        Ok(Self::with_sequencer(c.sequencer))
    }

    fn on_request(&mut self, ctx: &Ctx, _from: LayerIx, req: Request, out: &mut Out<Self>) {
        if let Request::Broadcast { msg } = req {
            let id = MsgId {
                origin: ctx.me,
                n: self.count,
            };
            self.count += 1;
            if ctx.me == self.sequencer || self.rogue {
                self.order(ctx, id, msg, out);
            } else {
                out.send(vec![self.sequencer], SeqMsg::Request { id, payload: msg });
            }
        }
    }

    fn on_message(&mut self, ctx: &Ctx, _from: Pid, m: SeqMsg, out: &mut Out<Self>) {
        match m {
            SeqMsg::Request { id, payload } if ctx.me == self.sequencer => {
                self.order(ctx, id, payload, out)
            }
            SeqMsg::Order { gseq, id, payload } => self.receive_order(gseq, id, payload, out),
            SeqMsg::Request { .. } => {}
        }
    }

    fn render(m: &SeqMsg, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match m {
            SeqMsg::Request { id, payload } => write!(f, "SEQ_REQUEST({id}, {payload})"),
            SeqMsg::Order { gseq, id, payload } => {
                write!(f, "SEQ_ORDER(#{gseq}, {id}, {payload})")
            }
        }
    }
}
