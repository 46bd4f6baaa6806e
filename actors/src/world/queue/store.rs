//! Where the queue keeps its pending events: numbered slots in chunks that never move, motion
//! steps in a compact form, and separate slot ranges for those claimed by handle keepers.

use super::super::event::{Event, EventClass, EventId, Payload, Target, NO_ROBOT};
use super::super::RobotId;
use super::Route;

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
    /// Puts `v` in a free slot and returns its number (below 2^30).
    fn put(&mut self, v: T) -> u32 {
        let slot = match self.free.pop() {
            Some(s) => s,
            None => {
                let s = self.used;
                assert!(s < CLAIMED, "fewer than 2^30 pending events of a kind");
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

    /// Puts `v` in `slot`, chosen by the caller ([`Claims`]), which must be free.
    fn put_at(&mut self, slot: u32, v: T) {
        while (slot >> CHUNK_BITS) as usize >= self.chunks.len() {
            self.chunks
                .push((0..1 << CHUNK_BITS).map(|_| None).collect());
        }
        let cell = self.cell(slot);
        assert!(cell.is_none(), "a claimed slot still holds a pending event");
        *cell = Some(v);
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

    /// Asks for `slot`'s cache lines.
    fn prefetch(&self, slot: u32) {
        if let Some(chunk) = self.chunks.get((slot >> CHUNK_BITS) as usize) {
            if let Some(v) = chunk.get((slot & ((1 << CHUNK_BITS) - 1)) as usize) {
                crate::world::prefetch::prefetch(v);
            }
        }
    }

    /// Takes the value out of `slot` if it is the event `id`; the slot becomes free (for
    /// [`Slots::put`] unless the slots are claimed ones, whose claimer frees them).
    fn take_if(&mut self, slot: u32, id: EventId, claimed: bool) -> Option<T> {
        let cell = self
            .chunks
            .get_mut((slot >> CHUNK_BITS) as usize)?
            .get_mut((slot & ((1 << CHUNK_BITS) - 1)) as usize)?;
        if cell.as_ref().is_none_or(|v| v.id() != id) {
            return None;
        }
        let v = cell.take();
        if !claimed {
            self.free.push(slot);
        }
        v
    }

    /// Every value with its slot, in slot order.
    fn iter(&self) -> impl Iterator<Item = (&T, u32)> {
        self.chunks.iter().enumerate().flat_map(|(k, c)| {
            c.iter().enumerate().filter_map(move |(i, v)| {
                v.as_ref()
                    .map(|v| (v, ((k as u32) << CHUNK_BITS) | i as u32))
            })
        })
    }
}

/// A motion step as the queue keeps it (32 bytes, where an [`Event`] takes 80): the motion
/// manager's `MotionStep` of one robot, its only content the robot and the steps' numbers. A
/// motion schedules all its steps at once, so a million moving robots keep four million of
/// them pending.
#[derive(Clone, Copy, Debug)]
pub(super) struct CompactStep {
    time: f64,
    id: EventId,
    robot: RobotId,
    step: u32,
    /// Steps after `step` that the event stands for too.
    more: u8,
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
    pub(super) fn of(ev: &Event) -> Option<Self> {
        match ev.payload {
            Payload::MotionStep {
                robot,
                step,
                through,
            } if ev.target == Target::MotionManager && ev.concerns == [robot, NO_ROBOT] => {
                Some(Self {
                    time: ev.time,
                    id: ev.id,
                    robot,
                    step: u32::try_from(step).ok()?,
                    more: u8::try_from(through.checked_sub(step)?).ok()?,
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
                through: self.step as usize + usize::from(self.more),
            },
        }
    }
}

/// The queue's pending events: motion steps compact, the others whole, each in slots the
/// queue hands out or in slots claimed by handle keepers ([`Claims`]). A slot number's top
/// bit says whether it holds a step, the next bit whether it is claimed.
#[derive(Debug, Default)]
pub(super) struct Store {
    events: Slots<Event>,
    steps: Slots<CompactStep>,
    claimed_events: Slots<Event>,
    claimed_steps: Slots<CompactStep>,
}

/// The top bit of a slot number in [`Store`]: a compact step's.
pub(super) const STEP: u32 = 1 << 31;

/// The second bit of a slot number in [`Store`]: a claimed slot.
pub(super) const CLAIMED: u32 = 1 << 30;

/// A slot number without its kind bits.
const NUMBER: u32 = CLAIMED - 1;

/// One of the store's tables, as a slot number names it: compact steps or whole events.
enum Table<'a> {
    Steps(&'a Slots<CompactStep>),
    Events(&'a Slots<Event>),
}

/// [`Table`], to change.
enum TableMut<'a> {
    Steps(&'a mut Slots<CompactStep>),
    Events(&'a mut Slots<Event>),
}

impl Store {
    pub(super) fn put(&mut self, ev: Event) -> u32 {
        match CompactStep::of(&ev) {
            Some(step) => self.steps.put(step) | STEP,
            None => self.events.put(ev),
        }
    }

    /// Puts `ev` in the claimed `slot`: a step slot if and only if `ev` is kept compact (as
    /// [`super::Claims`] chose it).
    pub(super) fn put_at(&mut self, slot: u32, ev: Event) {
        assert!(slot & CLAIMED != 0, "a claimed slot");
        let n = slot & NUMBER;
        if slot & STEP != 0 {
            let step = CompactStep::of(&ev).expect("a compact step in a step slot");
            self.claimed_steps.put_at(n, step);
        } else {
            self.claimed_events.put_at(n, ev);
        }
    }

    /// The table that `slot` names, its number there, and whether it is claimed.
    #[inline(always)]
    fn table(&self, slot: u32) -> (Table<'_>, u32) {
        let n = slot & NUMBER;
        let table = match (slot & STEP != 0, slot & CLAIMED != 0) {
            (true, false) => Table::Steps(&self.steps),
            (false, false) => Table::Events(&self.events),
            (true, true) => Table::Steps(&self.claimed_steps),
            (false, true) => Table::Events(&self.claimed_events),
        };
        (table, n)
    }

    /// [`Store::table`], to change.
    #[inline(always)]
    fn table_mut(&mut self, slot: u32) -> (TableMut<'_>, u32) {
        let n = slot & NUMBER;
        let table = match (slot & STEP != 0, slot & CLAIMED != 0) {
            (true, false) => TableMut::Steps(&mut self.steps),
            (false, false) => TableMut::Events(&mut self.events),
            (true, true) => TableMut::Steps(&mut self.claimed_steps),
            (false, true) => TableMut::Events(&mut self.claimed_events),
        };
        (table, n)
    }

    pub(super) fn holds(&self, slot: u32, id: EventId) -> bool {
        match self.table(slot) {
            (Table::Steps(t), n) => t.holds(n, id),
            (Table::Events(t), n) => t.holds(n, id),
        }
    }

    /// The target and robots of the event in `slot`, if there is one and `wanted` accepts its
    /// id (the check of [`Store::holds`] and the route in one look-up).
    pub(super) fn route_where(&self, slot: u32, wanted: impl Fn(EventId) -> bool) -> Option<Route> {
        match self.table(slot) {
            (Table::Steps(t), n) => t
                .get(n)
                .and_then(|s| wanted(s.id).then_some((Target::MotionManager, [s.robot, NO_ROBOT]))),
            (Table::Events(t), n) => t
                .get(n)
                .and_then(|e| wanted(e.id).then_some((e.target, e.concerns))),
        }
    }

    pub(super) fn prefetch(&self, slot: u32) {
        match self.table(slot) {
            (Table::Steps(t), n) => t.prefetch(n),
            (Table::Events(t), n) => t.prefetch(n),
        }
    }

    /// Takes the event in `slot` if it is the event `id` (the check of [`Store::holds`] and the
    /// taking in one look-up).
    pub(super) fn take_if(&mut self, slot: u32, id: EventId) -> Option<Event> {
        let claimed = slot & CLAIMED != 0;
        match self.table_mut(slot) {
            (TableMut::Steps(t), n) => t.take_if(n, id, claimed).map(|s| s.event()),
            (TableMut::Events(t), n) => t.take_if(n, id, claimed),
        }
    }

    /// A copy of the event in `slot`, if any (for listings).
    pub(super) fn get(&self, slot: u32) -> Option<Event> {
        match self.table(slot) {
            (Table::Steps(t), n) => t.get(n).map(CompactStep::event),
            (Table::Events(t), n) => t.get(n).cloned(),
        }
    }

    /// Copies of every pending event, with their slots.
    pub(super) fn all(&self) -> impl Iterator<Item = (Event, u32)> + '_ {
        let events = |s: &'_ Slots<Event>, bits: u32| {
            s.iter()
                .map(move |(e, n)| (e.clone(), n | bits))
                .collect::<Vec<_>>()
        };
        let steps = |s: &'_ Slots<CompactStep>, bits: u32| {
            s.iter()
                .map(move |(e, n)| (e.event(), n | bits))
                .collect::<Vec<_>>()
        };
        [
            events(&self.events, 0),
            steps(&self.steps, STEP),
            events(&self.claimed_events, CLAIMED),
            steps(&self.claimed_steps, STEP | CLAIMED),
        ]
        .into_iter()
        .flatten()
    }
}
