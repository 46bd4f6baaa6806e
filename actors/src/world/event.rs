//! Events and the event queue (seed 3.6 and 4.3, event manager of 4.2.3).
//!
//! Every change of state is an [`Event`] at an instant of virtual time. Events are ordered by
//! time and, at equal times, by their [`EventId`], which is derived from causality: an event
//! created while the event processed as number `s` was handled gets the id `(s, i)`, `i` being
//! its position among that handler's outputs. Processing numbers are handed out in processing
//! order, so the order is the same on every run whatever the order in which actor mailboxes
//! happened to be served. Setup events have cause 0.
//!
//! Events are *eventually-happen* (motion starts, sensor events, notices) or *conditional*
//! (motion steps after the start, collisions, cell crossings, sensor entries): a conditional
//! event is cancelled when a robot it depends on changes its path before it fires.

use std::collections::HashMap;

use super::motion::Motion;
use super::observation::Observation;
use super::radix::{key_time, time_key, Entry, RadixQueue};
use super::sensor::{SensorKind, SensorQuery, SensorValue};
use super::{MotionOutcome, Obstacle, RobotId};
use crate::world::motion::Kinematics;
use nekosim_protocols::{Indication, Input, LayerIx};

/// Identity and tie-break key of an event: `(cause, index)`, see the module doc. Packed to 12
/// bytes (an event carries one, and a large run holds millions of events: issue 17).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(C, packed(4))]
pub struct EventId {
    /// Processing number of the event whose handling created this one (0 for setup).
    pub cause: u64,
    /// Position among the events that handling created.
    pub index: u32,
}

/// Which actor handles an event.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Target {
    /// The scheduler itself, as the event manager (answers listings inline).
    EventManager,
    MotionManager,
    SensorManager,
    Robot(RobotId),
    Sensor(RobotId, SensorKind),
    /// The simulated network.
    Network,
    /// A robot's protocol layer (index in the stack).
    Layer(RobotId, LayerIx),
}

/// Eventually-happen or conditional (seed 4.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EventClass {
    Eventual,
    Conditional,
}

/// What a robot's algorithm is told.
#[derive(Clone, Debug, PartialEq)]
pub enum Notice {
    /// The algorithm starts.
    Start,
    /// A motion ended; `state` is the robot's kinematic state then.
    MotionEnded {
        ticket: u64,
        outcome: MotionOutcome,
        state: Kinematics,
    },
    /// A pull sensor answered, or a push sensor acknowledged (de)activation.
    SensorReply { ticket: u64, value: SensorValue },
    /// A push sensor interrupts the robot.
    Interrupt {
        sensor: SensorKind,
        value: SensorValue,
    },
    /// A timer set by `sleep` fired.
    Timer { ticket: u64 },
    /// A message or indication for the algorithm: a direct message from the network
    /// (`layer` is [`nekosim_protocols::NET`]) or an indication of a protocol layer.
    Incoming { layer: LayerIx, ind: Indication },
    /// The event manager's listing of the robot's future events.
    FutureEvents {
        ticket: u64,
        events: Vec<FutureEvent>,
    },
}

/// One pending event, as the event manager lists it (seed 4.2.3).
#[derive(Clone, Debug, PartialEq)]
pub struct FutureEvent {
    /// When it is due [s].
    pub time: f64,
    pub class: EventClass,
    /// What it is: `motion_step`, `collision`, `cell_crossing`, `timer`, ...
    pub kind: &'static str,
    /// The robots it concerns.
    pub robots: [Option<RobotId>; 2],
}

