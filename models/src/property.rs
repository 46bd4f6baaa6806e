//! The properties, stated once per protocol family and attached to every model of the family.
//!
//! Safety properties are `always` conditions on every reachable state. The liveness-flavoured
//! ones (validity, agreement) are checked `always` at the states where the system is **at
//! rest**: nothing can be delivered to a live process, no client request or staged send is
//! pending, and no live process can still fire a protocol timer. A state cut by a bound (the
//! timer budget, the round bound of Chandra-Toueg) is never at rest, so a bound never produces
//! a false counterexample; it only narrows what is explored. The `sometimes` properties give a
//! witness that the good outcome is reachable at all.
//!
//! Each property also says which steps of one process may undo its discovery ([`Undo`]), so
//! that the partial-order reduction ([`crate::reduction`]) never leaves such a step to later.
//! The sequences a process records (deliveries, decisions, receipts) only grow, so a
//! violation read in them stays; a client request can make a past delivery proper (its
//! message is then issued), and a witness of a last value (a leader, a length) can be undone
//! by a change of that value. What a detector told its process is kept as a summary
//! ([`crate::adapter::Detections`]) whose fault flag and trusted processes only grow; only a suspicion
//! withdrawn can undo a witness read in it. Properties judged at rest undo nothing: no step
//! is left in the states where they fail.

use std::collections::BTreeSet;

use nekosim_protocols::{MsgId, Payload, Pid, Request};
use stateright::Expectation;

use crate::adapter::{live, ProcessState, State};
use crate::config::{CheckModel, Condition, ModelCfg, NetworkKind, Options, Undo};
use crate::family::Family;
use crate::rest::at_rest;

/// A property: how it is checked, its name, its condition and which steps may undo its
/// discovery.
pub type Prop = (Expectation, &'static str, Condition, Undo);

/// The properties of a family for a model with the options `opts` (crashes allowed, the
/// network, the timer budget) and the given proposers (consensus only).
pub fn properties(family: Family, n: u32, opts: &Options, proposers: u32) -> Vec<Prop> {
    use Expectation::{Always, Sometimes};
    let crashes = opts.crashes;
    match family {
        Family::P2p { fifo } => {
            let mut v: Vec<Prop> = vec![
                (Always, "no creation", no_creation, received_or_issued),
                (Always, "no duplication", no_duplication, received_rewritten),
            ];
            if fifo {
                v.push((Always, "FIFO order", fifo_order, received_or_issued));
            }
            if opts.network != NetworkKind::Lossy {
                v.push((Always, "reliable delivery", reliable_delivery, at_rest_only));
            }
            v.push((
                Sometimes,
                "everything delivered",
                everything_received,
                received_rewritten_or_unissued,
            ));
            v
        }
        Family::FailureDetector => {
            let mut v: Vec<Prop> = vec![(
                Always,
                "well-formed suspicions",
                well_formed,
                fault_forgotten,
            )];
            if crashes > 0 {
                v.push((Sometimes, "completeness", completeness, suspicion_withdrawn));
            }
            if opts.timer_budget >= 2 {
                v.push((
                    Sometimes,
                    "false suspicion revoked",
                    suspicion_revoked,
                    trust_forgotten,
                ));
            }
            v
        }
        Family::Leader => vec![
            (Always, "leader is a process", leader_valid, leader_changed),
            (
                Sometimes,
                "common live leader",
                common_leader,
                leader_changed,
            ),
        ],
        Family::Abcast => vec![
            (Always, "total order", total_order, delivered_rewritten),
            (
                Always,
                "integrity",
                broadcast_integrity,
                delivered_or_issued,
            ),
            (Always, "uniform agreement", uniform_agreement, at_rest_only),
            (Always, "validity", validity, at_rest_only),
            (
                Sometimes,
                "everything delivered",
                everything_delivered,
                delivered_past_all,
            ),
        ],
        Family::Broadcast => vec![
            (
                Always,
                "integrity",
                broadcast_integrity,
                delivered_or_issued,
            ),
            (Always, "agreement", agreement, at_rest_only),
            (Always, "validity", validity, at_rest_only),
            (
                Sometimes,
                "everything delivered",
                everything_delivered,
                delivered_past_all,
            ),
        ],
        Family::Consensus => {
            let mut v: Vec<Prop> = vec![
                (Always, "agreement", consensus_agreement, decided_rewritten),
                (Always, "validity", consensus_validity, decided_or_issued),
                (Always, "integrity", consensus_integrity, decided_rewritten),
                (Sometimes, "termination", termination, decided_rewritten),
            ];
            if crashes > 0 {
                let majority = n / 2 + 1;
                for p in 0..n.min(TERMINATION_WITHOUT.len() as u32) {
                    // Termination needs proposals from a majority of live processes.
                    let live_proposers = proposers - u32::from(p < proposers);
                    if live_proposers >= majority {
                        let (name, f) = TERMINATION_WITHOUT[p as usize];
                        v.push((Sometimes, name, f, decided_rewritten));
                    }
                }
            }
            v
        }
    }
}

/// What a property of [`properties`] says, in words (reports and recordings state it in full).
pub fn statement(name: &str) -> Option<&'static str> {
    Some(match name {
        "total order" => "the delivery sequences of any two processes, crashed ones included, are prefixes of one another",
        "integrity" => "no process delivers (or decides) twice, and only what was broadcast (or proposed), by its origin, with its content",
        "uniform agreement" => "at rest, whatever any process delivered, crashed or not, every live process delivered",
        "agreement" => "at rest, whatever a live process delivered, every live process delivered (consensus: no two processes decide differently)",
        "validity" => "at rest, every live process delivered everything it broadcast (consensus: a decided value was proposed)",
        "everything delivered" => "a state where every process delivered every request",
        "termination" => "a state where every live process decided every instance",
        "no creation" => "every message a process delivered from p was sent to it by p",
        "no duplication" => "no process delivers a message twice",
        "FIFO order" => "each process delivers each sender's messages in the order they were sent",
        "reliable delivery" => "at rest, every message a live process sent to a live process was delivered",
        "well-formed suspicions" => "a detector never suspects its own process, and alternates suspect and trust about each process",
        "completeness" => "a state where a process crashed and every live process suspects every crashed one",
        "false suspicion revoked" => "a state where a live process trusts again a live process it had suspected",
        "leader is a process" => "every leader indicated is one of the processes",
        "common live leader" => "a state where every live process trusts the same live leader",
        n if n.starts_with("termination with p") => {
            "a state where that process crashed undecided and every live process decided"
        }
        _ => return None,
    })
}

