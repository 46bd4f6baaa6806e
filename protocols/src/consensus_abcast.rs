//! Consensus-based atomic broadcast (Neko's abcast.ChandraToueg): reliable broadcast of the
//! messages (the layer below) plus a sequence of consensus instances (used layer 0) on batches.
//!
//! Assumes: a reliable broadcast below and a consensus layer that tolerate the run's crashes
//! (f < n/2 with Chandra-Toueg).
//! Guarantees: total order, uniform agreement, integrity and validity: messages are
//! R-broadcast; a process proposes the set of messages it has received but not yet ordered to
//! instance k, delivers the decided batch (in id order, skipping messages already delivered)
//! and moves on to instance k+1.

use std::collections::{BTreeMap, BTreeSet};

use crate::protocol::Microprotocol;
use crate::service::{Ctx, Indication, LayerIx, Out, Request};
use crate::wire::{MsgId, Wire};

/// The consensus-based atomic broadcast layer.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct ConsensusAbcast {
    unordered: BTreeMap<MsgId, Wire>,
    delivered: BTreeSet<MsgId>,
    /// Next instance to decide.
    k: u64,
    proposing: bool,
    /// Decisions of later instances that arrived early.
    decisions: BTreeMap<u64, Vec<(MsgId, Wire)>>,
}

impl ConsensusAbcast {
    fn maybe_propose(&mut self, out: &mut Out) {
        if self.proposing || self.unordered.is_empty() {
            return;
        }
        self.proposing = true;
        let batch = self
            .unordered
            .iter()
            .map(|(id, m)| (*id, m.clone()))
            .collect();
        out.use_layer(
            0,
            Request::Propose {
                k: self.k,
                value: Wire::Batch(batch),
            },
        );
    }

    fn apply_decisions(&mut self, out: &mut Out) {
        while let Some(batch) = self.decisions.remove(&self.k) {
            let mut batch = batch;
            batch.sort();
            for (id, msg) in batch {
                self.unordered.remove(&id);
                if self.delivered.insert(id) {
                    out.up(Indication::BDeliver { id, msg });
                }
            }
            self.k += 1;
            self.proposing = false;
        }
        self.maybe_propose(out);
    }
}

impl Microprotocol for ConsensusAbcast {
    fn name(&self) -> &'static str {
        "abcast.ChandraToueg"
    }

    fn on_request(&mut self, _ctx: &Ctx, _from: LayerIx, req: Request, out: &mut Out) {
        if let Request::Broadcast { msg } = req {
            out.down(Request::Broadcast { msg });
        }
    }

    fn on_indication(&mut self, _ctx: &Ctx, _from: LayerIx, ind: Indication, out: &mut Out) {
        match ind {
            Indication::BDeliver { id, msg } if !self.delivered.contains(&id) => {
                self.unordered.insert(id, msg);
                self.maybe_propose(out);
            }
            Indication::Decide {
                k,
                value: Wire::Batch(batch),
            } if k >= self.k => {
                self.decisions.entry(k).or_insert(batch);
                self.apply_decisions(out);
            }
            _ => {}
        }
    }
}
