//! Why a counterexample violates its property, said in the property's own terms ("p2 never
//! delivered 0:0, which p1 delivered at step 3"): the last state of the path is read again,
//! independently of the condition that flagged it, and the steps that matter are found along
//! the path. Step `k` is the state after the path's `k`-th action (step 0 is the start).

use std::collections::BTreeSet;

use nekosim_protocols::codec::with_codecs;
use nekosim_protocols::{Indication, MsgId, Payload, Pid, Request};
use stateright::Path;

use crate::adapter::{live, Happening, State};
use crate::config::{Action, CheckModel};
use crate::explain::{explain, Event};
use crate::family::Family;
use crate::property::{has_issued, request_of, sent};
use crate::rest::at_rest;

/// What is wrong in the last state of `path`, a counterexample of the property `name`;
/// `None` when that state does not show it (not a counterexample of that property).
pub fn reason(model: &CheckModel, name: &str, path: &Path<State, Action>) -> Option<String> {
    let states: Vec<State> = path.clone().into_states();
    let codecs = &model.actors.first()?.shared.wiring.codecs;
    with_codecs(codecs, || {
        Reader {
            m: model,
            path,
            states: &states,
        }
        .why(name)
    })
}

struct Reader<'a> {
    m: &'a CheckModel,
    path: &'a Path<State, Action>,
    states: &'a [State],
}

/// At rest: what the at-rest properties add to their reason.
const AT_REST: &str = "; nothing is left to happen";

