//! Chandra-Toueg rotating-coordinator consensus with a ◇S failure detector (Neko's
//! ConsensusCT), for any number of instances.
//!
//! Assumes: reliable links, fewer than n/2 crashes, a ◇S detector (used layer 0).
//! Guarantees: uniform agreement (no two processes decide differently), validity (a decided
//! value was proposed), integrity (each instance decides once: the decision is indicated once,
//! also to a process that proposes after it learnt the decision) and, with ◇S, termination for
//! every correct process. Round `r` of an instance is coordinated by process `r mod n`: every
//! process sends it its estimate; with a majority of estimates it proposes the one with the
//! latest timestamp; each process acks the proposal (adopting it) or nacks when it suspects
//! the coordinator, and moves on; with a majority of replies that are all acks the coordinator
//! decides and the decision is relayed by everybody (reliable broadcast).

use std::collections::{BTreeMap, BTreeSet};

use crate::protocol::Microprotocol;
use crate::service::{Ctx, Indication, LayerIx, Out, Request};
use crate::wire::{Pid, Wire};

#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
struct Instance {
    proposed: bool,
    round: u64,
    est: Option<Wire>,
    ts: u64,
    /// Waiting for the proposal of `round`'s coordinator.
    waiting: bool,
    /// As coordinator: estimates by round.
    estimates: BTreeMap<u64, BTreeMap<Pid, (Wire, u64)>>,
    /// As coordinator: what was proposed, by round.
    proposed_in: BTreeMap<u64, Wire>,
    /// As coordinator: acks (true) and nacks by round.
    replies: BTreeMap<u64, BTreeMap<Pid, bool>>,
    /// As participant: proposals received, by round.
    proposals: BTreeMap<u64, Wire>,
}

/// The consensus layer.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct ChandraToueg {
    suspected: BTreeSet<Pid>,
    instances: BTreeMap<u64, Instance>,
    decided: BTreeMap<u64, Wire>,
    /// Quorums of one instead of a majority (the deliberately broken variant).
    minority: bool,
}

impl ChandraToueg {
    /// A broken variant whose coordinators act on one estimate and one ack: agreement fails.
    pub fn minority() -> Self {
        Self {
            minority: true,
            ..Self::default()
        }
    }

    fn quorum(&self, ctx: &Ctx) -> usize {
        if self.minority {
            1
        } else {
            ctx.majority()
        }
    }

    fn coord(ctx: &Ctx, r: u64) -> Pid {
        (r % ctx.n as u64) as Pid
    }

    fn enter_round(&mut self, ctx: &Ctx, k: u64, r: u64, out: &mut Out) {
        let inst = self.instances.entry(k).or_default();
        inst.round = r;
        inst.waiting = true;
        let (est, ts) = (inst.est.clone().expect("proposed"), inst.ts);
        let c = Self::coord(ctx, r);
        if c == ctx.me {
            self.on_estimate(ctx, k, r, ctx.me, est, ts, out);
        } else {
            out.send(
                vec![c],
                Wire::CtEstimate {
                    k,
                    r,
                    est: Box::new(est),
                    ts,
                },
            );
        }
        self.check_wait(ctx, k, out);
    }

