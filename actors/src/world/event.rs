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
    Schedule(Event),
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
        self.effects.push(Effect::Schedule(Event {
            time: time.max(self.now),
            id,
            target,
            class,
            concerns: robots.map(|r| r.unwrap_or(NO_ROBOT)),
            payload,
        }));
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
///
/// Pending events sit in reusable slots ([`Slots`]); the order's entries carry their slot, so
/// taking the next event looks nothing up. Cancelling goes by id, through a table from ids to
/// slots ([`EventQueue::place`]) that a fired event leaves behind: its entry goes stale (the
/// slot is empty or holds another event, which the id tells) and is swept out when the table
/// would otherwise grow. Issue 17: removing each fired event's entry from a table of millions
/// was a cache miss per event, the largest single cost of a million-robot run.
#[derive(Debug, Default)]
pub struct EventQueue {
    /// The order of pending events; cancelled events' entries stay until they come up.
    order: RadixQueue,
    slots: Store,
    /// Where each pending event sits, plus stale entries of events that fired since the last
    /// sweep (16 bytes an entry).
    place: HashMap<EventId, u32, IdHash>,
    /// Number of pending events.
    live: usize,
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
    pub fn register(&mut self, ev: Event) {
        let id = ev.id;
        if let Some(index) = self.by_robot.as_mut() {
            Self::index(index, &ev);
        }
        let key = time_key(ev.time);
        let slot = self.slots.put(ev);
        self.order.push(Entry {
            key,
            cause: id.cause,
            index: id.index,
            slot,
        });
        // Sweep the stale entries rather than grow, when they are a quarter of the table or
        // more (so a sweep, one pass over the table, frees at least a quarter of it).
        let stale = self.place.len() - self.live;
        if self.place.len() == self.place.capacity() && stale >= self.place.capacity() / 4 {
            let slots = &self.slots;
            self.place.retain(|id, slot| slots.holds(*slot, *id));
        }
        self.place.insert(id, slot);
        self.live += 1;
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
        match self.place.remove(&id) {
            Some(slot) if self.slots.holds(slot, id) => {
                let ev = self.slots.take(slot);
                self.live -= 1;
                self.unindex(&ev);
                true
            }
            _ => false,
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

    /// Whether the entry's event is still pending (not cancelled).
    fn pending(&self, e: &Entry) -> bool {
        let id = EventId {
            cause: e.cause,
            index: e.index,
        };
        self.slots.holds(e.slot, id)
    }

    /// Takes the pending event of an entry just popped.
    fn take(&mut self, e: &Entry) -> Event {
        let ev = self.slots.take(e.slot);
        self.live -= 1;
        self.unindex(&ev);
        ev
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
            if self.pending(&e) {
                return Some(self.take(&e));
            }
        }
        None
    }

    /// Removes and returns the next pending event if it is at `until` or before.
    pub fn pop_until(&mut self, until: f64) -> Option<Event> {
        while let Some(e) = self.order.pop() {
            if !self.pending(&e) {
                continue;
            }
            if key_time(e.key) <= until {
                return Some(self.take(&e));
            }
            // Too late: it stays the next event.
            self.order.push_front(e);
            return None;
        }
        None
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
            let mut all: Vec<Event> = slots.all().collect();
            all.sort_unstable_by_key(|e| e.id);
            for ev in &all {
                Self::index(&mut index, ev);
            }
            index
        });
        let place = &self.place;
        let mut evs: Vec<Event> = index
            .get(robot as usize)
            .into_iter()
            .flatten()
            .filter_map(|id| place.get(id).and_then(|&s| slots.get(s)))
            .collect();
        evs.sort_by(|a, b| a.time.total_cmp(&b.time).then(a.id.cmp(&b.id)));
        evs
    }
}

/// Slots per chunk of [`Slots`] (1.3 MB of events).
const CHUNK_BITS: u32 = 14;

/// What a slot store keeps: anything with an event id.
trait Stored {
    fn id(&self) -> EventId;
}

