//! The event manager's queue (seed 4.2.3): pending events in order of time and causal key,
//! cancellable through their handles, and a robot's future events listed on demand.

mod store;

use super::event::{Event, EventId, Handle, Target};
use super::radix::{key_time, time_key, Entry, RadixQueue};
use super::RobotId;
use store::{CompactStep, Store, CLAIMED, STEP};

/// How many events' slots the queue's look-ahead asks for, from the third pending on
/// ([`EventQueue::look_ahead`]).
pub const SLOTS_AHEAD: usize = 4;

/// The queue slots of the cancellable events someone keeps handles of: a slot is claimed when
/// such an event is scheduled ([`Outbox::schedule_in`]) and released when its handle is
/// dropped, after cancelling it (a no-op if it already fired). The queue keeps those events
/// in slots of their own, so the two numberings never meet; a released slot's stale order
/// entry is skipped by the id check, as a cancelled event's is.
#[derive(Clone, Debug, Default)]
pub struct Claims {
    /// Released slots, whole events' and motion steps', reused last released first.
    free: [Vec<u32>; 2],
    /// Slots handed out so far, of each kind.
    next: [u32; 2],
}

impl Claims {
    /// A free slot for `ev`, of the kind the queue keeps it in.
    pub(crate) fn claim_for(&mut self, ev: &Event) -> u32 {
        self.claim(CompactStep::of(ev).is_some())
    }

    /// A free slot for an event that the queue keeps compact (`step`) or whole.
    fn claim(&mut self, step: bool) -> u32 {
        let k = usize::from(step);
        let n = self.free[k].pop().unwrap_or_else(|| {
            let n = self.next[k];
            assert!(n < CLAIMED, "fewer than 2^30 claimed slots of a kind");
            self.next[k] = n + 1;
            n
        });
        n | CLAIMED | if step { STEP } else { 0 }
    }

    /// Gives back the slot of a handle that is dropped (after cancelling it).
    pub fn release(&mut self, h: Handle) {
        let slot = h.slot;
        self.free[usize::from(slot & STEP != 0)].push(slot & !(STEP | CLAIMED));
    }
}

/// How many more entries than twice the pending events the queue's order may hold before it
/// drops those of cancelled events ([`EventQueue::cancel`]). The crate's own tests sweep
/// as soon as the cancelled outnumber the pending, so that their queues sweep often.
const STALE_FLOOR: usize = if cfg!(test) { 0 } else { 1 << 12 };

/// The event manager's queue: register, cancel, pop in order, and list a robot's future
/// events (seed 4.2.3).
///
/// Pending events sit in reusable slots ([`Slots`]); the order's entries carry their slot, so
/// taking the next event looks nothing up. A cancellable event sits in a slot that whoever
/// keeps its [`Handle`] claimed ([`Claims`]), so cancelling looks nothing up either: the
/// handle names the slot, whose id says whether the event is still there. A table from ids to
/// slots, written for every scheduled event and swept of fired ones, would be the largest
/// single cost of a million-robot run's steady state.
#[derive(Debug, Default)]
pub struct EventQueue {
    /// The order of pending events; cancelled events' entries stay until they come up or a
    /// sweep drops them ([`EventQueue::sweep`]).
    order: RadixQueue,
    slots: Store,
    /// Number of pending events.
    live: usize,
    /// Each robot's pending events (id and slot), by dense robot id, for `future_of`: built on
    /// the first listing and kept from then on (a run that never lists pays nothing; at a
    /// million robots the index would take about 128 MB). `future_of` sorts on demand.
    by_robot: Option<Vec<Vec<(EventId, u32)>>>,
}

impl EventQueue {
    /// An empty queue.
    pub fn new() -> Self {
        Self::default()
    }

    /// Registers an event.
    pub fn register(&mut self, ev: Event) {
        let key = time_key(ev.time);
        let id = ev.id;
        let slot = self.slots.put(ev);
        self.enter(key, id, slot);
    }