    /// A participant waiting in its round moves on once the proposal is there or the
    /// coordinator is suspected.
    fn check_wait(&mut self, ctx: &Ctx, k: u64, out: &mut Out) {
        if self.decided.contains_key(&k) {
            return;
        }
        let Some(inst) = self.instances.get_mut(&k) else {
            return;
        };
        if !inst.waiting {
            return;
        }
        let r = inst.round;
        let c = Self::coord(ctx, r);
        let ack = if let Some(v) = inst.proposals.get(&r).cloned() {
            inst.est = Some(v);
            inst.ts = r;
            true
        } else if c != ctx.me && self.suspected.contains(&c) {
            false
        } else {
            return;
        };
        inst.waiting = false;
        if c == ctx.me {
            self.on_reply(ctx, k, r, ctx.me, ack, out);
        } else if ack {
            out.send(vec![c], Wire::CtAck { k, r });
        } else {
            out.send(vec![c], Wire::CtNack { k, r });
        }
        if !self.decided.contains_key(&k) {
            self.enter_round(ctx, k, r + 1, out);
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn on_estimate(
        &mut self,
        ctx: &Ctx,
        k: u64,
        r: u64,
        from: Pid,
        est: Wire,
        ts: u64,
        out: &mut Out,
    ) {
        if self.decided.contains_key(&k) {
            return;
        }
        let quorum = self.quorum(ctx);
        let inst = self.instances.entry(k).or_default();
        if inst.proposed_in.contains_key(&r) {
            return;
        }
        let ests = inst.estimates.entry(r).or_default();
        ests.insert(from, (est, ts));
        if ests.len() < quorum {
            return;
        }
        // The estimate with the latest timestamp (lowest process id among ties).
        let best = ests
            .iter()
            .max_by(|a, b| a.1 .1.cmp(&b.1 .1).then(b.0.cmp(a.0)))
            .map(|(_, (v, _))| v.clone())
            .expect("quorum");
        inst.proposed_in.insert(r, best.clone());
        inst.estimates.remove(&r);
        out.send(
            ctx.others(),
            Wire::CtPropose {
                k,
                r,
                value: Box::new(best.clone()),
            },
        );
        self.on_propose(ctx, k, r, best, out);
    }

    fn on_propose(&mut self, ctx: &Ctx, k: u64, r: u64, value: Wire, out: &mut Out) {
        if self.decided.contains_key(&k) {
            return;
        }
        self.instances
            .entry(k)
            .or_default()
            .proposals
            .insert(r, value);
        self.check_wait(ctx, k, out);
    }

    fn on_reply(&mut self, ctx: &Ctx, k: u64, r: u64, from: Pid, ack: bool, out: &mut Out) {
        if self.decided.contains_key(&k) {
            return;
        }
        let quorum = self.quorum(ctx);
        let inst = self.instances.entry(k).or_default();
        let replies = inst.replies.entry(r).or_default();
        if replies.len() >= quorum {
            return;
        }
        replies.insert(from, ack);
        if replies.len() == quorum && replies.values().all(|a| *a) {
            if let Some(v) = inst.proposed_in.get(&r).cloned() {
                self.decide(ctx, k, v, None, out);
            }
        }
    }

    fn decide(&mut self, ctx: &Ctx, k: u64, value: Wire, from: Option<Pid>, out: &mut Out) {
        if self.decided.contains_key(&k) {
            return;
        }
        self.decided.insert(k, value.clone());
        self.instances.remove(&k);
        let relay: Vec<Pid> = ctx
            .others()
            .into_iter()
            .filter(|p| Some(*p) != from)
            .collect();
        out.send(
            relay,
            Wire::CtDecide {
                k,
                value: Box::new(value.clone()),
            },
        );
        out.up(Indication::Decide { k, value });
    }
}

impl Microprotocol for ChandraToueg {
    fn name(&self) -> &'static str {
        "ConsensusCT"
    }

    fn on_request(&mut self, ctx: &Ctx, _from: LayerIx, req: Request, out: &mut Out) {
        let Request::Propose { k, value } = req else {
            return;
        };
        if self.decided.contains_key(&k) {
            // Already decided and indicated (a decision can arrive before the local proposal);
            // indicating it again would break integrity.
            return;
        }
        let inst = self.instances.entry(k).or_default();
        if inst.proposed {
            return;
        }
        inst.proposed = true;
        inst.est = Some(value);
        inst.ts = 0;
        self.enter_round(ctx, k, 0, out);
    }

    fn on_indication(&mut self, ctx: &Ctx, _from: LayerIx, ind: Indication, out: &mut Out) {
        match ind {
            Indication::Suspect(p) => {
                self.suspected.insert(p);
                let ks: Vec<u64> = self.instances.keys().copied().collect();
                for k in ks {
                    self.check_wait(ctx, k, out);
                }
            }
            Indication::Trust(p) => {
                self.suspected.remove(&p);
            }
            Indication::Deliver { from, msg } => match msg {
                Wire::CtEstimate { k, r, est, ts } => {
                    self.on_estimate(ctx, k, r, from, *est, ts, out)
                }
                Wire::CtPropose { k, r, value } => self.on_propose(ctx, k, r, *value, out),
                Wire::CtAck { k, r } => self.on_reply(ctx, k, r, from, true, out),
                Wire::CtNack { k, r } => self.on_reply(ctx, k, r, from, false, out),
                Wire::CtDecide { k, value } => self.decide(ctx, k, *value, Some(from), out),
                _ => {}
            },
            _ => {}
        }
    }
}