/// The content of an event. Variants that are rare or large keep their bulk in a box, so that
/// an event (most are motion steps, collisions and cell crossings) stays small: a large run
/// holds millions of them (issue 17).
#[derive(Clone, Debug)]
pub enum Payload {
    /// Robot -> motion manager: start `motion`, replacing the current one.
    MotionRequest {
        robot: RobotId,
        ticket: u64,
        motion: Box<Motion>,
    },
    /// The `step`-th event of the robot's current motion.
    MotionStep { robot: RobotId, step: usize },
    /// Robot `a` touches robot `b`.
    Collision { a: RobotId, b: RobotId },
    /// `robot` touches the world's boundary or an obstacle (`with`) at the point `at` on it.
    Contact {
        robot: RobotId,
        with: Obstacle,
        at: super::geometry::Point,
    },
    /// The robot leaves its cell of the spatial index towards `offset`.
    CellCrossing { robot: RobotId, offset: [i64; 2] },
    /// `other` enters the range of `robot`'s entry-triggered push `sensor` (push proximity).
    ProximityEntry {
        robot: RobotId,
        other: RobotId,
        sensor: SensorKind,
    },
    /// `robot`'s entry-triggered push `sensor` ends its quiet interval.
    ProximityRearm {
        robot: RobotId,
        sensor: SensorKind,
        generation: u64,
    },
    /// Motion manager -> sensor manager: `robot` touched `with`; its contact `sensor` senses.
    Touched {
        robot: RobotId,
        sensor: SensorKind,
        with: Obstacle,
    },
    /// A periodic push sensor re-senses (every `interval` [s] from its activation).
    PeriodicSense {
        robot: RobotId,
        sensor: SensorKind,
        interval: f64,
        generation: u64,
    },
    /// Robot -> sensor manager: a sensor request.
    SensorRequest {
        robot: RobotId,
        ticket: u64,
        query: Box<SensorQuery>,
    },
    /// The sensor event of a request, at its trigger time.
    SensorTrigger {
        robot: RobotId,
        ticket: u64,
        query: Box<SensorQuery>,
    },
    /// Sensor manager -> sensor actor: compute the reply from the world's data.
    SensorCompute(Box<SensorCompute>),
    /// To a robot's algorithm.
    Notice(Box<Notice>),
    /// A robot's own timer.
    Timer { robot: RobotId, ticket: u64 },
    /// Robot -> event manager: list the future events of robot `of` (itself or another).
    ListEvents {
        robot: RobotId,
        of: RobotId,
        ticket: u64,
    },
    /// A layer or the application hands a message to the network.
    NetSend {
        from: RobotId,
        layer: LayerIx,
        to: Box<[RobotId]>,
        msg: Box<nekosim_protocols::Payload>,
    },
    /// An input for a robot's protocol layer.
    LayerInput {
        robot: RobotId,
        layer: LayerIx,
        input: Box<Input>,
    },
    /// A protocol layer's timer (`generation` tells cancelled timers apart).
    LayerTimer {
        robot: RobotId,
        layer: LayerIx,
        timer: Box<nekosim_protocols::Payload>,
        generation: u64,
    },
    /// The robot crashes (handled by the event manager, then the motion manager).
    Crash { robot: RobotId },
}

/// What a sensor actor computes its reply from (the content of [`Payload::SensorCompute`]).
#[derive(Clone, Debug)]
pub struct SensorCompute {
    pub robot: RobotId,
    /// The request's ticket; `None` for a push sensor's interrupt.
    pub ticket: Option<u64>,
    pub query: SensorQuery,
    /// The reading (as [`SensorValue::Reply`]), or the outcome of a (de)activation.
    pub snapshot: SensorValue,
}

impl Payload {
    /// Short name of the kind of event.
    pub fn kind(&self) -> &'static str {
        match self {
            Payload::MotionRequest { .. } => "motion_request",
            Payload::MotionStep { .. } => "motion_step",
            Payload::Collision { .. } | Payload::Contact { .. } => "collision",
            Payload::CellCrossing { .. } => "cell_crossing",
            Payload::ProximityEntry { .. } => "proximity_entry",
            Payload::ProximityRearm { .. } => "proximity_rearm",
            Payload::PeriodicSense { .. } => "periodic_sense",
            Payload::Touched { .. } => "touched",
            Payload::SensorRequest { .. } => "sensor_request",
            Payload::SensorTrigger { .. } => "sensor_trigger",
            Payload::SensorCompute { .. } => "sensor_compute",
            Payload::Notice(_) => "notice",
            Payload::Timer { .. } => "timer",
            Payload::ListEvents { .. } => "list_events",
            Payload::NetSend { .. } => "net_send",
            Payload::LayerInput { .. } => "layer_input",
            Payload::LayerTimer { .. } => "layer_timer",
            Payload::Crash { .. } => "crash",
        }
    }
}

