//! Reliable broadcast by eager relay (Neko's RBroadcast).
//!
//! Assumes: reliable point-to-point links; any number of crashes.
//! Guarantees: validity (a correct broadcaster delivers its message), integrity (each message
//! at most once, only if broadcast) and agreement (if a correct process delivers m, every
//! correct process does): every process relays a message to all others the first time it
//! receives it, before delivering it.

use std::collections::BTreeSet;

use crate::protocol::Microprotocol;
use crate::service::{Ctx, Indication, LayerIx, Out, Request};
use crate::wire::{MsgId, Wire};

/// The reliable broadcast layer.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct ReliableBroadcast {
    count: u64,
    delivered: BTreeSet<MsgId>,
    /// Relay received messages (turned off only by the deliberately broken variant used to
    /// show the model checker is not vacuous).
    no_relay: bool,
}

impl ReliableBroadcast {
    /// A broken variant that does not relay: agreement fails when the broadcaster crashes.
    pub fn without_relay() -> Self {
        Self {
            no_relay: true,
            ..Self::default()
        }
    }
}

impl Microprotocol for ReliableBroadcast {
    fn name(&self) -> &'static str {
        "RBroadcast"
    }

    fn on_request(&mut self, ctx: &Ctx, _from: LayerIx, req: Request, out: &mut Out) {
        if let Request::Broadcast { msg } = req {
            let id = MsgId {
                origin: ctx.me,
                n: self.count,
            };
            self.count += 1;
            self.delivered.insert(id);
            out.send(
                ctx.others(),
                Wire::Rb {
                    id,
                    inner: Box::new(msg.clone()),
                },
            );
            out.up(Indication::BDeliver { id, msg });
        }
    }

    fn on_indication(&mut self, ctx: &Ctx, _from: LayerIx, ind: Indication, out: &mut Out) {
        let Indication::Deliver {
            from,
            msg: Wire::Rb { id, inner },
        } = ind
        else {
            return;
        };
        if !self.delivered.insert(id) {
            return;
        }
        if !self.no_relay {
            let relay: Vec<_> = ctx
                .others()
                .into_iter()
                .filter(|&p| p != id.origin && p != from)
                .collect();
            out.send(
                relay,
                Wire::Rb {
                    id,
                    inner: inner.clone(),
                },
            );
        }
        out.up(Indication::BDeliver { id, msg: *inner });
    }
}
