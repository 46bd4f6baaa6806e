//! Packing a state into a record of its parts' numbers and back (SPIN's "collapse
//! compression", see [`super`]): each distinct part (the history, a process's state with its
//! timers, random choices, crash flag and storage, a message in flight) is stored once, in an
//! interning [`Table`], and a state is the list of the numbers of its parts.

use std::fmt::Debug;
use std::hash::Hash;
use std::sync::{Arc, RwLock};

use dashmap::mapref::entry::Entry;
use dashmap::DashMap;
use stateright::actor::{Actor, ActorModelState, Envelope, Network, RandomChoices, Timers};

use super::{Images, Spent};

/// One process's part of a state: its state, timers, random choices, crash flag and storage.
type ProcPart<A> = (
    Arc<<A as Actor>::State>,
    Timers<<A as Actor>::Timer>,
    RandomChoices<<A as Actor>::Random>,
    bool,
    Option<<A as Actor>::Storage>,
);

/// Distinct values, each numbered once: the number of an equal value is always the same.
pub struct Table<T> {
    ids: DashMap<Arc<T>, u32, ahash::RandomState>,
    values: RwLock<Vec<Arc<T>>>,
}

impl<T: Hash + Eq> Default for Table<T> {
    fn default() -> Self {
        Self {
            ids: DashMap::default(),
            values: RwLock::new(Vec::new()),
        }
    }
}

impl<T> Debug for Table<T> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Table").finish_non_exhaustive()
    }
}

impl<T: Hash + Eq> Table<T> {
    /// The number of `v`, numbering it if it is new.
    pub fn intern(&self, v: T) -> u32 {
        if let Some(id) = self.ids.get(&v) {
            return *id;
        }
        match self.ids.entry(Arc::new(v)) {
            Entry::Occupied(e) => *e.get(),
            Entry::Vacant(e) => {
                let mut values = self.values.write().expect("table lock");
                let id = u32::try_from(values.len()).expect("at most 2^32 distinct parts");
                values.push(Arc::clone(e.key()));
                e.insert(id);
                id
            }
        }
    }

    /// The values numbered so far.
    pub fn len(&self) -> usize {
        self.values.read().expect("table lock").len()
    }