/// An at-rest property: it fails only where no step is left, so no step undoes it.
fn at_rest_only(_: &ModelCfg, _: &ProcessState, _: &ProcessState) -> bool {
    false
}

/// `after` is not `before` with entries appended.
fn rewritten<T: PartialEq>(before: &[T], after: &[T]) -> bool {
    !after.starts_with(before)
}

/// Delivery sequences are read as they grow (total order).
fn delivered_rewritten(_: &ModelCfg, b: &ProcessState, a: &ProcessState) -> bool {
    rewritten(&b.delivered, &a.delivered)
}

/// Deliveries, and whether their messages were issued (integrity).
fn delivered_or_issued(_: &ModelCfg, b: &ProcessState, a: &ProcessState) -> bool {
    rewritten(&b.delivered, &a.delivered) || a.issued != b.issued
}

/// Every process delivered exactly every request: undone by a process that had delivered
/// them all and delivers again.
fn delivered_past_all(m: &ModelCfg, b: &ProcessState, a: &ProcessState) -> bool {
    b.delivered.len() == m.requests.len() && a.delivered.len() != b.delivered.len()
}

/// Decisions are read as they grow (agreement, integrity, termination).
fn decided_rewritten(_: &ModelCfg, b: &ProcessState, a: &ProcessState) -> bool {
    rewritten(&b.decided, &a.decided)
}

/// Decisions, and whether their values were proposed (validity).
fn decided_or_issued(_: &ModelCfg, b: &ProcessState, a: &ProcessState) -> bool {
    rewritten(&b.decided, &a.decided) || a.issued != b.issued
}

/// Receipts are read as they grow (no duplication).
fn received_rewritten(_: &ModelCfg, b: &ProcessState, a: &ProcessState) -> bool {
    rewritten(&b.received, &a.received)
}

/// Receipts, and whether their messages were sent (no creation, FIFO order).
fn received_or_issued(_: &ModelCfg, b: &ProcessState, a: &ProcessState) -> bool {
    rewritten(&b.received, &a.received) || a.issued != b.issued
}

