//! Partial-order reduction: at a state, the breadth-first search explores the steps of a few
//! processes only (a persistent set), when it can prove that the steps it leaves out lead to
//! nothing the properties could tell apart from what it explores.
//!
//! **Independence.** A step of an actor model belongs to one process: a delivery to its
//! destination, a timer to the process it is set on. It reads and writes that process's state
//! and timers, removes the message it delivers and adds the messages it sends. Two steps of
//! different processes therefore commute, and neither disables the other: a delivery takes
//! the head of its channel, which a send to the same channel (at its tail) leaves in place. A
//! crash is the exception: while one is still allowed, `Crash(p)` and `Crash(q)` disable each
//! other (the crash budget), so a state where a crash can happen is always fully expanded. A
//! lost message, a recovery (always outside the model) and a random choice (none here) never
//! enter a reduced set.
//!
//! **Persistence** (Godefroid 1996, *Partial-Order Methods for the Verification of Concurrent
//! Systems*, LNCS 1032, ch. 4): the steps of a set `S` of processes form a persistent set
//! at `s` when no path from `s` made of other processes' steps can enable a step of `S`
//! before `S` moves. Other processes' steps never touch the state of `S`; they can only send
//! to it. On an **ordered** network a message to `p` waits behind the head of its channel, so
//! a send from `r` creates no new step of `p` when the channel `r → p` is not empty. `S` is
//! closed under that rule: a live process with an empty channel into `S` joins `S`
//! ([`process_sets`]). On an unordered (or lossy) network any new message to `p` is a new step
//! of `p`, which may come before the ones `p` already has and changes what `p` does; as every
//! process of the shipped protocols sends to every other, only the set of all processes with
//! a step is persistent there, and the search expands everything.
//!
//! **What the properties need.** Clarke, Grumberg and Peled (*Model Checking*, 1999, ch. 10;
//! Peled 1993, *All from one, one for all*) ask for invisible steps in a reduced set. The
//! properties here need less, each for its own reason (`crate::property` states which steps
//! may undo each discovery):
//!
//! - A property judged **at rest** fails only in a state where no delivery or timer step is
//!   left. Persistent sets keep every such state (Godefroid 1996, ch. 4): a path from `s`
//!   to one must take a step of the set, or that step would still be possible at its end.
//! - Every other property's discovery (an `always` property's violation, a `sometimes`
//!   property's witness) is kept by a step that does not undo it. For a path `w` from `s` to
//!   a discovery that takes no step of the set, a step `t` of the set commutes with all of
//!   `w`, so `t` then `w` reaches the state after the discovery and `t`, which is a discovery
//!   still. The set may therefore hold only steps that cannot undo a discovery: an `always`
//!   property over delivery sequences that only grow stays violated, while a client request
//!   may make a delivery proper after the fact. A step is judged on its own process's state
//!   before and after it, which is the same wherever it is taken along `w`.
//! - **Cycle proviso.** Each time the argument above moves `t` ahead of `w`, the remaining
//!   path does not get shorter; that must not go on around a cycle. The search fully
//!   expands a state when a step of its set leads to a state already seen at the depth being
//!   explored or before, a breadth-first form of the proviso after Bošnački and Holzmann
//!   (2005, *Improving Spin's partial-order reduction for breadth-first search*): around any
//!   cycle of the reduced graph, depth goes back down somewhere, and that edge leads to a
//!   state seen no later than its source, so every cycle holds a fully expanded state
//!   (Clarke, Grumberg and Peled's condition C3).
//!
//! The search takes the reduction only on an ordered network, and there, only at a state
//! where some process set is persistent; elsewhere it expands as without it.
//!
//! **Early arrivals** (a reduction in Lipton's sense: *Reduction: a method of proving
//! properties of parallel programs*, CACM 1975). On a network that reorders but never loses,
//! a stack whose every layer on the network holds early arrivals back (Fifo:
//! [`nekosim_protocols::Microprotocol::HOLDS_EARLY`], [`early_arrivals_held`]) is explored
//! as if the network kept each link in send order, and the persistent sets above then apply.
//! The argument: the arrival `a` of a message before an earlier one `e` from its sender only
//! writes a buffer that nothing else reads, so `a` commutes with every step but the arrival
//! of `e`, and moving `a` to right after that arrival yields the same states up to that
//! buffer and the message still in flight. There the arrival of `e` passes up both, which is
//! the arrival of `e` followed at once by that of the next message in order. So every path
//! of the reordering network has a path in send order through states that differ from its
//! own only in messages held or still in flight, which no property reads, and ends in the
//! same state when nothing is held (at rest, every message has arrived). Conversely a path
//! in send order is a path of the reordering network, so every counterexample is real. The
//! liveness graph does not take it: a lasso in send order is a real fair run, but the state
//! the split arrival adds between two upcalls could hide the lasso of a property that is not
//! monotone in what was delivered.
//!
//! With symmetry reduction the set is taken at the representative of a class; the process
//! sets, the properties and the proviso are invariant under renamings, which is what
//! Emerson, Jha and Peled (*Combining partial order and symmetry reductions*, TACAS 1997)
//! need. A depth bound turns the reduction off: a step moved ahead lengthens the path to a
//! discovery.