    /// Whether nothing is numbered yet.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A history as a table key. Histories are only `PartialEq` in stateright; those it ships
/// (and `()`) compare every value equal to itself, which is what a key needs.
#[derive(Clone, Hash, PartialEq)]
pub(super) struct History<H>(H);

impl<H: PartialEq> Eq for History<H> {}

/// The interning tables of a search and how to pack and unpack states with them: a state is
/// a record of its parts' numbers (see the module doc), with its spent messages forgotten.
pub struct Packer<A: Actor, H> {
    pub(super) n: usize,
    pub(super) ordered: bool,
    pub(super) history: Table<History<H>>,
    pub(super) procs: Table<ProcPart<A>>,
    pub(super) envelopes: Table<Envelope<A::Msg>>,
    pub(super) spent: Option<Spent<A>>,
}

impl<A, H> Packer<A, H>
where
    A: Actor,
    A::State: Eq,
    A::Storage: Clone + Eq + Hash,
    A::Random: Clone + Eq + Hash,
    H: Clone + Hash + PartialEq,
{
    /// The tables of an empty search of `n` processes on an `ordered` network or not, which
    /// forgets the messages `spent` names (on a network that reorders messages only).
    pub fn new(n: usize, ordered: bool, spent: Option<Spent<A>>) -> Self {
        Self {
            n,
            ordered,
            history: Table::default(),
            procs: Table::default(),
            envelopes: Table::default(),
            spent,
        }
    }

    /// Packs `s` into `out` (cleared first), consuming it, with its spent messages
    /// forgotten. `parent` (the record and state `s` was made from) lets unchanged parts keep
    /// their numbers without a lookup.
    pub fn pack(
        &self,
        mut s: ActorModelState<A, H>,
        parent: Option<(&[u32], &Unpacked<A, H>)>,
        out: &mut Vec<u32>,
    ) {
        self.forget(&mut s, parent);
        self.pack_forgotten(s, parent, out);
    }

    /// Forgets the spent messages in flight in `s`, the successor of `parent` (if any).
    pub fn forget(&self, s: &mut ActorModelState<A, H>, parent: Option<(&[u32], &Unpacked<A, H>)>) {
        if let Some(spent) = &self.spent {
            let (states, crashed) = (&s.actor_states, &s.crashed);
            // A message the parent kept, to a receiver whose state and crash flag the step
            // left alone, is still not spent: only the rest need asking.
            let kept = |env: &Envelope<&A::Msg>| {
                parent.is_some_and(|(_, p)| {
                    let to = usize::from(env.dst);
                    Arc::ptr_eq(&p.state.actor_states[to], &states[to])
                        && p.state.crashed[to] == crashed[to]
                        && p.envelopes
                            .iter()
                            .any(|(_, e)| e.src == env.src && e.dst == env.dst && e.msg == *env.msg)
                })
            };
            let keep = |env: Envelope<&A::Msg>| kept(&env) || !spent(states, crashed, env);
            match &mut s.network {
                Network::UnorderedNonDuplicating(multiset) => multiset.retain(|env, _| {
                    keep(Envelope {
                        src: env.src,
                        dst: env.dst,
                        msg: &env.msg,
                    })
                }),
                // On an ordered network partial-order reduction applies instead: its
                // persistent sets read the channels as they are.
                Network::Ordered(_) => {}
                Network::UnorderedDuplicating(..) => {}
            }
        }
    }

    /// Packs `s`, whose spent messages are already forgotten ([`Self::forget`]), into `out`
    /// as [`Self::pack`] does.
    pub fn pack_forgotten(
        &self,
        mut s: ActorModelState<A, H>,
        parent: Option<(&[u32], &Unpacked<A, H>)>,
        out: &mut Vec<u32>,
    ) {
        out.clear();
        match parent {
            Some((rec, p)) if p.state.history == s.history => out.push(rec[0]),
            _ => out.push(self.history.intern(History(s.history.clone()))),
        }
        for i in 0..self.n {
            if let Some((rec, Unpacked { state: p, .. })) = parent {
                if Arc::ptr_eq(&p.actor_states[i], &s.actor_states[i])
                    && p.crashed[i] == s.crashed[i]
                    && p.timers_set[i] == s.timers_set[i]
                    && p.actor_storages[i] == s.actor_storages[i]
                    && p.random_choices[i] == s.random_choices[i]
                {
                    out.push(rec[1 + i]);
                    continue;
                }
            }
            let part: ProcPart<A> = (
                Arc::clone(&s.actor_states[i]),
                std::mem::take(&mut s.timers_set[i]),
                std::mem::take(&mut s.random_choices[i]),
                s.crashed[i],
                s.actor_storages[i].take(),
            );
            out.push(self.procs.intern(part));
        }
        // Most messages in flight were in flight in the parent: look there first.
        let known: &[(u32, Envelope<A::Msg>)] = parent.map_or(&[], |(_, p)| &p.envelopes);
        let intern = |env: Envelope<A::Msg>| match known.iter().find(|(_, e)| *e == env) {
            Some((id, _)) => *id,
            None => self.envelopes.intern(env),
        };
        let start = out.len();
        match &mut s.network {
            Network::UnorderedNonDuplicating(multiset) => {
                for (env, count) in multiset.drain() {
                    let id = intern(env);
                    out.extend(std::iter::repeat_n(id, count));
                }
                out[start..].sort_unstable();
            }
            Network::Ordered(channels) => {
                for ((src, dst), queue) in std::mem::take(channels) {
                    for msg in queue {
                        out.push(intern(Envelope { src, dst, msg }));
                    }
                }
            }
            Network::UnorderedDuplicating(..) => {
                unreachable!("compact search is not spawned on duplicating networks")
            }
        }
    }

    /// Packs `s` as the least record of `s` and its `images`, into `out` (`tmp` is scratch).
    pub(super) fn pack_least(
        &self,
        s: ActorModelState<A, H>,
        parent: Option<(&[u32], &Unpacked<A, H>)>,
        images: Option<&Images<A, H>>,
        out: &mut Vec<u32>,
        tmp: &mut Vec<u32>,
    ) {
        let others = images.map(|f| f(&s)).unwrap_or_default();
        self.pack(s, parent, out);
        for image in others {
            self.pack(image, None, tmp);
            if *tmp < *out {
                std::mem::swap(out, tmp);
            }
        }
    }

    /// The state a record stands for.
    pub fn unpack(&self, rec: &[u32]) -> Unpacked<A, H> {
        let history = {
            let values = self.history.values.read().expect("table lock");
            values[rec[0] as usize].0.clone()
        };
        let procs: Vec<Arc<ProcPart<A>>> = {
            let values = self.procs.values.read().expect("table lock");
            rec[1..=self.n]
                .iter()
                .map(|&id| Arc::clone(&values[id as usize]))
                .collect()
        };
        let envelopes: Vec<(u32, Envelope<A::Msg>)> = {
            let values = self.envelopes.values.read().expect("table lock");
            rec[1 + self.n..]
                .iter()
                .map(|&id| (id, Envelope::clone(&values[id as usize])))
                .collect()
        };
        let in_flight = envelopes.iter().map(|(_, e)| e.clone());
        let state = ActorModelState {
            actor_states: procs.iter().map(|p| Arc::clone(&p.0)).collect(),
            network: if self.ordered {
                Network::new_ordered(in_flight)
            } else {
                Network::new_unordered_nonduplicating(in_flight)
            },
            timers_set: procs.iter().map(|p| p.1.clone()).collect(),
            random_choices: procs.iter().map(|p| p.2.clone()).collect(),
            crashed: procs.iter().map(|p| p.3).collect(),
            history,
            actor_storages: procs.iter().map(|p| p.4.clone()).collect(),
        };
        Unpacked { state, envelopes }
    }
}

impl<A: Actor, H> Debug for Packer<A, H> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Packer")
            .field("n", &self.n)
            .field("ordered", &self.ordered)
            .finish_non_exhaustive()
    }
}

impl<A: Actor, H> Debug for Unpacked<A, H> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Unpacked")
            .field("envelopes", &self.envelopes.len())
            .finish_non_exhaustive()
    }
}

/// A state unpacked from its record, with its messages in flight and their numbers.
pub struct Unpacked<A: Actor, H> {
    pub(super) state: ActorModelState<A, H>,
    pub(super) envelopes: Vec<(u32, Envelope<A::Msg>)>,
}

impl<A: Actor, H> Unpacked<A, H> {
    /// The state.
    pub fn state(&self) -> &ActorModelState<A, H> {
        &self.state
    }

    /// The state, without the numbers of its messages.
    pub fn into_state(self) -> ActorModelState<A, H> {
        self.state
    }
}
