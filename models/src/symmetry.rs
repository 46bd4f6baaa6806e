//! Symmetry reduction: when every layer of the stack treats processes alike
//! ([`nekosim_protocols::symmetry`]), a state and the states equal to it up to a renaming of
//! the processes have the same futures, so the compact search keeps one of each class.
//!
//! The renamings are the permutations of the processes that map the client requests onto
//! themselves: request `g` is issued by process `g mod n` as its `g / n`-th, so a renaming
//! may only exchange processes that issue equally many requests, and request `g` of process
//! `p` becomes the same-numbered request of the process `p` is renamed to. A state's images
//! rename everything that names a process: each process's stack and what its application saw,
//! the messages in flight (their endpoints and contents), timers, crash flags.
//!
//! Sound by construction: the representative of a state is the least record among the state
//! and its images, which is the same for every state of a class; an image that cannot be made
//! (a payload of a layer that does not rename) is left out, which can only keep equivalent
//! states apart, never merge different ones.

use std::sync::Arc;

use nekosim_protocols::codec::Codecs;
use nekosim_protocols::{Payload, Pid, Rename, Request, APP};
use stateright::actor::{Envelope, Id, Network, Timers};

use crate::adapter::{ModelTimer, NetMsg, ProcessState, State};

/// The renamings of a model and how to apply them.
#[derive(Debug)]
pub struct Symmetry {
    /// Each renaming but the identity: process `p` becomes `perm[p]`.
    pub perms: Vec<Vec<Pid>>,
    n: u32,
    /// The payload of each client request, in global order.
    requests: Vec<Payload>,
    codecs: Arc<Codecs>,
}

/// Every permutation of `0..n`, in lexicographic order.
fn permutations(n: u32) -> Vec<Vec<Pid>> {
    fn extend(prefix: &mut Vec<Pid>, n: u32, out: &mut Vec<Vec<Pid>>) {
        if prefix.len() == n as usize {
            out.push(prefix.clone());
            return;
        }
        for p in 0..n {
            if !prefix.contains(&p) {
                prefix.push(p);
                extend(prefix, n, out);
                prefix.pop();
            }
        }
    }
    let mut out = Vec::new();
    extend(&mut Vec::new(), n, &mut out);
    out
}

impl Symmetry {
    /// The renamings of `n` processes issuing `requests` (in global order) that map the
    /// requests onto themselves.
    pub fn new(n: u32, requests: &[(Pid, Request)], codecs: Arc<Codecs>) -> Self {
        let count = |p: Pid| requests.iter().filter(|(q, _)| *q == p).count();
        let perms = permutations(n)
            .into_iter()
            .filter(|perm| perm.iter().enumerate().any(|(p, q)| p as Pid != *q))
            .filter(|perm| (0..n).all(|p| count(perm[p as usize]) == count(p)))
            .collect();
        let requests = requests
            .iter()
            .map(|(_, r)| match r {
                Request::Broadcast { msg } | Request::Send { msg, .. } => msg.clone(),
                Request::Propose { value, .. } => value.clone(),
                Request::Custom(p) => p.clone(),
            })
            .collect();
        Self {
            perms,
            n,
            requests,
            codecs,
        }
    }

    /// The images of `s` under every renaming (those that can be made).
    pub fn images(&self, s: &State) -> Vec<State> {
        self.perms
            .iter()
            .filter_map(|perm| self.renamed(s, perm))
            .collect()
    }

    /// A payload renamed: an application message by the request it is, a layer's by its
    /// layer's codec.
    fn payload(&self, p: &Payload, r: &Rename) -> Option<Payload> {
        if p.layer() != APP {
            return p.renamed_with(&self.codecs, r, false);
        }
        let n = self.n as usize;
        let g = self.requests.iter().position(|q| q == p)?;
        let to = r.pid((g % n) as Pid) as usize + g / n * n;
        self.requests.get(to).cloned()
    }

    /// `s` with process `p` renamed `perm[p]`, or `None` if some part does not rename.
    pub fn renamed(&self, s: &State, perm: &[Pid]) -> Option<State> {
        let payload = |p: &Payload, r: &Rename| self.payload(p, r);
        let r = Rename::new(perm, &payload);
        let n = perm.len();
        let at = |i: usize| perm[i] as usize;
        let msg = |m: &NetMsg| {
            Some(NetMsg {
                layer: m.layer,
                msg: r.payload(&m.msg)?,
            })
        };
        let mut actor_states = vec![None; n];
        let mut timers_set = vec![Timers::new(); n];
        let mut random_choices = s.random_choices.clone();
        let mut crashed = vec![false; n];
        let mut actor_storages = vec![None; n];
        for i in 0..n {
            let a = &s.actor_states[i];
            let state = ProcessState {
                stack: a.stack.renamed(&r)?,
                issued: a.issued,
                fired: a.fired,
                delivered: a
                    .delivered
                    .iter()
                    .map(|(id, m)| Some((r.msg_id(*id), r.payload(m)?)))
                    .collect::<Option<_>>()?,
                decided: a
                    .decided
                    .iter()
                    .map(|(k, v)| Some((*k, r.payload(v)?)))
                    .collect::<Option<_>>()?,
                received: a
                    .received
                    .iter()
                    .map(|(from, m)| Some((r.pid(*from), r.payload(m)?)))
                    .collect::<Option<_>>()?,
                detections: a.detections.renamed(|p| r.pid(p)),
                leader: a.leader.map(|l| r.pid(l)),
                outbox: a
                    .outbox
                    .iter()
                    .map(|(to, m)| Some((r.pid(*to), msg(m)?)))
                    .collect::<Option<_>>()?,
                zombie: a.zombie,
            };
            actor_states[at(i)] = Some(Arc::new(state));
            let mut timers = Timers::new();
            for t in s.timers_set[i].iter() {
                timers.set(match t {
                    ModelTimer::Layer { layer, timer } => ModelTimer::Layer {
                        layer: *layer,
                        timer: timer.renamed_with(&self.codecs, &r, true)?,
                    },
                    other => other.clone(),
                });
            }
            timers_set[at(i)] = timers;
            random_choices[at(i)] = s.random_choices[i].clone();
            crashed[at(i)] = s.crashed[i];
            actor_storages[at(i)] = s.actor_storages[i].clone();
        }
        let id = |i: Id| Id::from(at(usize::from(i)));
        let envelopes = |list: Vec<Envelope<&NetMsg>>| {
            list.into_iter()
                .map(|e| {
                    Some(Envelope {
                        src: id(e.src),
                        dst: id(e.dst),
                        msg: msg(e.msg)?,
                    })
                })
                .collect::<Option<Vec<_>>>()
        };
        let network = match &s.network {
            Network::Ordered(channels) => Network::new_ordered(envelopes(
                channels
                    .iter()
                    .flat_map(|(&(src, dst), q)| {
                        q.iter().map(move |msg| Envelope { src, dst, msg })
                    })
                    .collect(),
            )?),
            Network::UnorderedNonDuplicating(multiset) => {
                Network::new_unordered_nonduplicating(envelopes(
                    multiset
                        .iter()
                        .flat_map(|(e, count)| {
                            std::iter::repeat_n(
                                Envelope {
                                    src: e.src,
                                    dst: e.dst,
                                    msg: &e.msg,
                                },
                                *count,
                            )
                        })
                        .collect(),
                )?)
            }
            Network::UnorderedDuplicating(..) => return None,
        };
        Some(State {
            actor_states: actor_states.into_iter().collect::<Option<_>>()?,
            network,
            timers_set,
            random_choices,
            crashed,
            history: (),
            actor_storages,
        })
    }
}