    /// Registers a cancellable event in the slot its handle names (which must be free: its
    /// event fired or was cancelled).
    pub fn register_in(&mut self, ev: Event, slot: u32) {
        let key = time_key(ev.time);
        let id = ev.id;
        self.slots.put_at(slot, ev);
        self.enter(key, id, slot);
    }

    fn enter(&mut self, key: u64, id: EventId, slot: u32) {
        let entry = self.counted(key, id, slot);
        self.order.push(entry);
    }

    /// Indexes the event just put in `slot` for listings (once they are asked for), counts it
    /// pending, and returns its entry in the order.
    fn counted(&mut self, key: u64, id: EventId, slot: u32) -> Entry {
        if let Some(index) = self.by_robot.as_mut() {
            let ev = self.slots.get(slot).expect("just put");
            Self::index(index, &ev, slot);
        }
        self.live += 1;
        Entry {
            key,
            cause: id.cause,
            index: id.index,
            slot,
        }
    }

    fn index(index: &mut Vec<Vec<(EventId, u32)>>, ev: &Event, slot: u32) {
        for r in ev.robots().into_iter().flatten() {
            let r = r as usize;
            if index.len() <= r {
                index.resize_with(r + 1, Vec::new);
            }
            index[r].push((ev.id, slot));
        }
    }

    /// Asks for the slot of a handle's event to be brought into cache ([`super::prefetch`]),
    /// ahead of its cancellation. Only a hint: it changes nothing.
    pub fn prefetch_slot(&self, h: Handle) {
        self.slots.prefetch(h.slot);
    }

    /// Cancels an event; returns whether it was still pending. Once cancelled events' entries
    /// outnumber the pending events (and [`STALE_FLOOR`]), the order drops them all
    /// ([`EventQueue::sweep`]).
    pub fn cancel(&mut self, h: Handle) -> bool {
        let was = self.take_pending(h.slot, h.id).is_some();
        if self.order.len() > 2 * self.live + STALE_FLOOR {
            self.sweep();
        }
        was
    }

    /// Drops the entries of cancelled events from the order. Their entries otherwise stay
    /// until their time comes, and a robot that turns cancels the predictions of its path,
    /// some of them hundreds or thousands of simulated seconds ahead: without sweeps a run's
    /// queue would grow by their entries for the whole of its first thousands of simulated
    /// seconds, to many times its pending events. A sweep reads every entry's slot,
    /// asked for some entries ahead ([`RadixQueue::retain`]); it comes after more
    /// cancellations than the entries it keeps, so its cost per cancellation is bounded.
    /// Out of line: cancellations are frequent, sweeps rare.
    #[cold]
    #[inline(never)]
    fn sweep(&mut self) {
        let slots = &self.slots;
        self.order.retain(
            |e| slots.prefetch(e.slot),
            |e| slots.holds(e.slot, Self::id_of(e)),
        );
    }

    fn unindex(&mut self, ev: &Event) {
        let Some(index) = self.by_robot.as_mut() else {
            return;
        };
        for r in ev.robots().into_iter().flatten() {
            if let Some(list) = index.get_mut(r as usize) {
                if let Some(k) = list.iter().position(|(id, _)| *id == ev.id) {
                    list.swap_remove(k);
                }
            }
        }
    }

    /// Whether the entry's event is still pending (not cancelled).
    fn pending(&self, e: &Entry) -> bool {
        self.slots.holds(e.slot, Self::id_of(e))
    }

    /// The id of the event of an entry.
    fn id_of(e: &Entry) -> EventId {
        EventId {
            cause: e.cause,
            index: e.index,
        }
    }

    /// Takes the event `id` out of `slot` if it is still pending there (one look-up).
    fn take_pending(&mut self, slot: u32, id: EventId) -> Option<Event> {
        let ev = self.slots.take_if(slot, id)?;
        self.live -= 1;
        self.unindex(&ev);
        Some(ev)
    }

    /// Time of the next pending event.
    pub fn peek_time(&mut self) -> Option<f64> {
        while let Some(e) = self.order.peek().copied() {
            if self.pending(&e) {
                return Some(key_time(e.key));
            }
            self.order.pop();
        }
        None
    }