/// A scheduled event: 80 bytes (issue 17; a million robots keep about seven million pending).
#[derive(Clone, Debug)]
pub struct Event {
    /// When it fires [s].
    pub time: f64,
    pub id: EventId,
    pub target: Target,
    pub class: EventClass,
    /// Robots the event concerns, for the event manager's per-robot listing ([`NO_ROBOT`] for
    /// none; see [`Event::robots`]).
    pub concerns: [RobotId; 2],
    pub payload: Payload,
}

/// The robot id that stands for no robot in [`Event::concerns`].
pub const NO_ROBOT: RobotId = RobotId::MAX;

impl Event {
    /// The robots the event concerns.
    pub fn robots(&self) -> [Option<RobotId>; 2] {
        self.concerns.map(|r| (r != NO_ROBOT).then_some(r))
    }
}

/// What handling an event produces: effects as data, carried out by the scheduler.
#[derive(Clone, Debug)]
pub enum Effect {
    Schedule(Box<Event>),
    Cancel(EventId),
    Record(Observation),
}

/// Collects the effects of one event's handling and names the events it creates.
#[derive(Debug)]
pub struct Outbox {
    now: f64,
    cause: u64,
    next: u32,
    effects: Vec<Effect>,
}

impl Outbox {
    /// An outbox for handling the event processed as number `cause` at time `now`.
    pub fn new(now: f64, cause: u64) -> Self {
        Self {
            now,
            cause,
            next: 0,
            effects: Vec::new(),
        }
    }

    /// Current virtual time [s].
    pub fn now(&self) -> f64 {
        self.now
    }

    /// Schedules an event; times before now are raised to now so time never goes backwards.
    pub fn schedule(
        &mut self,
        time: f64,
        target: Target,
        class: EventClass,
        robots: [Option<RobotId>; 2],
        payload: Payload,
    ) -> EventId {
        debug_assert!(!time.is_nan(), "event time is NaN");
        let id = EventId {
            cause: self.cause,
            index: self.next,
        };
        self.next += 1;
        self.effects.push(Effect::Schedule(Box::new(Event {
            time: time.max(self.now),
            id,
            target,
            class,
            concerns: robots.map(|r| r.unwrap_or(NO_ROBOT)),
            payload,
        })));
        id
    }

    /// Schedules a notice to a robot's algorithm, now.
    pub fn notify(&mut self, robot: RobotId, notice: Notice) {
        self.schedule(
            self.now,
            Target::Robot(robot),
            EventClass::Eventual,
            [Some(robot), None],
            Payload::Notice(Box::new(notice)),
        );
    }

    /// Cancels a scheduled event (no-op if it already fired or was cancelled).
    pub fn cancel(&mut self, id: EventId) {
        self.effects.push(Effect::Cancel(id));
    }

    /// Records an observation for the run's trace.
    pub fn record(&mut self, obs: Observation) {
        self.effects.push(Effect::Record(obs));
    }

    /// The effects, in the order they were produced.
    pub fn into_effects(self) -> Vec<Effect> {
        self.effects
    }
}

/// The event manager's queue: register, cancel, pop in order, and list a robot's future
/// events (seed 4.2.3).
#[derive(Debug, Default)]
pub struct EventQueue {
    /// The order of pending events; cancelled events' entries stay until they come up.
    order: RadixQueue,
    /// Pending events, boxed as the handlers' effects carry them: the table holds a pointer
    /// per event (24 bytes with its key, against 112 for the event itself), so growing it
    /// moves little (issue 17: at 100k robots the table of whole events peaked at 291 MB).
    live: HashMap<EventId, Box<Event>, super::grid::FixedHash>,
    /// Each robot's pending events, by dense robot id, for `future_of`: built on the first
    /// listing and kept from then on (a run that never lists pays nothing; at a million robots
    /// the index was 128 MB). `future_of` sorts on demand.
    by_robot: Option<Vec<Vec<EventId>>>,
}

impl EventQueue {
    /// An empty queue.
    pub fn new() -> Self {
        Self::default()
    }