/// Receipts and requests that only grow (everything received).
fn received_rewritten_or_unissued(_: &ModelCfg, b: &ProcessState, a: &ProcessState) -> bool {
    rewritten(&b.received, &a.received) || a.issued < b.issued
}

/// An ill-formed indication is read (well-formed suspicions): the fault is never forgotten
/// ([`crate::adapter::Detections::record`] only sets it), so no step undoes a violation.
fn fault_forgotten(_: &ModelCfg, b: &ProcessState, a: &ProcessState) -> bool {
    !b.detections.well_formed() && a.detections.well_formed()
}

/// The suspicions in force are read, a witness needing some (completeness): a step undoes it
/// only by withdrawing a suspicion; one that adds a suspicion keeps every crashed process
/// suspected.
fn suspicion_withdrawn(_: &ModelCfg, b: &ProcessState, a: &ProcessState) -> bool {
    !a.detections.keeps_suspicions_of(&b.detections)
}

/// The processes ever trusted are read (a revoked suspicion): they only grow, and a crash,
/// which could make the trusted one dead, never enters a reduced set.
fn trust_forgotten(_: &ModelCfg, b: &ProcessState, a: &ProcessState) -> bool {
    !a.detections.keeps_trusts_of(&b.detections)
}

/// The last leader is read.
fn leader_changed(_: &ModelCfg, b: &ProcessState, a: &ProcessState) -> bool {
    a.leader != b.leader
}

/// The global index of the broadcast `id` (process `p`'s `i`-th request is request
/// `p + i * n`), if it is one.
pub(crate) fn request_of(m: &CheckModel, id: MsgId) -> Option<usize> {
    let g = id.origin as usize + id.n as usize * m.cfg.n as usize;
    (id.origin < m.cfg.n && g < m.cfg.requests.len()).then_some(g)
}

/// Any two processes' delivery sequences are prefixes of one another (crashed processes
/// included: the order is uniform).
fn total_order(_: &CheckModel, s: &State) -> bool {
    let states = &s.actor_states;
    states.iter().all(|a| {
        states
            .iter()
            .all(|b| (a.delivered.iter().zip(&b.delivered)).all(|((x, _), (y, _))| x == y))
    })
}

/// No process delivers a message twice, and every delivered message was broadcast, by its
/// origin, with that content.
fn broadcast_integrity(m: &CheckModel, s: &State) -> bool {
    s.actor_states.iter().all(|a| {
        let once = |k: usize, id: &MsgId| !a.delivered[..k].iter().any(|(d, _)| d == id);
        a.delivered
            .iter()
            .enumerate()
            .all(|(k, (id, _))| once(k, id))
            && a.delivered.iter().all(|(id, msg)| {
                request_of(m, *id).is_some_and(|g| {
                    let (p, req) = &m.cfg.requests[g];
                    *p == id.origin
                        && matches!(req, Request::Broadcast { msg: sent } if sent == msg)
                        && s.actor_states[*p as usize].issued * m.cfg.n as usize > g - *p as usize
                })
            })
    })
}

/// At rest, whatever any process (crashed or not) delivered, every live process delivered.
fn uniform_agreement(m: &CheckModel, s: &State) -> bool {
    delivered_everywhere(s, 0..s.actor_states.len()) || !at_rest(m, s)
}

/// At rest, whatever a live process delivered, every live process delivered.
fn agreement(m: &CheckModel, s: &State) -> bool {
    delivered_everywhere(s, live(s)) || !at_rest(m, s)
}

/// Every live process delivered whatever the processes `from` delivered. Delivery sequences
/// are a few messages long and every state asks: scanning them costs less than building sets.
fn delivered_everywhere(s: &State, from: impl Iterator<Item = usize>) -> bool {
    let has = |i: usize, id: &MsgId| s.actor_states[i].delivered.iter().any(|(d, _)| d == id);
    from.flat_map(|j| s.actor_states[j].delivered.iter())
        .all(|(id, _)| live(s).all(|i| has(i, id)))
}

/// At rest, every live process delivered each message it broadcast.
fn validity(m: &CheckModel, s: &State) -> bool {
    live(s).all(|i| {
        let a = &s.actor_states[i];
        (0..a.issued as u64).all(|n| {
            let id = MsgId {
                origin: i as Pid,
                n,
            };
            a.delivered.iter().any(|(d, _)| *d == id)
        })
    }) || !at_rest(m, s)
}