impl Stored for Event {
    fn id(&self) -> EventId {
        self.id
    }
}

/// Values in numbered slots, reused last-freed first, in chunks that never move: a million
/// robots keep millions of events, and growing one vector would copy them all and hold both
/// copies at once.
#[derive(Debug)]
struct Slots<T> {
    chunks: Vec<Box<[Option<T>]>>,
    free: Vec<u32>,
    /// Slots handed out so far.
    used: u32,
}

impl<T> Default for Slots<T> {
    fn default() -> Self {
        Self {
            chunks: Vec::new(),
            free: Vec::new(),
            used: 0,
        }
    }
}

impl<T: Stored> Slots<T> {
    /// Puts `v` in a free slot and returns its number (below 2^31).
    fn put(&mut self, v: T) -> u32 {
        let slot = match self.free.pop() {
            Some(s) => s,
            None => {
                let s = self.used;
                assert!(s < 1 << 31, "fewer than 2^31 pending events of a kind");
                self.used = s + 1;
                if (s >> CHUNK_BITS) as usize == self.chunks.len() {
                    self.chunks
                        .push((0..1 << CHUNK_BITS).map(|_| None).collect());
                }
                s
            }
        };
        *self.cell(slot) = Some(v);
        slot
    }

    fn cell(&mut self, slot: u32) -> &mut Option<T> {
        &mut self.chunks[(slot >> CHUNK_BITS) as usize][(slot & ((1 << CHUNK_BITS) - 1)) as usize]
    }

    /// The value in `slot`, if any.
    fn get(&self, slot: u32) -> Option<&T> {
        self.chunks
            .get((slot >> CHUNK_BITS) as usize)?
            .get((slot & ((1 << CHUNK_BITS) - 1)) as usize)?
            .as_ref()
    }

    /// Whether `slot` holds the event `id`.
    fn holds(&self, slot: u32, id: EventId) -> bool {
        self.get(slot).is_some_and(|v| v.id() == id)
    }

    /// Takes the value out of `slot`, which becomes free.
    fn take(&mut self, slot: u32) -> T {
        let v = self.cell(slot).take().expect("a pending event");
        self.free.push(slot);
        v
    }

    /// Every value, in slot order.
    fn iter(&self) -> impl Iterator<Item = &T> {
        self.chunks.iter().flat_map(|c| c.iter().flatten())
    }
}

/// A motion step as the queue keeps it (32 bytes, where an [`Event`] takes 80): the motion
/// manager's `MotionStep` of one robot, its only content the robot and the step's number. A
/// motion schedules all its steps at once, so a million moving robots keep four million of
/// them pending (issue 17).
#[derive(Clone, Copy, Debug)]
struct CompactStep {
    time: f64,
    id: EventId,
    robot: RobotId,
    step: u32,
    class: EventClass,
}

impl Stored for CompactStep {
    fn id(&self) -> EventId {
        self.id
    }
}

impl CompactStep {
    /// `ev` as a compact step, if it is a motion step that [`CompactStep::event`] gives back
    /// exactly.
    fn of(ev: &Event) -> Option<Self> {
        match ev.payload {
            Payload::MotionStep { robot, step }
                if ev.target == Target::MotionManager && ev.concerns == [robot, NO_ROBOT] =>
            {
                Some(Self {
                    time: ev.time,
                    id: ev.id,
                    robot,
                    step: u32::try_from(step).ok()?,
                    class: ev.class,
                })
            }
            _ => None,
        }
    }

    /// The event it stands for.
    fn event(&self) -> Event {
        Event {
            time: self.time,
            id: self.id,
            target: Target::MotionManager,
            class: self.class,
            concerns: [self.robot, NO_ROBOT],
            payload: Payload::MotionStep {
                robot: self.robot,
                step: self.step as usize,
            },
        }
    }
}

/// The queue's pending events: motion steps compact, the others whole. A slot number's top
/// bit says which store it is in.
#[derive(Debug, Default)]
struct Store {
    events: Slots<Event>,
    steps: Slots<CompactStep>,
}