impl Reader<'_> {
    fn last(&self) -> &State {
        self.states.last().expect("a path has a state")
    }

    /// The first step whose state satisfies `f`.
    fn step(&self, f: impl Fn(&State) -> bool) -> usize {
        self.states
            .iter()
            .position(f)
            .unwrap_or(self.states.len() - 1)
    }

    /// The step at which process `p` delivered `id`.
    fn delivered_at(&self, p: usize, id: MsgId) -> usize {
        self.step(|s| s.actor_states[p].delivered.iter().any(|(d, _)| *d == id))
    }

    fn crashed(&self, p: usize) -> &'static str {
        if self.last().crashed[p] {
            " (crashed)"
        } else {
            ""
        }
    }

    fn why(&self, name: &str) -> Option<String> {
        let s = self.last();
        let consensus = self.m.cfg.family == Family::Consensus;
        let rest = at_rest(self.m, s);
        match name {
            "total order" => self.total_order(),
            "integrity" if consensus => self.decided_twice(),
            "integrity" => self.broadcast_integrity(),
            "agreement" if consensus => self.different_decisions(),
            "uniform agreement" if rest => self.missing(true),
            "agreement" if rest => self.missing(false),
            "validity" if consensus => self.unproposed(),
            "validity" if rest => self.own_missing(),
            "no creation" => self.created(),
            "no duplication" => self.duplicated(),
            "FIFO order" => self.out_of_order(),
            "reliable delivery" if rest => self.undelivered(),
            "well-formed suspicions" => self.ill_formed(),
            "leader is a process" => self.no_such_leader(),
            _ => self.stated(name),
        }
    }

    fn total_order(&self) -> Option<String> {
        let s = self.last();
        let seq = |p: usize| -> Vec<MsgId> {
            s.actor_states[p]
                .delivered
                .iter()
                .map(|(id, _)| *id)
                .collect()
        };
        let n = s.actor_states.len();
        for a in 0..n {
            for b in a + 1..n {
                let (x, y) = (seq(a), seq(b));
                if let Some(k) = (0..x.len().min(y.len())).find(|&k| x[k] != y[k]) {
                    return Some(format!(
                        "p{a}{} delivered {} as its delivery {} (step {}), p{b}{} delivered {} (step {})",
                        self.crashed(a),
                        x[k],
                        k + 1,
                        self.delivered_at(a, x[k]),
                        self.crashed(b),
                        y[k],
                        self.delivered_at(b, y[k]),
                    ));
                }
            }
        }
        None
    }

    fn broadcast_integrity(&self) -> Option<String> {
        let s = self.last();
        for (p, a) in s.actor_states.iter().enumerate() {
            let mut seen = BTreeSet::new();
            for (id, msg) in &a.delivered {
                if !seen.insert(*id) {
                    return Some(format!("p{p} delivered {id} ({msg}) twice"));
                }
                let genuine = request_of(self.m, *id).is_some_and(|g| {
                    let (o, req) = &self.m.cfg.requests[g];
                    *o == id.origin
                        && matches!(req, Request::Broadcast { msg: sent } if sent == msg)
                        && has_issued(self.m, s, *o, g)
                });
                if !genuine {
                    return Some(format!(
                        "p{p} delivered {id} ({msg}) at step {}, which p{} never broadcast",
                        self.delivered_at(p, *id),
                        id.origin
                    ));
                }
            }
        }
        None
    }

    /// A live process missing a delivery that another (any process when `uniform`, else a
    /// live one) made.
    fn missing(&self, uniform: bool) -> Option<String> {
        let s = self.last();
        for p in 0..s.actor_states.len() {
            if !uniform && s.crashed[p] {
                continue;
            }
            for (id, msg) in &s.actor_states[p].delivered {
                for q in live(s) {
                    if !s.actor_states[q].delivered.iter().any(|(d, _)| d == id) {
                        return Some(format!(
                            "p{q} never delivered {id} ({msg}), which p{p}{} delivered at step {}{AT_REST}",
                            self.crashed(p),
                            self.delivered_at(p, *id)
                        ));
                    }
                }
            }
        }
        None
    }

    fn own_missing(&self) -> Option<String> {
        let s = self.last();
        for p in live(s) {
            for n in 0..s.actor_states[p].issued as u64 {
                let id = MsgId {
                    origin: p as Pid,
                    n,
                };
                if !s.actor_states[p].delivered.iter().any(|(d, _)| *d == id) {
                    let at = self.step(|s| s.actor_states[p].issued as u64 > n);
                    return Some(format!(
                        "p{p} never delivered its own {id}, broadcast at step {at}{AT_REST}"
                    ));
                }
            }
        }
        None
    }

    fn decided_at(&self, p: usize, k: u64) -> usize {
        self.step(|s| s.actor_states[p].decided.iter().any(|(d, _)| *d == k))
    }

    fn different_decisions(&self) -> Option<String> {
        let s = self.last();
        let all: Vec<(usize, u64, &Payload)> = s
            .actor_states
            .iter()
            .enumerate()
            .flat_map(|(p, a)| a.decided.iter().map(move |(k, v)| (p, *k, v)))
            .collect();
        for (i, (p, k, v)) in all.iter().enumerate() {
            if let Some((q, _, w)) = all[..i].iter().find(|(_, k2, w)| k2 == k && w != v) {
                return Some(format!(
                    "in instance {k}, p{q}{} decided {w} (step {}) and p{p}{} decided {v} (step {})",
                    self.crashed(*q),
                    self.decided_at(*q, *k),
                    self.crashed(*p),
                    self.decided_at(*p, *k),
                ));
            }
        }
        None
    }

    fn decided_twice(&self) -> Option<String> {
        let s = self.last();
        for (p, a) in s.actor_states.iter().enumerate() {
            let mut seen = BTreeSet::new();
            for (k, v) in &a.decided {
                if !seen.insert(*k) {
                    return Some(format!("p{p} decided instance {k} twice (again {v})"));
                }
            }
        }
        None
    }

    fn unproposed(&self) -> Option<String> {
        let s = self.last();
        let m = self.m;
        for (p, a) in s.actor_states.iter().enumerate() {
            for (k, v) in &a.decided {
                let proposed = m.cfg.requests.iter().enumerate().any(|(g, (o, r))| {
                    has_issued(m, s, *o, g)
                        && matches!(r, Request::Propose { k: k2, value } if k2 == k && value == v)
                });
                if !proposed {
                    return Some(format!(
                        "p{p} decided {v} in instance {k} at step {}, which no process proposed",
                        self.decided_at(p, *k)
                    ));
                }
            }
        }
        None
    }

    fn created(&self) -> Option<String> {
        let s = self.last();
        for (q, a) in s.actor_states.iter().enumerate() {
            for (from, msg) in &a.received {
                if sent(self.m, s, *from, q as Pid, msg).is_none() {
                    return Some(format!(
                        "p{q} delivered {msg} from p{from}, which p{from} never sent to it"
                    ));
                }
            }
        }
        None
    }

    fn duplicated(&self) -> Option<String> {
        let s = self.last();
        for (q, a) in s.actor_states.iter().enumerate() {
            let mut seen = BTreeSet::new();
            for (from, msg) in &a.received {
                if !seen.insert((from, msg)) {
                    return Some(format!("p{q} delivered {msg} from p{from} twice"));
                }
            }
        }
        None
    }

    fn out_of_order(&self) -> Option<String> {
        let s = self.last();
        for (q, a) in s.actor_states.iter().enumerate() {
            let mut last: Vec<Option<(usize, &Payload)>> = vec![None; s.actor_states.len()];
            for (from, msg) in &a.received {
                let Some(g) = sent(self.m, s, *from, q as Pid, msg) else {
                    continue;
                };
                if let Some((h, earlier)) = last[*from as usize] {
                    if g < h {
                        return Some(format!(
                            "p{q} delivered {earlier} from p{from} before {msg}, which p{from} sent first"
                        ));
                    }
                }
                last[*from as usize] = Some((g, msg));
            }
        }
        None
    }

    fn undelivered(&self) -> Option<String> {
        let s = self.last();
        let m = self.m;
        for (g, (p, req)) in m.cfg.requests.iter().enumerate() {
            let Request::Send { to, msg } = req else {
                continue;
            };
            if s.crashed[*p as usize] || !has_issued(m, s, *p, g) {
                continue;
            }
            for &q in to {
                let got = s.actor_states[q as usize]
                    .received
                    .iter()
                    .any(|(f, m)| f == p && m == msg);
                if !s.crashed[q as usize] && !got {
                    let at = self.step(|s| has_issued(m, s, *p, g));
                    return Some(format!(
                        "p{q} never delivered {msg} from p{p}, sent at step {at}{AT_REST}"
                    ));
                }
            }
        }
        None
    }

    /// The first ill-formed indication of the first process whose detector gave one. A state
    /// keeps only whether there was one ([`crate::adapter::Detections`]), so the indications
    /// are read from the path's steps, replayed.
    fn ill_formed(&self) -> Option<String> {
        let s = self.last();
        let faulty: Vec<usize> = (0..s.actor_states.len())
            .filter(|&me| !s.actor_states[me].detections.well_formed())
            .collect();
        let first = *faulty.first()?;
        let entry = self.m.actors[0].shared.entry;
        let mut heard: Vec<Vec<(Pid, bool, usize)>> = vec![Vec::new(); s.actor_states.len()];
        for step in explain(self.m, self.path) {
            for e in step.events {
                if let Event::At {
                    process,
                    what: Happening::App { layer, ind },
                } = e
                {
                    let told = match ind {
                        Indication::Suspect(p) => (p, true, step.index),
                        Indication::Trust(p) => (p, false, step.index),
                        _ => continue,
                    };
                    if layer == entry {
                        heard[process as usize].push(told);
                    }
                }
            }
        }
        for &me in &faulty {
            let mut now: BTreeSet<Pid> = BTreeSet::new();
            for &(p, suspected, at) in &heard[me] {
                if p as usize == me {
                    return Some(format!(
                        "p{me}'s detector indicates p{me} itself (step {at})"
                    ));
                }
                if suspected && !now.insert(p) {
                    return Some(format!(
                        "p{me} suspects p{p} again without trusting it between (step {at})"
                    ));
                }
                if !suspected && !now.remove(&p) {
                    return Some(format!(
                        "p{me} trusts p{p} without having suspected it (step {at})"
                    ));
                }
            }
        }
        Some(format!("p{first}'s detector indications are ill-formed"))
    }

    fn no_such_leader(&self) -> Option<String> {
        let s = self.last();
        let n = self.m.cfg.n;
        s.actor_states.iter().enumerate().find_map(|(p, a)| {
            a.leader
                .filter(|&l| l >= n)
                .map(|l| format!("p{p}'s leader is p{l}, and there are only {n} processes"))
        })
    }

    /// A property a protocol states itself: its condition is all that can be said.
    fn stated(&self, name: &str) -> Option<String> {
        let p = self.m.cfg.stated.iter().find(|p| p.name == name)?;
        let last = self.states.len() - 1;
        Some(if p.always {
            format!("\"{name}\" is false after step {last}")
        } else {
            format!("\"{name}\" is true after step {last}")
        })
    }
}
