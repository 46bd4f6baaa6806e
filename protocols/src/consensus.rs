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
use std::fmt;

use serde::{Deserialize, Serialize};

use crate::payload::Payload;
use crate::protocol::{FieldError, Microprotocol, NoConfig, Out, Round, Rounds};
use crate::service::{Ctx, Indication, LayerIx, Request, Service, Shape};
use crate::wire::Pid;

/// Chandra-Toueg's messages, of instance `k` and round `r`.
#[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum CtMsg {
    /// A participant's estimate and its timestamp, to the round's coordinator.
    Estimate {
        k: u64,
        r: u64,
        est: Payload,
        ts: u64,
    },
    /// The coordinator's proposal.
    Propose {
        k: u64,
        r: u64,
        value: Payload,
    },
    Ack {
        k: u64,
        r: u64,
    },
    Nack {
        k: u64,
        r: u64,
    },
    /// The decision, relayed by everybody.
    Decide {
        k: u64,
        value: Payload,
    },
}

impl CtMsg {
    /// The round a message belongs to (a decision belongs to none).
    pub fn round(&self) -> Option<u64> {
        match self {
            CtMsg::Estimate { r, .. }
            | CtMsg::Propose { r, .. }
            | CtMsg::Ack { r, .. }
            | CtMsg::Nack { r, .. } => Some(*r),
            CtMsg::Decide { .. } => None,
        }
    }
}

#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
struct Instance {
    proposed: bool,
    round: u64,
    est: Option<Payload>,
    ts: u64,
    /// Waiting for the proposal of `round`'s coordinator.
    waiting: bool,
    /// As coordinator: estimates by round.
    estimates: BTreeMap<u64, BTreeMap<Pid, (Payload, u64)>>,
    /// As coordinator: what was proposed, by round.
    proposed_in: BTreeMap<u64, Payload>,
    /// As coordinator: acks (true) and nacks by round.
    replies: BTreeMap<u64, BTreeMap<Pid, bool>>,
    /// As participant: proposals received, by round.
    proposals: BTreeMap<u64, Payload>,
}

/// The consensus layer.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct ChandraToueg {
    suspected: BTreeSet<Pid>,
    instances: BTreeMap<u64, Instance>,
    decided: BTreeMap<u64, Payload>,
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

    fn enter_round(&mut self, ctx: &Ctx, k: u64, r: u64, out: &mut Out<Self>) {
        let inst = self.instances.entry(k).or_default();
        inst.round = r;
        inst.waiting = true;
        let (est, ts) = (inst.est.clone().expect("proposed"), inst.ts);
        let c = Self::coord(ctx, r);
        if c == ctx.me {
            self.on_estimate(ctx, k, r, ctx.me, est, ts, out);
        } else {
            out.send(vec![c], CtMsg::Estimate { k, r, est, ts });
        }
        self.check_wait(ctx, k, out);
    }

    /// A participant waiting in its round moves on once the proposal is there or the
    /// coordinator is suspected.
    fn check_wait(&mut self, ctx: &Ctx, k: u64, out: &mut Out<Self>) {
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
            out.send(vec![c], CtMsg::Ack { k, r });
        } else {
            out.send(vec![c], CtMsg::Nack { k, r });
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
        est: Payload,
        ts: u64,
        out: &mut Out<Self>,
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
            CtMsg::Propose {
                k,
                r,
                value: best.clone(),
            },
        );
        self.on_propose(ctx, k, r, best, out);
    }

    fn on_propose(&mut self, ctx: &Ctx, k: u64, r: u64, value: Payload, out: &mut Out<Self>) {
        if self.decided.contains_key(&k) {
            return;
        }
        let inst = self.instances.entry(k).or_default();
        // Only the proposal of the round being waited in is ever read, and rounds only go
        // up: a proposal of a round already left is dropped.
        if r < inst.round {
            return;
        }
        inst.proposals.insert(r, value);
        self.check_wait(ctx, k, out);
    }

    fn on_reply(&mut self, ctx: &Ctx, k: u64, r: u64, from: Pid, ack: bool, out: &mut Out<Self>) {
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

    fn decide(
        &mut self,
        ctx: &Ctx,
        k: u64,
        value: Payload,
        from: Option<Pid>,
        out: &mut Out<Self>,
    ) {
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
            CtMsg::Decide {
                k,
                value: value.clone(),
            },
        );
        out.up(Indication::Decide { k, value });
    }
}

