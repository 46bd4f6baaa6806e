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
use std::fmt;

use serde::{Deserialize, Serialize};

use crate::payload::Payload;
use crate::protocol::{FieldError, Microprotocol, NoConfig, Out};
use crate::service::{Ctx, Indication, LayerIx, Request, Service, Shape};
use crate::wire::MsgId;

/// A proposal and decision of the consensus used: a batch of broadcast messages.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Batch(pub Vec<(MsgId, Payload)>);

/// The consensus-based atomic broadcast layer.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct ConsensusAbcast {
    unordered: BTreeMap<MsgId, Payload>,
    delivered: BTreeSet<MsgId>,
    /// Next instance to decide.
    k: u64,
    proposing: bool,
    /// Decisions of later instances that arrived early.
    decisions: BTreeMap<u64, Vec<(MsgId, Payload)>>,
}

impl ConsensusAbcast {
    fn maybe_propose(&mut self, out: &mut Out<Self>) {
        if self.proposing || self.unordered.is_empty() {
            return;
        }
        self.proposing = true;
        let batch = Batch(
            self.unordered
                .iter()
                .map(|(id, m)| (*id, m.clone()))
                .collect(),
        );
        let value = out.encode(&batch);
        out.use_layer(0, Request::Propose { k: self.k, value });
    }

    fn apply_decisions(&mut self, out: &mut Out<Self>) {
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
    type Msg = Batch;
    type Timer = ();
    type Config = NoConfig;
    const NAME: &'static str = "abcast.ChandraToueg";

    fn shape(_: &NoConfig) -> Shape {
        Shape {
            provides: Service::TOTAL_ORDER,
            needs_below: Service::BROADCAST,
            needs_uses: vec![Service::CONSENSUS],
        }
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Ok(Self::default())
    }

    fn on_request(&mut self, _ctx: &Ctx, _from: LayerIx, req: Request, out: &mut Out<Self>) {
        if let Request::Broadcast { msg } = req {
            out.down(Request::Broadcast { msg });
        }
    }

    fn on_indication(&mut self, _ctx: &Ctx, _from: LayerIx, ind: Indication, out: &mut Out<Self>) {
        match ind {
            Indication::BDeliver { id, msg } if !self.delivered.contains(&id) => {
                self.unordered.insert(id, msg);
                self.maybe_propose(out);
            }
            Indication::Decide { k, value } if k >= self.k => {
                if let Some(Batch(batch)) = out.decode(&value) {
                    self.decisions.entry(k).or_insert(batch);
                    self.apply_decisions(out);
                }
            }
            _ => {}
        }
    }

    fn render(b: &Batch, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ids: Vec<String> = b.0.iter().map(|(id, _)| id.to_string()).collect();
        write!(f, "batch[{}]", ids.join(","))
    }
}