/// The top bit of a slot number in [`Store`]: a compact step's.
const STEP: u32 = 1 << 31;

impl Store {
    fn put(&mut self, ev: Event) -> u32 {
        match CompactStep::of(&ev) {
            Some(step) => self.steps.put(step) | STEP,
            None => self.events.put(ev),
        }
    }

    fn holds(&self, slot: u32, id: EventId) -> bool {
        if slot & STEP != 0 {
            self.steps.holds(slot & !STEP, id)
        } else {
            self.events.holds(slot, id)
        }
    }

    fn take(&mut self, slot: u32) -> Event {
        if slot & STEP != 0 {
            self.steps.take(slot & !STEP).event()
        } else {
            self.events.take(slot)
        }
    }

    /// A copy of the event in `slot`, if any (for listings).
    fn get(&self, slot: u32) -> Option<Event> {
        if slot & STEP != 0 {
            self.steps.get(slot & !STEP).map(CompactStep::event)
        } else {
            self.events.get(slot).cloned()
        }
    }

    /// Copies of every pending event.
    fn all(&self) -> impl Iterator<Item = Event> + '_ {
        (self.events.iter().cloned()).chain(self.steps.iter().map(CompactStep::event))
    }
}

/// Hashes event ids so that the first eight events of a handling fall in neighbouring
/// buckets of [`EventQueue::place`] (a handling's new entries share cache lines, and so do
/// the cancellations of events predicted together) while everything else is spread: the low
/// three bits are the index's, the rest is mixed from the cause and the index's higher bits
/// (longer runs of neighbours made long probes: a setup's million events at cause 0 filled
/// one run of a million buckets).
#[derive(Clone, Copy, Debug, Default)]
pub struct IdHash;

impl std::hash::BuildHasher for IdHash {
    type Hasher = IdHasher;

    fn build_hasher(&self) -> IdHasher {
        IdHasher { cause: 0, index: 0 }
    }
}

/// The hasher of [`IdHash`].
#[derive(Clone, Copy, Debug)]
pub struct IdHasher {
    cause: u64,
    index: u32,
}

impl std::hash::Hasher for IdHasher {
    fn finish(&self) -> u64 {
        // A 64-bit finalizer (splitmix64's) of the cause and the index's run of eight.
        let mut x = self.cause ^ u64::from(self.index >> 3).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        x ^= x >> 31;
        (x & !7) | u64::from(self.index & 7)
    }

    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.cause = (self.cause ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
    }

    fn write_u64(&mut self, cause: u64) {
        self.cause ^= cause;
    }

    fn write_u32(&mut self, index: u32) {
        self.index ^= index;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
        for e in [&a, &b, &c] {
            q.register(e.clone());
        }
        let listed: Vec<String> = q.future_of(9).iter().map(|e| format!("{e:?}")).collect();
        let want: Vec<String> = [&c, &a, &b].iter().map(|e| format!("{e:?}")).collect();
        assert_eq!(listed, want);
        let popped: Vec<String> = std::iter::from_fn(|| q.pop())
            .map(|e| format!("{e:?}"))
            .collect();
        assert_eq!(popped, want);
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
            /// Cancel the `k`-th last event that fired (or was cancelled): nothing happens.
            CancelGone(usize),
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
                    1 => (0usize..20).prop_map(Op::CancelGone),
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
                // Events that fired or were cancelled, latest last.
                let mut gone: Vec<EventId> = Vec::new();
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
                                gone.push(e.id);
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
                                // Motion steps (kept compact) and other events.
                                let e = if robot % 2 == 0 {
                                    step(t, seq, index as u32, robot)
                                } else {
                                    ev(t, seq, index as u32, robot)
                                };
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
                            if had.is_some() {
                                gone.push(id);
                            }
                        }
                        Op::CancelGone(k) => {
                            if let Some(&id) = gone.iter().rev().nth(k) {
                                prop_assert!(!q.cancel(id));
                            }
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
                                gone.push(k.1);
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