    /// Removes and returns the next pending event.
    pub fn pop(&mut self) -> Option<Event> {
        while let Some(e) = self.order.pop() {
            if let Some(ev) = self.take_pending(e.slot, Self::id_of(&e)) {
                return Some(ev);
            }
        }
        None
    }

    /// Removes and returns the next pending event if it is at `until` or before.
    pub fn pop_until(&mut self, until: f64) -> Option<Event> {
        while let Some(e) = self.order.pop() {
            if key_time(e.key) <= until {
                match self.take_pending(e.slot, Self::id_of(&e)) {
                    Some(ev) => return Some(ev),
                    None => continue,
                }
            }
            if self.pending(&e) {
                // Too late: it stays the next event.
                self.order.push_front(e);
                return None;
            }
        }
        None
    }

    /// Looks three events ahead, once an event is taken, in stages, so that no look reads
    /// memory it has not asked for an event before: asks for the slot of the third event to
    /// be brought into cache ([`super::prefetch`]), and returns the routes of the next two,
    /// whose slots were asked for one and two events ago, so that the caller can ask for what
    /// their handlings will read ([`Ahead`]). At a million robots every slot, every robot's
    /// state and every cell is a cache miss of its own. It takes nothing; the
    /// queue's order may move on to later instants early, which changes nothing of what it
    /// gives. A delivery may take several events at once (a chain, see
    /// [`crate::host::Deliver::inline`]), after which the next two may never have been third
    /// at a look; so the slots of the [`SLOTS_AHEAD`] events from
    /// the third on are asked for, not the third's alone.
    pub fn look_ahead(&mut self) -> Ahead {
        for n in 2..2 + SLOTS_AHEAD {
            match self.order.peek_nth(n) {
                Some(e) => self.slots.prefetch(e.slot),
                None => break,
            }
        }
        let mut route = |n: usize| {
            let e = *self.order.peek_nth(n)?;
            self.slots.route_where(e.slot, |_| true)
        };
        let after = route(1);
        Ahead {
            next: route(0),
            after,
        }
    }

    /// Number of pending events.
    pub fn len(&self) -> usize {
        self.live
    }

    /// Whether no event is pending.
    pub fn is_empty(&self) -> bool {
        self.live == 0
    }

    /// The pending events of a robot, in time order (time ties in id order), as copies.
    pub fn future_of(&mut self, robot: RobotId) -> Vec<Event> {
        let slots = &self.slots;
        let index = self.by_robot.get_or_insert_with(|| {
            let mut index = Vec::new();
            // In causal order, as registration would have built it.
            let mut all: Vec<(Event, u32)> = slots.all().collect();
            all.sort_unstable_by_key(|(e, _)| e.id);
            for (ev, slot) in &all {
                Self::index(&mut index, ev, *slot);
            }
            index
        });
        let mut evs: Vec<Event> = index
            .get(robot as usize)
            .into_iter()
            .flatten()
            .filter_map(|&(id, slot)| slots.get(slot).filter(|e| e.id == id))
            .collect();
        evs.sort_by(|a, b| a.time.total_cmp(&b.time).then(a.id.cmp(&b.id)));
        evs
    }
}

/// Who handles a pending event and the robots it concerns: what its handling will read.
pub type Route = (Target, [RobotId; 2]);

