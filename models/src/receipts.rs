//! Receipts remembered: the step a process takes on receiving a message, kept per thread and
//! replayed when the same process state receives the same message again.
//!
//! A search meets one process state receiving one message in many global states: the other
//! processes' steps interleave around it (the independence that partial-order reduction
//! exploits, [`crate::reduction`]). The step is a function of the model, the process, its
//! state and the message alone, so it is run once and replayed; the protocol code still runs
//! for every receipt the search has not met.

use std::borrow::Cow;
use std::cell::RefCell;
use std::ops::Range;
use std::sync::Arc;
use std::time::Duration;

use stateright::actor::{Command, Id, Out};

use crate::adapter::{ModelTimer, NetMsg, ProcessActor, ProcessState, Shared, Started};

/// Slots of the receipts remembered per thread: a power of two.
const SLOTS: usize = 1 << 12;

/// The slots' hash: fixed keys, so a run's speed does not vary with a random seed.
const HASHER: ahash::RandomState =
    ahash::RandomState::with_seeds(0x7265_6365, 0x6970_7473, 0x6e65_6b6f, 0x0073_696d);

thread_local! {
    static RECEIPTS: RefCell<Receipts> = RefCell::new(Receipts::new(SLOTS));
}

/// [`ProcessActor::receive`] (with no record of what happened), remembered on this thread.
pub fn receive(
    actor: &ProcessActor,
    id: Id,
    state: &mut Cow<ProcessState>,
    src: Id,
    msg: NetMsg,
    o: &mut Out<ProcessActor>,
) {
    RECEIPTS.with(|r| r.borrow_mut().receive(actor, id, state, src, msg, o));
}

/// One receipt: who received what in which state, and what came of it.
struct Receipt {
    model: Arc<Shared>,
    id: Id,
    src: Id,
    msg: NetMsg,
    before: ProcessState,
    /// The state after, if the step changed it.
    after: Option<ProcessState>,
    out: Vec<Effect>,
}

/// A command of the step, kept to be given again.
enum Effect {
    Cancel(ModelTimer),
    Set(ModelTimer, Range<Duration>),
    Send(Id, NetMsg),
    Save(Started),
}

/// The receipts met last, one per slot, a slot chosen by the receiving state's address and
/// the message. A slot answers only for a state equal to the one it holds, so an address
/// reused by another state is never mistaken for it.
pub(crate) struct Receipts {
    slots: Vec<Option<Receipt>>,
}

impl Receipts {
    /// Room for `slots` receipts (a power of two), allocated at the first.
    pub(crate) fn new(slots: usize) -> Self {
        debug_assert!(slots.is_power_of_two());
        Self {
            slots: Vec::with_capacity(slots),
        }
    }

    /// [`receive`] through these receipts.
    pub(crate) fn receive(
        &mut self,
        actor: &ProcessActor,
        id: Id,
        state: &mut Cow<ProcessState>,
        src: Id,
        msg: NetMsg,
        o: &mut Out<ProcessActor>,
    ) {
        if self.slots.is_empty() {
            let n = self.slots.capacity();
            self.slots.resize_with(n, || None);
        }
        let h = HASHER.hash_one((std::ptr::from_ref::<ProcessState>(state), id, src, &msg));
        let mask = self.slots.len() - 1;
        let slot = &mut self.slots[h as usize & mask];
        if let Some(r) = slot.as_ref().filter(|r| {
            Arc::ptr_eq(&r.model, &actor.shared)
                && (r.id, r.src) == (id, src)
                && r.msg == msg
                && r.before == **state
        }) {
            if let Some(after) = &r.after {
                *state = Cow::Owned(after.clone());
            }
            for e in &r.out {
                match e {
                    Effect::Cancel(t) => o.cancel_timer(t.clone()),
                    Effect::Set(t, d) => o.set_timer(t.clone(), d.clone()),
                    Effect::Send(to, m) => o.send(*to, m.clone()),
                    Effect::Save(s) => o.save(s.clone()),
                }
            }
            return;
        }
        let before = (**state).clone();
        let mut out = Out::new();
        actor.receive(id, state, src, msg.clone(), &mut out, &mut Vec::new());
        let effects = out.iter().map(|c| match c {
            Command::CancelTimer(t) => Some(Effect::Cancel(t.clone())),
            Command::SetTimer(t, d) => Some(Effect::Set(t.clone(), d.clone())),
            Command::Send(to, m) => Some(Effect::Send(*to, m.clone())),
            Command::Save(s) => Some(Effect::Save(s.clone())),
            // A process of this adapter never chooses at random.
            Command::ChooseRandom(..) => None,
        });
        *slot = effects.collect::<Option<Vec<_>>>().map(|out| Receipt {
            model: Arc::clone(&actor.shared),
            id,
            src,
            msg,
            before,
            after: match state {
                Cow::Owned(s) => Some(s.clone()),
                Cow::Borrowed(_) => None,
            },
            out,
        });
        o.append(&mut out);
    }
}

#[cfg(test)]
mod tests {
    use std::borrow::Cow;

    use stateright::actor::Out;
    use stateright::{Checker, Model, StateRecorder};

    use super::Receipts;
    use crate::adapter::ProcessActor;
    use crate::config::{CheckModel, Options};
    use crate::{build, find, State};

    fn states(name: &str, o: &Options) -> (CheckModel, Vec<State>) {
        let m = build(&find(name).unwrap().target(), o, |_, _| {}).unwrap();
        let (recorder, states) = StateRecorder::new_with_accessor();
        m.clone().checker().visitor(recorder).spawn_bfs().join();
        (m, states())
    }

    /// A replayed receipt is the step itself: with one slot, every delivery of every state of
    /// two models in turn lands on the receipt before it, and each answer (the state after
    /// and the commands) equals the protocol's own step.
    #[test]
    fn a_receipt_replays_only_the_same_state_receiving_the_same_message() {
        let o = Options {
            processes: 3,
            requests: 2,
            crashes: 1,
            reduction: false,
            ..Options::default()
        };
        let (a, sa) = states("lamport-abcast", &o);
        let (b, sb) = states("reliable-broadcast", &o);
        let mut one = Receipts::new(1);
        let (mut asked, mut changing) = (0, 0);
        for (i, s) in sa.iter().enumerate() {
            for (m, s) in [(&a, s), (&b, &sb[i % sb.len()])] {
                for e in s.network.iter_deliverable() {
                    let actor: &ProcessActor = &m.actors[usize::from(e.dst)];
                    let p = &*s.actor_states[usize::from(e.dst)];
                    let mut fresh = Cow::Borrowed(p);
                    let mut fresh_out = Out::new();
                    actor.receive(
                        e.dst,
                        &mut fresh,
                        e.src,
                        e.msg.clone(),
                        &mut fresh_out,
                        &mut Vec::new(),
                    );
                    for _ in 0..2 {
                        let mut state = Cow::Borrowed(p);
                        let mut out = Out::new();
                        one.receive(actor, e.dst, &mut state, e.src, e.msg.clone(), &mut out);
                        assert_eq!(state, fresh);
                        assert_eq!(
                            matches!(state, Cow::Owned(_)),
                            matches!(fresh, Cow::Owned(_))
                        );
                        assert_eq!(format!("{out:?}"), format!("{fresh_out:?}"));
                    }
                    asked += 1;
                    changing += usize::from(matches!(fresh, Cow::Owned(_)));
                }
            }
        }
        assert!(changing > 0 && changing < asked, "{changing} of {asked}");
    }
}