use std::sync::Arc;

use nekosim_protocols::{Stack, Wiring, NET};
use stateright::actor::{Actor, ActorModelAction, ActorModelState, Id, Network};

/// Whether every message between processes of this stack reaches a layer that holds early
/// arrivals back ([`nekosim_protocols::Microprotocol::HOLDS_EARLY`]): every layer that sits
/// on or uses the network does, and one does.
pub fn early_arrivals_held(wiring: &Wiring, stack: &Stack) -> bool {
    let on_net: Vec<usize> = (0..stack.layers.len())
        .filter(|&i| wiring.below[i] == NET || wiring.uses[i].contains(&NET))
        .collect();
    !on_net.is_empty() && on_net.iter().all(|&i| stack.layers[i].holds_early())
}

/// Whether a step of process `p`, from the first state to the second, leaves every
/// property's discovery in place ([`crate::property`]: which steps may undo which).
pub type Invisible<A, H> =
    Arc<dyn Fn(&ActorModelState<A, H>, usize, &ActorModelState<A, H>) -> bool + Send + Sync>;

/// The process a step belongs to, if the step may enter a reduced set: a delivery's
/// destination, a timer's process.
pub fn owner<M, T, R>(action: &ActorModelAction<M, T, R>) -> Option<usize> {
    match action {
        ActorModelAction::Deliver { dst, .. } => Some(usize::from(*dst)),
        ActorModelAction::Timeout(id, _) => Some(usize::from(*id)),
        ActorModelAction::Drop(_)
        | ActorModelAction::Crash(_)
        | ActorModelAction::Recover(_)
        | ActorModelAction::SelectRandom { .. } => None,
    }
}

/// Whether a reduced set may be taken at a state with these steps at all: no crash can
/// happen there and no message can be lost.
pub fn reducible<M, T, R>(actions: &[ActorModelAction<M, T, R>]) -> bool {
    !actions
        .iter()
        .any(|a| matches!(a, ActorModelAction::Crash(_) | ActorModelAction::Drop(_)))
}

/// The sets of processes whose steps are persistent at `state` on an ordered network, each as
/// a bit mask, fewest steps first, leaving out any set that holds every step. `owners[i]` is
/// [`owner`] of the state's `i`-th step. Empty on any other network.
pub fn process_sets<A: Actor, H>(
    state: &ActorModelState<A, H>,
    owners: &[Option<usize>],
) -> Vec<u64> {
    let Network::Ordered(channels) = &state.network else {
        return Vec::new();
    };
    let n = state.actor_states.len();
    let live = |p: usize| !state.crashed[p];
    let waiting = |from: usize, to: usize| {
        channels
            .get(&(Id::from(from), Id::from(to)))
            .is_some_and(|c| !c.is_empty())
    };
    let steps = |mask: u64| {
        owners
            .iter()
            .filter(|o| o.is_some_and(|p| mask & (1 << p) != 0))
            .count()
    };
    let all = owners.iter().filter(|o| o.is_some()).count();
    let mut sets: Vec<(usize, u64)> = Vec::new();
    for seed in (0..n).filter(|&p| live(p)) {
        let mut mask = 1u64 << seed;
        if steps(mask) == 0 {
            continue;
        }
        // A live process that could send into the set through an empty channel joins it.
        loop {
            let joining = (0..n).find(|&r| {
                mask & (1 << r) == 0
                    && live(r)
                    && (0..n).any(|q| mask & (1 << q) != 0 && !waiting(r, q))
            });
            match joining {
                Some(r) => mask |= 1 << r,
                None => break,
            }
        }
        let k = steps(mask);
        if k < all && !sets.iter().any(|(_, m)| *m == mask) {
            sets.push((k, mask));
        }
    }
    sets.sort_unstable();
    sets.into_iter().map(|(_, m)| m).collect()
}