/// A witness: every process delivered every request.
fn everything_delivered(m: &CheckModel, s: &State) -> bool {
    s.actor_states
        .iter()
        .all(|a| a.delivered.len() == m.cfg.requests.len())
}

/// No two processes (crashed ones included) decide differently.
fn consensus_agreement(_: &CheckModel, s: &State) -> bool {
    let mut seen: Vec<(u64, &Payload)> = Vec::new();
    for a in &s.actor_states {
        for (k, v) in &a.decided {
            if seen.iter().any(|(k2, v2)| k2 == k && *v2 != v) {
                return false;
            }
            seen.push((*k, v));
        }
    }
    true
}

/// A decided value was proposed (by a process that has issued that proposal).
fn consensus_validity(m: &CheckModel, s: &State) -> bool {
    let proposed: Vec<(u64, &Payload)> = m
        .cfg
        .requests
        .iter()
        .enumerate()
        .filter(|(g, (p, _))| {
            s.actor_states[*p as usize].issued * m.cfg.n as usize > g - *p as usize
        })
        .filter_map(|(_, (_, r))| match r {
            Request::Propose { k, value } => Some((*k, value)),
            _ => None,
        })
        .collect();
    s.actor_states
        .iter()
        .all(|a| a.decided.iter().all(|(k, v)| proposed.contains(&(*k, v))))
}

/// No process decides an instance twice.
fn consensus_integrity(_: &CheckModel, s: &State) -> bool {
    s.actor_states.iter().all(|a| {
        let ks: BTreeSet<u64> = a.decided.iter().map(|(k, _)| *k).collect();
        ks.len() == a.decided.len()
    })
}

fn instances(m: &CheckModel) -> BTreeSet<u64> {
    m.cfg
        .requests
        .iter()
        .filter_map(|(_, r)| match r {
            Request::Propose { k, .. } => Some(*k),
            _ => None,
        })
        .collect()
}

pub(crate) fn decided_all(m: &CheckModel, s: &State, i: usize) -> bool {
    let ks: BTreeSet<u64> = s.actor_states[i].decided.iter().map(|(k, _)| *k).collect();
    instances(m).is_subset(&ks)
}

/// A witness: every live process decided every instance.
fn termination(m: &CheckModel, s: &State) -> bool {
    live(s).all(|i| decided_all(m, s, i))
}

/// A witness: with process `P` crashed before deciding, every live process decided.
fn termination_without<const P: usize>(m: &CheckModel, s: &State) -> bool {
    P < s.crashed.len()
        && s.crashed[P]
        && s.actor_states[P].decided.is_empty()
        && live(s).all(|i| decided_all(m, s, i))
}

/// Whether process `p` has issued its request `g` (its `(g - p) / n`-th).
pub(crate) fn has_issued(m: &CheckModel, s: &State, p: Pid, g: usize) -> bool {
    s.actor_states[p as usize].issued * m.cfg.n as usize > g - p as usize
}

/// The request `msg` from `from` to `to` was, if it was issued.
pub(crate) fn sent(m: &CheckModel, s: &State, from: Pid, to: Pid, msg: &Payload) -> Option<usize> {
    m.cfg.requests.iter().enumerate().position(|(g, (p, req))| {
        *p == from
            && matches!(req, Request::Send { to: dst, msg: sent } if sent == msg && dst.contains(&to))
            && has_issued(m, s, *p, g)
    })
}

/// Every message a process delivered from `from` was sent to it by `from`.
fn no_creation(m: &CheckModel, s: &State) -> bool {
    s.actor_states.iter().enumerate().all(|(q, a)| {
        a.received
            .iter()
            .all(|(from, msg)| sent(m, s, *from, q as Pid, msg).is_some())
    })
}

/// No process delivers a message (a sender and content) twice.
fn no_duplication(_: &CheckModel, s: &State) -> bool {
    s.actor_states.iter().all(|a| {
        let distinct: BTreeSet<&(Pid, Payload)> = a.received.iter().collect();
        distinct.len() == a.received.len()
    })
}