    /// Registers an event.
    pub fn register(&mut self, ev: Box<Event>) {
        self.order.push(Entry {
            key: time_key(ev.time),
            cause: ev.id.cause,
            index: ev.id.index,
        });
        if let Some(index) = self.by_robot.as_mut() {
            Self::index(index, &ev);
        }
        self.live.insert(ev.id, ev);
    }

    fn index(index: &mut Vec<Vec<EventId>>, ev: &Event) {
        for r in ev.robots().into_iter().flatten() {
            let r = r as usize;
            if index.len() <= r {
                index.resize_with(r + 1, Vec::new);
            }
            index[r].push(ev.id);
        }
    }

    /// Cancels an event; returns whether it was still pending.
    pub fn cancel(&mut self, id: EventId) -> bool {
        match self.live.remove(&id) {
            Some(ev) => {
                self.unindex(&ev);
                true
            }
            None => false,
        }
    }

    fn unindex(&mut self, ev: &Event) {
        let Some(index) = self.by_robot.as_mut() else {
            return;
        };
        for r in ev.robots().into_iter().flatten() {
            if let Some(list) = index.get_mut(r as usize) {
                if let Some(k) = list.iter().position(|id| *id == ev.id) {
                    list.swap_remove(k);
                }
            }
        }
    }

    /// Time of the next pending event.
    pub fn peek_time(&mut self) -> Option<f64> {
        while let Some(e) = self.order.peek() {
            let id = EventId {
                cause: e.cause,
                index: e.index,
            };
            if self.live.contains_key(&id) {
                return Some(key_time(e.key));
            }
            self.order.pop();
        }
        None
    }

    /// Removes and returns the next pending event.
    pub fn pop(&mut self) -> Option<Box<Event>> {
        while let Some(e) = self.order.pop() {
            let id = EventId {
                cause: e.cause,
                index: e.index,
            };
            if let Some(ev) = self.live.remove(&id) {
                self.unindex(&ev);
                return Some(ev);
            }
        }
        None
    }

    /// Removes and returns the next pending event if it is at `until` or before (one table
    /// lookup an event, where `peek_time` and `pop` take two).
    pub fn pop_until(&mut self, until: f64) -> Option<Box<Event>> {
        while let Some(e) = self.order.pop() {
            let id = EventId {
                cause: e.cause,
                index: e.index,
            };
            let Some(ev) = self.live.remove(&id) else {
                continue;
            };
            if ev.time <= until {
                self.unindex(&ev);
                return Some(ev);
            }
            // Too late: it stays the next event.
            self.order.push_front(e);
            self.live.insert(id, ev);
            return None;
        }
        None
    }

    /// Number of pending events.
    pub fn len(&self) -> usize {
        self.live.len()
    }

    /// Whether no event is pending.
    pub fn is_empty(&self) -> bool {
        self.live.is_empty()
    }