impl Microprotocol for ChandraToueg {
    type Msg = CtMsg;
    type Timer = ();
    type Config = NoConfig;
    const NAME: &'static str = "ConsensusCT";
    // A process keeps going round until a decision arrives.
    const ROUNDS: Rounds = Rounds::Numbered;

    fn round(msg: &CtMsg) -> Round {
        msg.round().map_or(Round::None, Round::At)
    }

    fn shape(_: &NoConfig) -> Shape {
        Shape {
            provides: Service::CONSENSUS,
            needs_below: Service::P2P,
            needs_uses: vec![Service::FAILURE_DETECTOR],
        }
    }

    fn new(_: NoConfig) -> Result<Self, FieldError> {
        Ok(Self::default())
    }

    fn on_request(&mut self, ctx: &Ctx, _from: LayerIx, req: Request, out: &mut Out<Self>) {
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

    fn on_indication(&mut self, ctx: &Ctx, _from: LayerIx, ind: Indication, out: &mut Out<Self>) {
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
            _ => {}
        }
    }

    fn on_message(&mut self, ctx: &Ctx, from: Pid, m: CtMsg, out: &mut Out<Self>) {
        match m {
            CtMsg::Estimate { k, r, est, ts } => self.on_estimate(ctx, k, r, from, est, ts, out),
            CtMsg::Propose { k, r, value } => self.on_propose(ctx, k, r, value, out),
            CtMsg::Ack { k, r } => self.on_reply(ctx, k, r, from, true, out),
            CtMsg::Nack { k, r } => self.on_reply(ctx, k, r, from, false, out),
            CtMsg::Decide { k, value } => self.decide(ctx, k, value, Some(from), out),
        }
    }

    // Decisions, rounds, a coordinator's proposals and its quorums of replies only grow, and
    // each handler ignores what they already settle.
    fn spent(&self, ctx: &Ctx, _from: Pid, m: &CtMsg) -> bool {
        let k = match m {
            CtMsg::Estimate { k, .. }
            | CtMsg::Propose { k, .. }
            | CtMsg::Ack { k, .. }
            | CtMsg::Nack { k, .. }
            | CtMsg::Decide { k, .. } => *k,
        };
        if self.decided.contains_key(&k) {
            return true;
        }
        let Some(inst) = self.instances.get(&k) else {
            return false;
        };
        match m {
            CtMsg::Estimate { r, .. } => inst.proposed_in.contains_key(r),
            CtMsg::Propose { r, .. } => *r < inst.round,
            CtMsg::Ack { r, .. } | CtMsg::Nack { r, .. } => inst
                .replies
                .get(r)
                .is_some_and(|replies| replies.len() >= self.quorum(ctx)),
            CtMsg::Decide { .. } => false,
        }
    }

    fn render(m: &CtMsg, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match m {
            CtMsg::Estimate { k, r, est, ts } => {
                write!(f, "CT_ESTIMATE(k {k}, r {r}, {est}, ts {ts})")
            }
            CtMsg::Propose { k, r, value } => write!(f, "CT_PROPOSE(k {k}, r {r}, {value})"),
            CtMsg::Ack { k, r } => write!(f, "CT_ACK(k {k}, r {r})"),
            CtMsg::Nack { k, r } => write!(f, "CT_NACK(k {k}, r {r})"),
            CtMsg::Decide { k, value } => write!(f, "CT_DECIDE(k {k}, {value})"),
        }
    }
}
