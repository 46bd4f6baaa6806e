//! The outbox a handler writes its effects into (seed 3.6): events to schedule or cancel and
//! observations to record, named by causality ([`crate::world::event`]'s ordering) and carried
//! out by the scheduler after the handling.

use super::event::{Effect, Event, EventClass, EventId, Handle, Notice, Payload, Target, NO_ROBOT};
use super::observation::Observation;
use super::queue::Claims;
use super::RobotId;

/// Collects the effects of one event's handling and names the events it creates.
#[derive(Debug)]
pub struct Outbox {
    now: f64,
    cause: u64,
    next: u32,
    effects: Vec<Effect>,
    /// Whether anything reads the robots' step records ([`Outbox::records_steps`]).
    steps: bool,
}

impl Outbox {
    /// An outbox for handling the event processed as number `cause` at time `now`.
    pub fn new(now: f64, cause: u64) -> Self {
        Self {
            now,
            cause,
            next: 0,
            effects: Vec::new(),
            steps: true,
        }
    }

    /// An outbox as [`Outbox::new`] that collects into `effects` after what it holds: a
    /// buffer reused from an earlier handling (no allocation per event), or the effects of
    /// the events handled before this one in the same delivery
    /// ([`crate::host::handle_delivery`]).
    pub fn reusing(now: f64, cause: u64, effects: Vec<Effect>) -> Self {
        Self {
            now,
            cause,
            next: 0,
            effects,
            steps: true,
        }
    }

    /// The outbox, told whether anything reads the robots' step records this run.
    pub fn recording_steps(mut self, steps: bool) -> Self {
        self.steps = steps;
        self
    }

    /// Whether anything reads the robots' step records ([`Observation::is_step`]): when
    /// not, a handler need not make them ([`Outbox::record_step`]).
    pub fn records_steps(&self) -> bool {
        self.steps
    }

    /// Makes room for `n` more effects at once (a setup's millions, which growing by doubling
    /// copied; a million robots' run to simulated second 1 peaked 17 MB lower).
    pub fn reserve(&mut self, n: usize) {
        self.effects.reserve(n);
    }

    /// The outbox, its next event numbered `index` (for tests that make events of given ids).
    #[cfg(test)]
    pub(crate) fn numbering_from(mut self, index: u32) -> Self {
        self.next = index;
        self
    }

    /// The processing number of the event being handled: the `cause` of the events it
    /// creates.
    pub fn cause(&self) -> u64 {
        self.cause
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
        let ev = self.event(time, target, class, robots, payload);
        let id = ev.id;
        self.effects.push(Effect::Schedule(ev));
        id
    }

    /// Schedules an event for the end of the current instant: it is taken once no other event
    /// is pending at this instant, before time moves on; such events are taken in the order
    /// they were scheduled. Its own effects at this instant follow as usual. The motion
    /// manager's [`Payload::Settle`]: most robots that a collision stops start their next
    /// motion at the same instant, so what a robot at rest needs is predicted only for those
    /// still at rest then.
    pub fn at_instant_end(
        &mut self,
        target: Target,
        robots: [Option<RobotId>; 2],
        payload: Payload,
    ) -> EventId {
        let ev = self.event(self.now, target, EventClass::Eventual, robots, payload);
        let id = ev.id;
        self.effects.push(Effect::AtInstantEnd(ev));
        id
    }

    /// Withdraws the event `id` scheduled for the end of this instant, if not taken yet: the
    /// motion manager's [`Payload::Settle`] once every robot it was for has started a motion
    /// (it would be a hop for nothing after most collisions).
    pub fn withdraw_at_instant_end(&mut self, id: EventId) {
        self.effects.push(Effect::WithdrawAtInstantEnd(id));
    }

    /// Schedules a cancellable event in a slot claimed from `claims` and returns its handle,
    /// which the caller keeps to cancel the event and then releases ([`Claims::release`]).
    pub fn schedule_in(
        &mut self,
        claims: &mut Claims,
        time: f64,
        target: Target,
        class: EventClass,
        robots: [Option<RobotId>; 2],
        payload: Payload,
    ) -> Handle {
        let ev = self.event(time, target, class, robots, payload);
        let id = ev.id;
        let slot = claims.claim_for(&ev);
        self.effects.push(Effect::ScheduleIn(ev, slot));
        Handle { id, slot }
    }

    /// The handling's next event, named by the next index.
    fn event(
        &mut self,
        time: f64,
        target: Target,
        class: EventClass,
        robots: [Option<RobotId>; 2],
        payload: Payload,
    ) -> Event {
        debug_assert!(!time.is_nan(), "event time is NaN");
        let id = EventId {
            cause: self.cause,
            index: self.next,
        };
        self.next += 1;
        Event {
            time: time.max(self.now),
            id,
            target,
            class,
            concerns: robots.map(|r| r.unwrap_or(NO_ROBOT)),
            payload,
        }
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
    pub fn cancel(&mut self, h: Handle) {
        self.effects.push(Effect::Cancel(h));
    }

    /// Records an observation for the run's trace.
    pub fn record(&mut self, obs: Observation) {
        self.effects.push(Effect::Record(obs));
    }

    /// Records the step record `make` makes, if anything reads such records
    /// ([`Outbox::records_steps`]): otherwise it is not even made.
    pub fn record_step(&mut self, make: impl FnOnce() -> Observation) {
        if self.steps {
            let obs = make();
            debug_assert!(obs.is_step(), "a step record: {obs:?}");
            self.effects.push(Effect::Record(obs));
        }
    }

    /// The effects, in the order they were produced.
    pub fn into_effects(self) -> Vec<Effect> {
        self.effects
    }
}