    /// The pending events of a robot, in time order (time ties in id order).
    pub fn future_of(&mut self, robot: RobotId) -> Vec<&Event> {
        let live = &self.live;
        let index = self.by_robot.get_or_insert_with(|| {
            let mut index = Vec::new();
            // In causal order, as registration would have built it.
            let mut all: Vec<&Event> = live.values().map(|e| &**e).collect();
            all.sort_unstable_by_key(|e| e.id);
            for ev in all {
                Self::index(&mut index, ev);
            }
            index
        });
        let mut evs: Vec<&Event> = index
            .get(robot as usize)
            .into_iter()
            .flatten()
            .filter_map(|id| live.get(id).map(|e| &**e))
            .collect();
        evs.sort_by(|a, b| a.time.total_cmp(&b.time).then(a.id.cmp(&b.id)));
        evs
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(time: f64, cause: u64, index: u32, robot: RobotId) -> Box<Event> {
        Box::new(Event {
            time,
            id: EventId { cause, index },
            target: Target::Robot(robot),
            class: EventClass::Eventual,
            concerns: [robot, NO_ROBOT],
            payload: Payload::Timer { robot, ticket: 0 },
        })
    }

    #[test]
    fn an_event_stays_small() {
        // A million robots keep about seven million events pending (issue 17): each byte of an
        // event is 7 MB there. 80 bytes is a size class of the allocator.
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

    #[test]
    fn cancelled_events_never_fire_and_leave_the_robot_listing() {
        let mut q = EventQueue::new();
        q.register(ev(2.0, 1, 0, 4));
        q.register(ev(1.0, 1, 1, 4));
        assert_eq!(q.future_of(4).len(), 2);
        assert!(q.cancel(EventId { cause: 1, index: 1 }));
        assert!(!q.cancel(EventId { cause: 1, index: 1 }));
        assert_eq!(q.future_of(4).len(), 1);
        assert_eq!(q.pop().map(|e| e.time), Some(2.0));
        assert!(q.pop().is_none());
        assert!(q.future_of(4).is_empty());
    }

    mod against_an_oracle {
        use super::*;
        use proptest::prelude::*;
        use std::collections::BTreeMap;

        #[derive(Clone, Debug)]
        enum Op {
            /// Handle the next event: it schedules events this far ahead (0: now) for robots.
            Step(Vec<(u8, u16, RobotId)>),
            /// Cancel the `k`-th pending event (in the oracle's order), or an unknown id.
            Cancel(usize),
            /// List a robot's future events.
            List(RobotId),
            /// Take the next event if it is at most this far ahead.
            PopUntil(u16),
        }

        fn ops() -> impl Strategy<Value = Vec<Op>> {
            let ahead = (0u8..4, 0u16..500, 0u32..6);
            prop::collection::vec(
                prop_oneof![
                    4 => prop::collection::vec(ahead, 0..4).prop_map(Op::Step),
                    2 => (0usize..20).prop_map(Op::Cancel),
                    1 => (0u32..6).prop_map(Op::List),
                    1 => (0u16..300).prop_map(Op::PopUntil),
                ],
                0..300,
            )
        }

        type Oracle = BTreeMap<(u64, EventId), (f64, RobotId)>;

        fn key(t: f64, id: EventId) -> (u64, EventId) {
            (time_key(t), id)
        }

        proptest! {
            /// The queue against a sorted map: the same events come out in the same order,
            /// the same cancellations succeed, the same listings, as handlers schedule at
            /// the current instant (many ties), just after it and far ahead.
            #[test]
            fn the_queue_agrees_with_a_sorted_map(ops in ops()) {
                let mut q = EventQueue::new();
                let mut oracle = Oracle::new();
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
                            } else {
                                prop_assert!(oracle.is_empty());
                            }
                            seq += 1;
                            for (index, (kind, d, robot)) in children.into_iter().enumerate() {
                                let t = match kind {
                                    0 => now,
                                    1 => now + f64::from(d) * 1e-6,
                                    2 => now + f64::from(d),
                                    _ => now + f64::from(d) * 1e5,
                                };
                                let e = ev(t, seq, index as u32, robot);
                                oracle.insert(key(t, e.id), (t, robot));
                                q.register(e);
                            }
                        }
                        Op::Cancel(k) => {
                            let id = match oracle.keys().nth(k) {
                                Some(&(_, id)) => id,
                                None => EventId { cause: 1_000_000 + k as u64, index: 0 },
                            };
                            let had = oracle
                                .keys()
                                .find(|(_, i)| *i == id)
                                .copied()
                                .and_then(|k| oracle.remove(&k));
                            prop_assert_eq!(q.cancel(id), had.is_some());
                        }
                        Op::List(robot) => {
                            let got: Vec<(u64, EventId)> =
                                q.future_of(robot).iter().map(|e| key(e.time, e.id)).collect();
                            let want: Vec<(u64, EventId)> = oracle
                                .iter()
                                .filter(|(_, (_, r))| *r == robot)
                                .map(|(k, _)| *k)
                                .collect();
                            prop_assert_eq!(got, want);
                        }
                        Op::PopUntil(d) => {
                            let until = now + f64::from(d);
                            let got = q.pop_until(until).map(|e| key(e.time, e.id));
                            let want = match oracle.first_key_value() {
                                Some((k, (t, _))) if *t <= until => Some(*k),
                                _ => None,
                            };
                            if let Some(k) = want {
                                oracle.remove(&k);
                                now = key_time(k.0);
                            }
                            prop_assert_eq!(got, want);
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
