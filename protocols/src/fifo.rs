//! FIFO channels over a point-to-point service (Neko's FIFO layer): per-link sequence numbers
//! and a reordering buffer.
//!
//! Assumes: links that deliver every message exactly once (reliable, possibly reordering).
//! Guarantees: messages from one process to another are delivered in the order they were
//! sent. A multicast is split into one message per destination (each link has its own
//! sequence).

use std::collections::BTreeMap;

use crate::protocol::Microprotocol;
use crate::service::{Ctx, Indication, LayerIx, Out, Request};
use crate::wire::{Pid, Wire};

/// The FIFO layer.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct Fifo {
    next: BTreeMap<Pid, u64>,
    expected: BTreeMap<Pid, u64>,
    held: BTreeMap<(Pid, u64), (LayerIx, Wire)>,
}

impl Microprotocol for Fifo {
    fn name(&self) -> &'static str {
        "Fifo"
    }

    fn on_request(&mut self, _ctx: &Ctx, from: LayerIx, req: Request, out: &mut Out) {
        if let Request::Send { to, msg } = req {
            for d in to {
                let seq = self.next.entry(d).or_insert(0);
                out.send(
                    vec![d],
                    Wire::Fifo {
                        seq: *seq,
                        up: from,
                        inner: Box::new(msg.clone()),
                    },
                );
                *seq += 1;
            }
        }
    }

    fn on_indication(&mut self, _ctx: &Ctx, _from: LayerIx, ind: Indication, out: &mut Out) {
        let Indication::Deliver {
            from,
            msg: Wire::Fifo { seq, up, inner },
        } = ind
        else {
            return;
        };
        self.held.insert((from, seq), (up, *inner));
        let expected = self.expected.entry(from).or_insert(0);
        while let Some((up, msg)) = self.held.remove(&(from, *expected)) {
            out.up_to(up, Indication::Deliver { from, msg });
            *expected += 1;
        }
    }
}