/// Each process delivers the messages of each sender in the order they were sent.
fn fifo_order(m: &CheckModel, s: &State) -> bool {
    s.actor_states.iter().enumerate().all(|(q, a)| {
        (0..m.cfg.n).all(|from| {
            let order: Vec<Option<usize>> = a
                .received
                .iter()
                .filter(|(f, _)| *f == from)
                .map(|(_, msg)| sent(m, s, from, q as Pid, msg))
                .collect();
            order.windows(2).all(|w| w[0] < w[1])
        })
    })
}

/// At rest, every message a live process sent to a live process was delivered.
fn reliable_delivery(m: &CheckModel, s: &State) -> bool {
    all_received(m, s, |p| !s.crashed[p as usize]) || !at_rest(m, s)
}

/// Every issued request from a process `counts` was delivered at every live destination.
pub(crate) fn all_received(m: &CheckModel, s: &State, counts: impl Fn(Pid) -> bool) -> bool {
    m.cfg.requests.iter().enumerate().all(|(g, (p, req))| {
        let Request::Send { to, msg } = req else {
            return true;
        };
        !counts(*p)
            || !has_issued(m, s, *p, g)
            || to.iter().all(|&q| {
                s.crashed[q as usize]
                    || s.actor_states[q as usize]
                        .received
                        .iter()
                        .any(|(f, got)| f == p && got == msg)
            })
    })
}

/// A witness: every request issued and delivered at every destination.
fn everything_received(m: &CheckModel, s: &State) -> bool {
    m.cfg
        .requests
        .iter()
        .enumerate()
        .all(|(g, (p, _))| has_issued(m, s, *p, g))
        && live(s).count() == s.actor_states.len()
        && all_received(m, s, |_| true)
}

/// What process `a`'s failure detector says of `t` now: suspected or not.
pub(crate) fn suspects(s: &State, a: usize, t: Pid) -> bool {
    s.actor_states[a].detections.suspects(t)
}

/// A detector never suspects its own process, and about each process it alternates:
/// suspect, trust, suspect... (no trust without a suspicion, no suspicion repeated).
fn well_formed(_: &CheckModel, s: &State) -> bool {
    s.actor_states.iter().all(|a| a.detections.well_formed())
}

/// A witness of strong completeness: a process crashed, and every crashed process is
/// suspected by every live process.
fn completeness(_: &CheckModel, s: &State) -> bool {
    let crashed: Vec<Pid> = (0..s.crashed.len())
        .filter(|&i| s.crashed[i])
        .map(|i| i as Pid)
        .collect();
    !crashed.is_empty() && live(s).all(|a| crashed.iter().all(|&t| suspects(s, a, t)))
}

/// A witness of eventual accuracy: a live process trusts again a live process it had
/// suspected.
fn suspicion_revoked(_: &CheckModel, s: &State) -> bool {
    live(s).any(|a| {
        s.actor_states[a]
            .detections
            .trusted()
            .any(|p| !s.crashed[p as usize])
    })
}

/// Every leader indicated is a process.
fn leader_valid(m: &CheckModel, s: &State) -> bool {
    s.actor_states
        .iter()
        .all(|a| a.leader.is_none_or(|l| l < m.cfg.n))
}

/// A witness of eventual leadership: every live process trusts the same live leader, after
/// a crash when crashes are allowed (the leader then is not the crashed one).
fn common_leader(m: &CheckModel, s: &State) -> bool {
    let crashes_allowed = m.max_crashes > 0;
    let mut leaders = live(s).map(|i| s.actor_states[i].leader);
    let Some(Some(first)) = leaders.next() else {
        return false;
    };
    leaders.all(|l| l == Some(first))
        && !s.crashed[first as usize]
        && (!crashes_allowed || s.crashed.iter().any(|c| *c))
}

/// One termination witness per crash pattern of one process (names are `'static`, as
/// stateright wants them).
const TERMINATION_WITHOUT: [(&str, Condition); 8] = [
    ("termination with p0 crashed", termination_without::<0>),
    ("termination with p1 crashed", termination_without::<1>),
    ("termination with p2 crashed", termination_without::<2>),
    ("termination with p3 crashed", termination_without::<3>),
    ("termination with p4 crashed", termination_without::<4>),
    ("termination with p5 crashed", termination_without::<5>),
    ("termination with p6 crashed", termination_without::<6>),
    ("termination with p7 crashed", termination_without::<7>),
];
