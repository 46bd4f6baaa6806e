//! Whether a protocol stack's state is **at rest**: nothing is left to happen that would
//! change anything. The properties judged at rest ([`crate::property`]: validity, agreement,
//! termination) read only such states, where no step is left to make them true.
//!
//! The judgement runs the deliveries in flight (a delivery that changes nothing leaves the
//! system where it is), the costliest part of checking a state. The deliveries it ran are
//! remembered per thread, keyed by what their answers read.

use std::borrow::Cow;
use std::cell::RefCell;
use std::sync::Arc;

use stateright::actor::{Id, Network, Out};

use crate::adapter::{live, ModelTimer, NetMsg, ProcessState, Shared, State};
use crate::config::CheckModel;

/// Nothing is left to happen: no client request or staged send pending, no protocol timer
/// that a live process may still fire, no delivery to a live process that would change
/// anything (on an ordered network: no delivery at all). After a crash, a pending protocol
/// timer always counts as something left (a failure detector must keep running for the
/// survivors to make progress), so a run cut by the timer budget is never at rest.
pub fn at_rest(m: &CheckModel, s: &State) -> bool {
    judge(m, s, |p, src, dst, msg| {
        DELIVERIES.with(|d| d.borrow_mut().changes(m, p, src, dst, msg))
    })
}

/// [`at_rest`], asking `changes` whether a delivery changes anything.
fn judge(
    m: &CheckModel,
    s: &State,
    mut changes: impl FnMut(&Arc<ProcessState>, Id, Id, &NetMsg) -> bool,
) -> bool {
    let crashed_any = s.crashed.iter().any(|c| *c);
    let timers_done = live(s).all(|i| {
        s.timers_set[i].iter().all(|t| match t {
            ModelTimer::Client | ModelTimer::Flush => false,
            ModelTimer::Layer { .. } => {
                !crashed_any && s.actor_states[i].fired >= m.cfg.timer_budget
            }
        })
    });
    timers_done
        && s.network.iter_deliverable().all(|e| {
            let i = usize::from(e.dst);
            if s.crashed[i] {
                return true;
            }
            // On an ordered network, even a useless message is a step: it unblocks the
            // messages queued behind it.
            if matches!(s.network, Network::Ordered(_)) {
                return false;
            }
            !changes(&s.actor_states[i], e.src, e.dst, e.msg)
        })
}

/// Whether process `dst` in state `p` changes anything on receiving `msg` from `src`: its
/// state, or something it sends.
fn delivery_changes(m: &CheckModel, p: &ProcessState, src: Id, dst: Id, msg: &NetMsg) -> bool {
    let mut state = Cow::Borrowed(p);
    m.actors[usize::from(dst)].receive(
        dst,
        &mut state,
        src,
        msg.clone(),
        &mut Out::new(),
        &mut Vec::new(),
    );
    matches!(state, Cow::Owned(_))
}

/// Slots of the deliveries remembered per thread: a power of two.
const DELIVERY_SLOTS: usize = 1 << 12;

/// The slots' hash: fixed keys, so a run's speed does not vary with a random seed.
const HASHER: ahash::RandomState =
    ahash::RandomState::with_seeds(0x7265_7374, 0x6e65_6b6f, 0x0073_696d, 0x6465_6c69);

thread_local! {
    /// Deliveries [`at_rest`] ran on this thread, and whether each changed anything.
    /// The states of a search share their process states (the same `Arc`s) far more than they
    /// are equal as a whole, so one delivery answers for many states, as long as the process
    /// state it ran on is kept alive.
    static DELIVERIES: RefCell<Deliveries> = RefCell::new(Deliveries::new(DELIVERY_SLOTS));
}

/// A delivery judged: the model, the receiving process's state by identity, the envelope.
struct Delivery {
    model: Arc<Shared>,
    process: Arc<ProcessState>,
    src: Id,
    dst: Id,
    msg: NetMsg,
    changes: bool,
}

/// The deliveries judged last, one per slot, a slot chosen by hashing what the answer reads.
struct Deliveries {
    slots: Vec<Option<Delivery>>,
    /// How many slots `slots` gets at the first delivery: a power of two.
    size: usize,
}

impl Deliveries {
    /// Room for `size` deliveries (a power of two), allocated at the first.
    fn new(size: usize) -> Self {
        assert!(size.is_power_of_two(), "{size} slots: not a power of two");
        Self {
            slots: Vec::new(),
            size,
        }
    }

