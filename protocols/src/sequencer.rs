//! Fixed-sequencer total-order broadcast (Neko's FixedSequencer).
//!
//! Assumes: reliable links (any order), the sequencer does not crash.
//! Guarantees: total order, agreement, integrity, validity: every message goes to the
//! sequencer, which numbers it and sends the numbered message to all; processes deliver in
//! number order.

use std::collections::BTreeMap;

use crate::protocol::Microprotocol;
use crate::service::{Ctx, Indication, LayerIx, Out, Request};
use crate::wire::{MsgId, Pid, Wire};

/// The fixed-sequencer layer.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct FixedSequencer {
    sequencer: Pid,
    count: u64,
    /// Next number to hand out (at the sequencer).
    next_gseq: u64,
    /// Next number to deliver.
    expected: u64,
    held: BTreeMap<u64, (MsgId, Wire)>,
    /// Every process numbers its own messages (the deliberately broken variant: two
    /// sequencers act at once).
    rogue: bool,
}

impl FixedSequencer {
    /// Process `sequencer` orders all messages.
    pub fn new(sequencer: Pid) -> Self {
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

    fn order(&mut self, ctx: &Ctx, id: MsgId, msg: Wire, out: &mut Out) {
        let gseq = self.next_gseq;
        self.next_gseq += 1;
        out.send(
            ctx.others(),
            Wire::SeqOrder {
                gseq,
                id,
                inner: Box::new(msg.clone()),
            },
        );
        self.receive_order(gseq, id, msg, out);
    }

    fn receive_order(&mut self, gseq: u64, id: MsgId, msg: Wire, out: &mut Out) {
        self.held.insert(gseq, (id, msg));
        while let Some((id, msg)) = self.held.remove(&self.expected) {
            self.expected += 1;
            out.up(Indication::BDeliver { id, msg });
        }
    }
}

impl Microprotocol for FixedSequencer {
    fn name(&self) -> &'static str {
        "FixedSequencer"
    }

    fn on_request(&mut self, ctx: &Ctx, _from: LayerIx, req: Request, out: &mut Out) {
        if let Request::Broadcast { msg } = req {
            let id = MsgId {
                origin: ctx.me,
                n: self.count,
            };
            self.count += 1;
            if ctx.me == self.sequencer || self.rogue {
                self.order(ctx, id, msg, out);
            } else {
                out.send(
                    vec![self.sequencer],
                    Wire::SeqRequest {
                        id,
                        inner: Box::new(msg),
                    },
                );
            }
        }
    }

    fn on_indication(&mut self, ctx: &Ctx, _from: LayerIx, ind: Indication, out: &mut Out) {
        let Indication::Deliver { msg, .. } = ind else {
            return;
        };
        match msg {
            Wire::SeqRequest { id, inner } if ctx.me == self.sequencer => {
                self.order(ctx, id, *inner, out)
            }
            Wire::SeqOrder { gseq, id, inner } => self.receive_order(gseq, id, *inner, out),
            _ => {}
        }
    }
}