/// What [`EventQueue::look_ahead`] sees of the next two pending events.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Ahead {
    /// The next event's route.
    pub next: Option<Route>,
    /// The route of the event after it.
    pub after: Option<Route>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::event::{Effect, EventClass, Payload, NO_ROBOT};
    use crate::world::outbox::Outbox;

    fn ev(time: f64, cause: u64, index: u32, robot: RobotId) -> Event {
        Event {
            time,
            id: EventId { cause, index },
            target: Target::Robot(robot),
            class: EventClass::Eventual,
            concerns: [robot, NO_ROBOT],
            payload: Payload::Timer { robot, ticket: 0 },
        }
    }

    /// A motion step, which the queue keeps compact.
    fn step(time: f64, cause: u64, index: u32, robot: RobotId) -> Event {
        Event {
            time,
            id: EventId { cause, index },
            target: Target::MotionManager,
            class: EventClass::Conditional,
            concerns: [robot, NO_ROBOT],
            payload: Payload::MotionStep {
                robot,
                step: index as usize,
                through: index as usize,
            },
        }
    }

    #[test]
    fn motion_steps_come_back_as_they_went_in() {
        let mut q = EventQueue::new();
        let a = step(1.5, 7, 3, 9);
        let mut b = step(2.0, 7, 4, 9);
        // Not compact (another target): kept whole, and comes back as well.
        b.target = Target::SensorManager;
        let c = ev(1.0, 8, 0, 9);
        // Steps 5 to 7 at one instant, compact; steps 8 to 308, too many to be compact.
        let mut d = step(2.5, 7, 5, 9);
        let mut e = step(3.0, 7, 8, 9);
        for (x, through) in [(&mut d, 7), (&mut e, 308)] {
            if let Payload::MotionStep { through: t, .. } = &mut x.payload {
                *t = through;
            }
        }
        assert!(CompactStep::of(&d).is_some() && CompactStep::of(&e).is_none());
        for e in [&a, &b, &c, &d, &e] {
            q.register(e.clone());
        }
        let listed: Vec<String> = q.future_of(9).iter().map(|e| format!("{e:?}")).collect();
        let want: Vec<String> = [&c, &a, &b, &d, &e]
            .iter()
            .map(|e| format!("{e:?}"))
            .collect();
        assert_eq!(listed, want);
        let popped: Vec<String> = std::iter::from_fn(|| q.pop())
            .map(|e| format!("{e:?}"))
            .collect();
        assert_eq!(popped, want);
    }

    #[test]
    fn an_event_stays_small() {
        // A million robots keep about seven million events pending: each byte of an event is
        // 7 MB there. 80 bytes is a size class of the allocator.
        assert!(std::mem::size_of::<Event>() <= 80);
        assert!(std::mem::size_of::<Payload>() <= 32);
    }

    #[test]
    fn ties_are_broken_by_causal_key_not_insertion_order() {
        let mut q = EventQueue::new();
        q.register(ev(1.0, 7, 0, 0));
        q.register(ev(1.0, 3, 5, 1));
        q.register(ev(0.5, 9, 0, 2));
        q.register(ev(1.0, 3, 1, 3));
        let order: Vec<_> = std::iter::from_fn(|| q.pop())
            .map(|e| (e.id.cause, e.id.index))
            .collect();
        assert_eq!(order, vec![(9, 0), (3, 1), (3, 5), (7, 0)]);
    }

    /// Schedules `e` as cancellable, through an outbox, as the world does.
    fn claim(q: &mut EventQueue, claims: &mut Claims, e: &Event) -> Handle {
        let mut out = Outbox::new(e.time, e.id.cause).numbering_from(e.id.index);
        let h = out.schedule_in(
            claims,
            e.time,
            e.target,
            e.class,
            e.robots(),
            e.payload.clone(),
        );
        for effect in out.into_effects() {
            match effect {
                Effect::ScheduleIn(ev, slot) => q.register_in(ev, slot),
                other => panic!("unexpected {other:?}"),
            }
        }
        h
    }

    #[test]
    fn cancelled_events_never_fire_and_leave_the_robot_listing() {
        let mut q = EventQueue::new();
        let mut claims = Claims::default();
        q.register(ev(2.0, 1, 0, 4));
        let h = claim(&mut q, &mut claims, &ev(1.0, 1, 1, 4));
        let s = claim(&mut q, &mut claims, &step(1.5, 1, 2, 4));
        assert_eq!(EventId::from(h), EventId { cause: 1, index: 1 });
        assert_eq!(q.future_of(4).len(), 3);
        assert!(q.cancel(h));
        assert!(!q.cancel(h));
        assert_eq!(q.future_of(4).len(), 2);
        // Its slot, released, takes the next claimed event; the old handle finds another id.
        claims.release(h);
        let h2 = claim(&mut q, &mut claims, &ev(3.0, 2, 0, 4));
        assert_eq!({ h2.slot }, { h.slot });
        assert!(!q.cancel(h));
        assert_eq!(q.pop().map(|e| e.time), Some(1.5));
        assert!(!q.cancel(s));
        assert_eq!(q.pop().map(|e| e.time), Some(2.0));
        assert_eq!(q.future_of(4).len(), 1);
        assert!(q.cancel(h2));
        assert!(q.pop().is_none());
        assert!(q.future_of(4).is_empty());
    }

    /// A robot that turns again and again cancels its far predictions: the order keeps at
    /// most twice the pending events' entries (and the floor), and the events that stay come
    /// out in their order.
    #[test]
    fn cancelled_far_events_do_not_pile_up() {
        let mut q = EventQueue::new();
        let mut claims = Claims::default();
        let (mut kept, mut popped) = (Vec::new(), Vec::new());
        for cause in 1..20_000u64 {
            let t = cause as f64 * 1e-3;
            popped.extend(std::iter::from_fn(|| q.pop_until(t)).map(|e| e.id));
            // A near event that stays, a far one that is cancelled at once.
            let e = ev(t + 0.01, cause, 0, 1);
            kept.push(e.id);
            q.register(e);
            let h = claim(&mut q, &mut claims, &ev(t + 1e4, cause, 1, 2));
            assert!(q.cancel(h));
            claims.release(h);
            assert!(q.len() <= 12);
            assert!(q.order.len() <= 2 * q.len() + STALE_FLOOR + 1);
        }
        popped.extend(std::iter::from_fn(|| q.pop()).map(|e| e.id));
        assert_eq!(popped, kept);
    }

    mod against_an_oracle {
        use super::*;
        use proptest::prelude::*;
        use std::collections::BTreeMap;

        #[derive(Clone, Debug)]
        enum Op {
            /// Handle the next event: it schedules events this far ahead (0: now) for robots,
            /// cancellable ones (claimed slots, as the world's) or not.
            Step(Vec<(u8, u16, RobotId, bool)>),
            /// Cancel the `k`-th pending cancellable event (in the oracle's order) and release
            /// its slot, as the world does.
            Cancel(usize),
            /// Cancel every pending cancellable event of a robot and release their slots, as a
            /// robot that turns has its predictions cancelled (the entries left behind pile
            /// up until the order sweeps them).
            Turn(RobotId),
            /// Drop the `k`-th last held handle of a cancellable event that fired: cancelling
            /// it does nothing; its slot is released.
            CancelGone(usize),
            /// List a robot's future events.
            List(RobotId),
            /// Take the next event if it is at most this far ahead.
            PopUntil(u16),
            /// Look ahead, as the scheduler does after taking an event in a large queue
            /// (it may move the queue's order on to later instants early).
            LookAhead,
        }

        fn ops() -> impl Strategy<Value = Vec<Op>> {
            let ahead = (0u8..4, 0u16..500, 0u32..6, any::<bool>());
            prop::collection::vec(
                prop_oneof![
                    4 => prop::collection::vec(ahead, 0..4).prop_map(Op::Step),
                    2 => (0usize..20).prop_map(Op::Cancel),
                    1 => (0usize..20).prop_map(Op::CancelGone),
                    1 => (0u32..6).prop_map(Op::List),
                    2 => (0u32..6).prop_map(Op::Turn),
                    1 => (0u16..300).prop_map(Op::PopUntil),
                    1 => Just(Op::LookAhead),
                ],
                0..300,
            )
        }

        type Oracle = BTreeMap<(u64, EventId), (f64, RobotId, Option<Handle>)>;

        fn key(t: f64, id: EventId) -> (u64, EventId) {
            (time_key(t), id)
        }

        proptest! {
            /// The queue against a sorted map: the same events come out in the same order,
            /// the same cancellations succeed, the same listings, as handlers schedule at
            /// the current instant (many ties), just after it and far ahead, and keepers of
            /// handles release slots that are then claimed again; looking ahead changes none
            /// of it.
            #[test]
            fn the_queue_agrees_with_a_sorted_map(ops in ops()) {
                let mut q = EventQueue::new();
                let mut claims = Claims::default();
                let mut oracle = Oracle::new();
                // Handles of cancellable events that fired, still held, latest last.
                let mut held: Vec<Handle> = Vec::new();
                let (mut now, mut seq) = (0.0f64, 0u64);
                for op in ops {
                    match op {
                        Op::Step(children) => {
                            // Take the next event (as the scheduler does) and schedule its
                            // children with the next processing number as their cause.
                            if let Some(e) = q.pop() {
                                let first = oracle.pop_first().expect("oracle has it too");
                                prop_assert_eq!(key(e.time, e.id), first.0);
                                now = e.time;
                                held.extend(first.1 .2);
                            } else {
                                prop_assert!(oracle.is_empty());
                            }
                            seq += 1;
                            for (index, (kind, d, robot, cancellable)) in
                                children.into_iter().enumerate()
                            {
                                let t = match kind {
                                    0 => now,
                                    1 => now + f64::from(d) * 1e-6,
                                    2 => now + f64::from(d),
                                    _ => now + f64::from(d) * 1e5,
                                };
                                // Motion steps (kept compact) and other events.
                                let e = if robot % 2 == 0 {
                                    step(t, seq, index as u32, robot)
                                } else {
                                    ev(t, seq, index as u32, robot)
                                };
                                let h = if cancellable {
                                    Some(claim(&mut q, &mut claims, &e))
                                } else {
                                    q.register(e.clone());
                                    None
                                };
                                oracle.insert(key(t, e.id), (t, robot, h));
                            }
                        }
                        Op::Cancel(k) => {
                            let found = oracle
                                .iter()
                                .filter(|(_, (_, _, h))| h.is_some())
                                .nth(k)
                                .map(|(key, (_, _, h))| (*key, *h));
                            if let Some((key, Some(h))) = found {
                                oracle.remove(&key);
                                prop_assert!(q.cancel(h));
                                prop_assert!(!q.cancel(h));
                                claims.release(h);
                                prop_assert!(q.order.len() <= 2 * q.len() + STALE_FLOOR);
                            }
                        }
                        Op::Turn(robot) => {
                            let found: Vec<_> = oracle
                                .iter()
                                .filter(|(_, (_, r, h))| *r == robot && h.is_some())
                                .map(|(key, (_, _, h))| (*key, *h))
                                .collect();
                            for (key, h) in found {
                                let h = h.expect("cancellable");
                                oracle.remove(&key);
                                prop_assert!(q.cancel(h));
                                claims.release(h);
                                prop_assert!(q.order.len() <= 2 * q.len() + STALE_FLOOR);
                            }
                        }
                        Op::CancelGone(k) => {
                            if k < held.len() {
                                let h = held.remove(held.len() - 1 - k);
                                prop_assert!(!q.cancel(h));
                                claims.release(h);
                            }
                        }
                        Op::List(robot) => {
                            let got: Vec<(u64, EventId)> =
                                q.future_of(robot).iter().map(|e| key(e.time, e.id)).collect();
                            let want: Vec<(u64, EventId)> = oracle
                                .iter()
                                .filter(|(_, (_, r, _))| *r == robot)
                                .map(|(k, _)| *k)
                                .collect();
                            prop_assert_eq!(got, want);
                        }
                        Op::PopUntil(d) => {
                            let until = now + f64::from(d);
                            let got = q.pop_until(until).map(|e| key(e.time, e.id));
                            let want = match oracle.first_key_value() {
                                Some((k, (t, _, _))) if *t <= until => Some(*k),
                                _ => None,
                            };
                            if let Some(k) = want {
                                let (_, _, h) = oracle.remove(&k).expect("listed");
                                now = key_time(k.0);
                                held.extend(h);
                            }
                            prop_assert_eq!(got, want);
                        }
                        Op::LookAhead => {
                            q.look_ahead();
                        }
                    }
                    prop_assert_eq!(q.len(), oracle.len());
                }
                while let Some((k, _)) = oracle.pop_first() {
                    prop_assert_eq!(q.pop().map(|e| key(e.time, e.id)), Some(k));
                }
                prop_assert!(q.pop().is_none());
            }
        }
    }
}