    /// [`delivery_changes`], remembered: the answer depends only on the model, the process
    /// state and the envelope, and an `Arc` kept here keeps its address from being reused.
    fn changes(
        &mut self,
        m: &CheckModel,
        process: &Arc<ProcessState>,
        src: Id,
        dst: Id,
        msg: &NetMsg,
    ) -> bool {
        let model = &m.actors[0].shared;
        if self.slots.is_empty() {
            self.slots.resize_with(self.size, || None);
        }
        let h = HASHER.hash_one((Arc::as_ptr(model), Arc::as_ptr(process), src, dst, msg));
        let mask = self.slots.len() - 1;
        let slot = &mut self.slots[h as usize & mask];
        if let Some(d) = slot.as_ref().filter(|d| {
            Arc::ptr_eq(&d.model, model)
                && Arc::ptr_eq(&d.process, process)
                && (d.src, d.dst) == (src, dst)
                && d.msg == *msg
        }) {
            return d.changes;
        }
        let changes = delivery_changes(m, process, src, dst, msg);
        *slot = Some(Delivery {
            model: Arc::clone(model),
            process: Arc::clone(process),
            src,
            dst,
            msg: msg.clone(),
            changes,
        });
        changes
    }
}

#[cfg(test)]
mod tests {
    use stateright::actor::Network;
    use stateright::{Checker, Model, StateRecorder};

    use super::{at_rest, delivery_changes, judge, Deliveries};
    use crate::config::{CheckModel, Options};
    use crate::{build, find, State};

    fn states(name: &str, o: &Options) -> (CheckModel, Vec<State>) {
        let m = build(&find(name).unwrap().target(), o, |_, _| {}).unwrap();
        let (recorder, states) = StateRecorder::new_with_accessor();
        m.clone().checker().visitor(recorder).spawn_bfs().join();
        (m, states())
    }

    /// Every state of two models of different protocols (3 processes, 2 requests, a crash
    /// allowed): Lamport's total order, then reliable broadcast.
    fn two_models() -> [(CheckModel, Vec<State>); 2] {
        let o = Options {
            processes: 3,
            requests: 2,
            crashes: 1,
            reduction: false,
            ..Options::default()
        };
        [
            states("lamport-abcast", &o),
            states("reliable-broadcast", &o),
        ]
    }

    /// [`at_rest`] with nothing remembered: every delivery run again.
    fn judge_at_rest(m: &CheckModel, s: &State) -> bool {
        judge(m, s, |p, src, dst, msg| {
            delivery_changes(m, p, src, dst, msg)
        })
    }

    /// The answer with remembered deliveries is the answer, whatever order the states are
    /// asked in, the same state twice or states of two models in turn.
    #[test]
    fn at_rest_remembers_only_the_state_it_judged() {
        let [(a, sa), (b, sb)] = two_models();
        let resting = sa.iter().filter(|s| judge_at_rest(&a, s)).count();
        assert!(resting > 0 && resting < sa.len());
        for (i, s) in sa.iter().enumerate().rev() {
            let t = &sb[i % sb.len()];
            for _ in 0..2 {
                assert_eq!(at_rest(&a, s), judge_at_rest(&a, s));
                assert_eq!(at_rest(&b, t), judge_at_rest(&b, t));
            }
            // A successor shares most of its parts with the state judged before it.
            for next in a.next_states(s) {
                assert_eq!(at_rest(&a, &next), judge_at_rest(&a, &next));
            }
        }
        // The same processes (the very `Arc`s) with nothing in flight, or with a crash.
        let mut told_apart = 0;
        for s in &sa {
            let mut quiet = s.clone();
            quiet.network = Network::new_unordered_nonduplicating([]);
            let mut crashed = s.clone();
            crashed.crashed = vec![true; s.crashed.len()];
            for v in [&quiet, &crashed] {
                let (before, after) = (at_rest(&a, s), at_rest(&a, v));
                assert_eq!(
                    (before, after),
                    (judge_at_rest(&a, s), judge_at_rest(&a, v))
                );
                told_apart += usize::from(before != after);
            }
        }
        assert!(told_apart > 0);
    }

    /// A remembered delivery answers only for the same process state and envelope: with one
    /// slot, every delivery of every state of two models lands on the one before it.
    #[test]
    fn a_delivery_is_remembered_only_for_its_process_state_and_envelope() {
        let [(a, sa), (b, sb)] = two_models();
        let mut one = Deliveries::new(1);
        let (mut asked, mut changing) = (0, 0);
        for (i, s) in sa.iter().enumerate() {
            for (m, s) in [(&a, s), (&b, &sb[i % sb.len()])] {
                for e in s.network.iter_deliverable() {
                    let p = &s.actor_states[usize::from(e.dst)];
                    let fresh = delivery_changes(m, p, e.src, e.dst, e.msg);
                    for _ in 0..2 {
                        assert_eq!(one.changes(m, p, e.src, e.dst, e.msg), fresh);
                    }
                    asked += 1;
                    changing += usize::from(fresh);
                }
            }
        }
        assert!(changing > 0 && changing < asked, "{changing} of {asked}");
    }
}
