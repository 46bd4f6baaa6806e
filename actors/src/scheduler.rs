//! The virtual-time scheduler actor, which is also the event manager (seed 3.6 and 4.2.3).
//!
//! # Ordering contract
//!
//! 1. The scheduler owns the only event queue and the virtual clock. Nothing in a simulated run
//!    reads the wall clock or uses actix/tokio timers; time moves only when the scheduler takes
//!    the next event, and it jumps straight to that event's time.
//! 2. Events are taken in order of time; at equal times in order of their causal key
//!    `(cause, index)`: `cause` is the processing number of the event whose handling created
//!    them, `index` their position among that handling's outputs. Processing numbers are given
//!    out in processing order, so the whole order is a function of the scenario and seed alone.
//! 3. One delivery is in flight at a time. The scheduler sends the next event to its actor (a
//!    manager, a robot, a sensor) and waits for the reply, which is the list of effects the
//!    handling produced (events to schedule, events to cancel, observations to record). Only
//!    then does it take the next event. A delivery may carry a run: the events that come
//!    next for the same actor ([`Deliver::then`]). The actor handles each in turn only while
//!    the handlings before it leave it the next event ([`handle_run`]) and hands the rest
//!    back, so the events taken and their order are those of one delivery per event. Actors
//!    never message each other directly: every hop is an event.
//! 4. Quiescence is therefore structural: an actor's work at instant `t` is exactly the handling
//!    of events at `t`, and everything it causes is an event at `t` or later. Virtual time
//!    cannot advance while work at the current instant remains, because that work is an event
//!    at the current instant and sorts first. A robot's algorithm runs inside its actor's
//!    handler until it blocks on a motion, sensor, timer or notice, so every request it makes
//!    is in the reply before the scheduler moves on.
//! 5. Because of 2 and 3, the order does not depend on which arbiter (thread) hosts an actor
//!    or on mailbox timing; a run spread over several arbiters gives the same events in the
//!    same order as a run on one.

use std::collections::{HashMap, VecDeque};

use actix::prelude::*;

use crate::host::{Deliver, Host, Replied, Reply, ReplyTo, RUN};
use crate::robot::RobotActor;
use crate::world::event::{Effect, Event, FutureEvent, Notice, Payload, Target};
use crate::world::observation::{Observation, Record};
use crate::world::outbox::Outbox;
use crate::world::queue::{Ahead, EventQueue, Route};
use crate::world::sensor::SensorKind;
use crate::world::RobotId;

/// Who handles which events.
pub struct Routes {
    pub motion_manager: Recipient<Deliver>,
    pub sensor_manager: Recipient<Deliver>,
    /// The robot actors' addresses themselves, not boxed recipients: one fewer indirection
    /// into a million cold robots' memory on every hop.
    pub robots: Vec<Addr<Host<RobotActor>>>,
    pub network: Recipient<Deliver>,
    /// Each robot's protocol layers, by stack index.
    pub layers: Vec<Vec<Recipient<Deliver>>>,
    /// Starts a robot's sensor actor on the robot's arbiter when it is first needed.
    pub spawn_sensor: Box<dyn Fn(RobotId, SensorKind) -> Recipient<Deliver>>,
    /// Called, while an event is delivered, with the robots that the next two pending events
    /// concern when they are for a manager or the network ([`Core::ahead_in_world`]): asks for
    /// what their handlings read in the world ([`crate::world::VirtualWorld::prefetch`]), so
    /// that it arrives while this event is handled. Only a hint: it changes nothing.
    pub prefetch: Prefetch,
}

/// The look-ahead into the world ([`Routes::prefetch`]): called with what the next event and
/// the one after it read there ([`WorldAhead`]).
pub type Prefetch = Box<dyn Fn(&WorldAhead)>;

/// What the next two pending events read in the world ([`Core::ahead_in_world`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WorldAhead {
    /// The robots of the next event, when its handling reads the world,
    pub next: Option<[RobotId; 2]>,
    /// those of the event after it, likewise,
    pub after: Option<[RobotId; 2]>,
    /// and the robot and offset of the next event when it is a cell crossing.
    pub crossing: Option<(RobotId, [i64; 2])>,
}

impl WorldAhead {
    /// Asks `world` for all of it ([`VirtualWorld::prefetch`](crate::world::virtual_world::VirtualWorld::prefetch),
    /// [`VirtualWorld::prefetch_crossing`](crate::world::virtual_world::VirtualWorld::prefetch_crossing)).
    pub fn prefetch(&self, world: &crate::world::virtual_world::VirtualWorld) {
        world.prefetch(self.next, self.after);
        if let Some((robot, offset)) = self.crossing {
            world.prefetch_crossing(robot, offset);
        }
    }
}

impl std::fmt::Debug for Routes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Routes")
            .field("robots", &self.robots.len())
            .finish()
    }
}

/// Figures of a finished run.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RunStats {
    /// Events processed.
    pub events: u64,
    /// Events cancelled before they fired.
    pub cancelled: u64,
    /// Collisions (robot-robot and boundary).
    pub collisions: u64,
    /// Virtual time at the end [s].
    pub end_time: f64,
    /// Whether the run was stopped from outside before `until` ([`Observers::stop`]).
    pub interrupted: bool,
}

/// What a run hands back.
#[derive(Clone, Debug, Default)]
pub struct RunOutput {
    pub records: Vec<Record>,
    pub stats: RunStats,
    /// Set if the run stopped early: a livelock, or an actor that failed.
    pub failure: Option<RunFailure>,
}

/// Why a run stopped before its end time; both are fatal for the run (it ends where it got
/// to, its outputs hold the run up to there).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RunFailure {
    /// More than `limit` events happened at the instant `t` without virtual time advancing.
    #[error("livelock at t={t}: more than {limit} events without virtual time advancing (an algorithm keeps retrying at the same instant, e.g. a motion blocked by a collision, without waiting)")]
    Livelock { t: f64, limit: u64 },
    /// An actor did not answer an event (an internal error).
    #[error("{target} did not answer: {error}")]
    NoAnswer { target: String, error: String },
}

/// The scheduler's state apart from the actor machinery: the event queue, the virtual clock,
/// the crashed robots and the run's output. The scheduler actor hosts it; the kernel-alone
/// reference ([`crate::kernel`]) drives the same core without actors, so both take the same
/// events in the same order.
pub(crate) struct Core {
    queue: EventQueue,
    now: f64,
    seq: u64,
    until: f64,
    /// Crashed robots: events for their robot, sensor and layer actors are dropped.
    crashed: std::collections::BTreeSet<RobotId>,
    output: RunOutput,
    observers: Observers,
    recorded: u64,
    /// Events processed at the current instant, and the most allowed before the run is
    /// declared a livelock.
    at_instant: u64,
    instant_limit: u64,
    /// The effects buffer that the next delivery carries (see [`Deliver::effects`]).
    spare: Vec<Effect>,
    /// The routes of the next two pending events, seen when the last was taken
    /// ([`EventQueue::look_ahead`]).
    ahead: Ahead,
    /// Events for the end of the current instant ([`Outbox::at_instant_end`]), in the order
    /// they were scheduled.
    closing: VecDeque<Event>,
    /// Whether deliveries carry runs ([`Deliver::then`]): the scheduler actor's do, the
    /// kernel-alone reference's not (it has no hop to save).
    runs: bool,
    /// The time and slot of each event of the run in flight after its first.
    run: smallvec::SmallVec<[(f64, u32); RUN]>,
    /// The buffer for the next delivery's run (see `spare`).
    spare_then: Vec<Event>,
}

/// The fewest pending events at which the core looks ahead ([`EventQueue::look_ahead`]) and
/// the scheduler asks for what the next handlings will read. A world that small (about 2.75
/// pending events a robot in random movement: some 6,000 robots) is in cache anyway, and the
/// look-ahead was then only work: `nekosim run` of 1,000 robots for 330 s takes 8 % fewer
/// instructions without it, while 100,000 robots for 40 s ran faster with it (2.33 against
/// 2.54 s, the means of five alternate runs; docs/performance.md, issue 17, fourteenth
/// session).
pub(crate) const LOOK_AHEAD_FROM: usize = 1 << 14;

/// The largest effects buffer kept for reuse: the setup's million start notices are not.
const SPARE_EFFECTS: usize = 1 << 10;

/// What the core says to do next.
pub(crate) enum Next {
    /// Hand this event to the actor behind `Target` and apply its reply.
    Deliver(Target, Deliver),
    /// The run is over: `until` passed, no event left, a stop, a livelock.
    Finish,
}

/// The scheduler actor.
pub struct Scheduler {
    core: Core,
    routes: Routes,
    /// Where the replies go ([`ReplyTo`]): itself, once started.
    me: Option<std::sync::Arc<Recipient<Replied>>>,
    /// The target of the delivery in flight.
    in_flight: Option<Target>,
    sensors: HashMap<(RobotId, SensorKind), Recipient<Deliver>>,
    on_finish: Option<Box<dyn FnOnce(RunOutput)>>,
}

/// Receives every observation of a run, in order.
pub type Sink = Box<dyn FnMut(&Record)>;

/// How many robots spawn between two calls of [`Observers::startup`].
pub const STARTUP_EVERY: usize = 10_000;

/// Who sees a run while it goes on.
#[derive(Default)]
pub struct Observers {
    /// Keep every observation in [`RunOutput::records`].
    pub keep: bool,
    /// Called with every observation, in order (for streaming outputs).
    pub sink: Option<Sink>,
    /// Called with the virtual time and the number of events processed so far every
    /// [`PROGRESS_EVERY`] events (so a long instant, such as a million robots starting at
    /// t = 0, still shows progress).
    pub progress: Option<Box<dyn FnMut(f64, u64)>>,
    /// Called while the run starts, before its first event, with the robots spawned so far and
    /// their number (every [`STARTUP_EVERY`] robots, and when all are), so a large run is not
    /// silent while it starts.
    pub startup: Option<Box<dyn FnMut(usize, usize)>>,
    /// Set from outside the simulation (the user's Ctrl-C) to end the run before its next
    /// event, at the virtual time reached, as if `until` had come then: the run finishes
    /// normally and [`RunStats::interrupted`] says so.
    pub stop: Option<std::sync::Arc<std::sync::atomic::AtomicBool>>,
}

impl std::fmt::Debug for Observers {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Observers")
            .field("keep", &self.keep)
            .field("sink", &self.sink.is_some())
            .field("progress", &self.progress.is_some())
            .field("startup", &self.startup.is_some())
            .field("stop", &self.stop)
            .finish()
    }
}

/// How many events pass between two progress calls.
pub const PROGRESS_EVERY: u64 = 4096;

impl std::fmt::Debug for Scheduler {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scheduler")
            .field("now", &self.core.now)
            .field("seq", &self.core.seq)
            .field("pending", &self.core.queue.len())
            .finish()
    }
}

impl Core {
    /// A core that runs until `until` [s]; `setup` holds the effects of the setup at t = 0
    /// (cause 0).
    pub(crate) fn new(until: f64, setup: Outbox, observers: Observers) -> Self {
        let mut core = Self {
            queue: EventQueue::new(),
            now: 0.0,
            seq: 0,
            until,
            crashed: std::collections::BTreeSet::new(),
            output: RunOutput::default(),
            observers,
            recorded: 0,
            at_instant: 0,
            instant_limit: u64::MAX,
            spare: Vec::new(),
            ahead: Ahead::default(),
            closing: VecDeque::new(),
            runs: false,
            run: smallvec::SmallVec::new(),
            spare_then: Vec::new(),
        };
        core.apply(setup.into_effects());
        core
    }

    /// Applies the effects of one handling, in order.
    pub(crate) fn apply(&mut self, mut effects: Vec<Effect>) {
        self.prefetch_cancelled(&effects);
        for e in effects.drain(..) {
            self.apply_one(e);
        }
        self.keep_spare(effects);
    }

    /// Applies a delivery's reply ([`Reply`]): first the events of its run that were not
    /// handled go back to the queue, as they were before the delivery took them; then each
    /// handled event is taken in turn (as [`Core::next`] would have taken it: its time, its
    /// number, the count) and its effects applied. Since each handled event was still the
    /// next one after the effects before it, this is the order of delivering them one by one.
    pub(crate) fn apply_reply(&mut self, reply: Reply) {
        let Reply {
            mut effects,
            ends,
            mut then,
        } = reply;
        self.prefetch_cancelled(&effects);
        let handled = ends.len() - 1;
        assert_eq!(
            handled + then.len(),
            self.run.len(),
            "a run's events handled or handed back"
        );
        for (ev, &(_, slot)) in then.drain(..).rev().zip(self.run.iter().rev()) {
            self.queue.put_back(ev, slot);
        }
        let mut j = 0;
        for (k, e) in effects.drain(..).enumerate() {
            while k as u32 >= ends[j] {
                j += 1;
                self.enter(self.run[j - 1].0);
            }
            self.apply_one(e);
        }
        while j < handled {
            j += 1;
            self.enter(self.run[j - 1].0);
        }
        self.run.clear();
        self.keep_spare(effects);
        if then.capacity() <= RUN {
            self.spare_then = then;
        }
    }

    /// In a large queue (as [`EventQueue::look_ahead`]), asks for the slots of the events that
    /// `effects` cancel, all at once before the first is read: at a million robots each is a
    /// cache miss of its own (issue 17).
    #[inline]
    fn prefetch_cancelled(&self, effects: &[Effect]) {
        if self.queue.len() < LOOK_AHEAD_FROM {
            return;
        }
        for e in effects {
            if let Effect::Cancel(h) = e {
                self.queue.prefetch_slot(*h);
            }
        }
    }

    #[inline]
    fn keep_spare(&mut self, effects: Vec<Effect>) {
        if effects.capacity() <= SPARE_EFFECTS && effects.capacity() > self.spare.capacity() {
            self.spare = effects;
        }
    }

    /// Takes an event at `time` for processing: the clock, the processing number, the count
    /// and its progress calls. (The livelock check is the caller's.)
    #[inline]
    fn enter(&mut self, time: f64) {
        if time == self.now {
            self.at_instant += 1;
        } else {
            self.at_instant = 1;
        }
        self.now = time;
        self.seq += 1;
        self.output.stats.events += 1;
        if self.output.stats.events % PROGRESS_EVERY == 0 {
            if let Some(p) = self.observers.progress.as_mut() {
                p(self.now, self.output.stats.events);
            }
        }
    }

    /// Whether the run was stopped from outside.
    fn stopped(&self) -> bool {
        let stop = self.observers.stop.as_ref();
        stop.is_some_and(|s| s.load(std::sync::atomic::Ordering::Relaxed))
    }

    /// Takes the events after the one just taken for `target` (`first`) that come next for
    /// the same actor, up to a run of [`RUN`] ([`Deliver::then`]), each one that
    /// [`Core::next`] would take and deliver there next: at `until` or before, for the same
    /// actor, not past the livelock limit, no instant's end event pending (it could come
    /// between them). After an event that schedules another at its instant
    /// ([`Payload::schedules_at_its_instant`]), only events of that instant.
    fn take_run(&mut self, target: Target, first: &Payload) -> Vec<Event> {
        let mut then = std::mem::take(&mut self.spare_then);
        debug_assert!(then.is_empty() && self.run.is_empty());
        if !self.runs || !self.closing.is_empty() || self.stopped() {
            return then;
        }
        let (mut t, mut at) = (self.now, self.at_instant);
        let mut until = if first.schedules_at_its_instant() {
            self.now
        } else {
            self.until
        };
        while then.len() < RUN - 1 {
            let Some((ev, slot)) = self.queue.pop_for(target, until) else {
                break;
            };
            let n = if ev.time == t { at + 1 } else { 1 };
            if n > self.instant_limit {
                self.queue.put_back(ev, slot);
                break;
            }
            (t, at) = (ev.time, n);
            if ev.payload.schedules_at_its_instant() {
                until = ev.time;
            }
            self.run.push((ev.time, slot));
            then.push(ev);
        }
        then
    }

    /// Applies one effect.
    #[inline(always)]
    fn apply_one(&mut self, e: Effect) {
        match e {
            Effect::Schedule(ev) => {
                assert!(ev.time >= self.now, "an event was scheduled in the past");
                self.queue.register(ev);
            }
            Effect::ScheduleIn(ev, slot) => {
                assert!(ev.time >= self.now, "an event was scheduled in the past");
                self.queue.register_in(ev, slot);
            }
            Effect::AtInstantEnd(ev) => {
                debug_assert!(
                    ev.time == self.now,
                    "an instant's end event at another time"
                );
                self.closing.push_back(ev);
            }
            Effect::WithdrawAtInstantEnd(id) => {
                if let Some(k) = self.closing.iter().position(|e| e.id == id) {
                    self.closing.remove(k);
                }
            }
            Effect::Cancel(h) => {
                if self.queue.cancel(h) {
                    self.output.stats.cancelled += 1;
                }
            }
            Effect::Record(obs) => {
                if matches!(obs, Observation::Collision { .. }) {
                    self.output.stats.collisions += 1;
                }
                let record = Record {
                    t: self.now,
                    seq: self.recorded,
                    obs,
                };
                self.recorded += 1;
                if let Some(sink) = self.observers.sink.as_mut() {
                    sink(&record);
                }
                if self.observers.keep {
                    self.output.records.push(record);
                }
            }
        }
    }

    /// Takes the next event: events of crashed robots are dropped and the event manager's
    /// own events handled here; the first event for another actor is returned for delivery.
    pub(crate) fn next(&mut self) -> Next {
        loop {
            if self.stopped() {
                self.output.stats.interrupted = true;
                return Next::Finish;
            }
            // The instant's end events once nothing else is pending at this instant.
            let closing =
                !self.closing.is_empty() && self.queue.peek_time().is_none_or(|t| t > self.now);
            let event = if closing {
                self.closing.pop_front()
            } else {
                self.queue.pop_until(self.until)
            };
            let Some(event) = event else {
                return Next::Finish;
            };
            if !closing
                && !self.closing.is_empty()
                && matches!(event.payload, Payload::ListEvents { .. })
            {
                // A listing waits for the instant's end events, so that it shows what they
                // predict.
                self.closing.push_back(event);
                continue;
            }
            debug_assert!(event.time >= self.now, "time went backwards");
            if event.time == self.now && self.at_instant >= self.instant_limit {
                self.output.failure = Some(RunFailure::Livelock {
                    t: self.now,
                    limit: self.instant_limit,
                });
                return Next::Finish;
            }
            self.enter(event.time);
            let target = event.target;
            let dead = match target {
                Target::Robot(r) | Target::Sensor(r, _) | Target::Layer(r, _) => {
                    self.crashed.contains(&r)
                }
                _ => false,
            };
            if dead {
                continue;
            }
            if target == Target::EventManager {
                self.handle_inline(event);
                continue;
            }
            let then = self.take_run(target, &event.payload);
            let look_ahead = self.queue.len() >= LOOK_AHEAD_FROM;
            self.ahead = if look_ahead {
                self.queue.look_ahead()
            } else {
                Ahead::default()
            };
            let deliver = Deliver {
                now: self.now,
                seq: self.seq,
                event,
                effects: std::mem::take(&mut self.spare),
                reply: None,
                then,
                look_ahead,
            };
            return Next::Deliver(target, deliver);
        }
    }

    /// The event manager's own events: a robot's listing of its future events.
    fn handle_inline(&mut self, event: Event) {
        let mut out = Outbox::reusing(self.now, self.seq, std::mem::take(&mut self.spare));
        if let Payload::Crash { robot } = event.payload {
            // From now on the robot's own actors get nothing; the motion manager stops it.
            self.crashed.insert(robot);
            out.schedule(
                self.now,
                Target::MotionManager,
                crate::world::event::EventClass::Eventual,
                [Some(robot), None],
                Payload::Crash { robot },
            );
        } else if let Payload::ListEvents { robot, of, ticket } = event.payload {
            let events = self
                .queue
                .future_of(of)
                .into_iter()
                .flat_map(|e| {
                    let listed = FutureEvent {
                        time: e.time,
                        class: e.class,
                        kind: e.payload.kind(),
                        robots: e.robots(),
                    };
                    std::iter::repeat_n(listed, e.payload.stands_for())
                })
                .collect();
            out.notify(robot, Notice::FutureEvents { ticket, events });
        }
        self.apply(out.into_effects());
    }

    /// Records that the actor behind `target` did not answer; the run then finishes.
    pub(crate) fn no_answer(&mut self, target: Target, error: String) {
        self.output.failure = Some(RunFailure::NoAnswer {
            target: format!("{target:?}"),
            error,
        });
    }

    /// The run's output, once it is over.
    pub(crate) fn finish(&mut self) -> RunOutput {
        // Whatever the observers hold (the outputs being written) is theirs again at once,
        // whether or not the actors are dropped after the run (`simulation::run_then_exit`).
        self.observers = Observers::default();
        let mut output = std::mem::take(&mut self.output);
        output.stats.end_time = if self.queue.is_empty() || output.stats.interrupted {
            self.now
        } else {
            self.until.max(self.now)
        };
        output
    }

    /// The routes of the next two pending events, as seen when the last was taken.
    #[cfg(test)]
    pub(crate) fn ahead(&self) -> Ahead {
        self.ahead
    }

    /// The robots of the next two pending events, each when it is for a manager or the
    /// network, whose handling reads their state in the world: what the look-ahead prefetches
    /// there (`None` when neither is).
    pub(crate) fn ahead_in_world(&self) -> Option<WorldAhead> {
        let in_world = |route: Option<Route>| match route {
            Some((Target::MotionManager | Target::SensorManager | Target::Network, robots)) => {
                Some(robots)
            }
            _ => None,
        };
        let (next, after) = (in_world(self.ahead.next), in_world(self.ahead.after));
        (next.is_some() || after.is_some()).then_some(WorldAhead {
            next,
            after,
            crossing: self.ahead.crossing,
        })
    }

    /// Fails the run when more than `limit` events happen at one instant of virtual time.
    pub(crate) fn set_instant_limit(&mut self, limit: u64) {
        self.instant_limit = limit;
    }
}

impl Scheduler {
    /// A scheduler that runs until `until` [s] and then calls `on_finish`; `setup` holds the
    /// effects of the setup at t = 0 (cause 0).
    pub fn new(
        routes: Routes,
        until: f64,
        setup: Outbox,
        observers: Observers,
        on_finish: Box<dyn FnOnce(RunOutput)>,
    ) -> Self {
        let mut core = Core::new(until, setup, observers);
        core.runs = true;
        Self {
            core,
            routes,
            me: None,
            in_flight: None,
            sensors: HashMap::new(),
            on_finish: Some(on_finish),
        }
    }

    fn route(&mut self, target: Target) -> &Recipient<Deliver> {
        match target {
            Target::EventManager => unreachable!("the event manager's events are handled inline"),
            Target::Robot(_) => unreachable!("robots are sent to by address"),
            Target::MotionManager => &self.routes.motion_manager,
            Target::SensorManager => &self.routes.sensor_manager,
            Target::Network => &self.routes.network,
            Target::Layer(r, l) => &self.routes.layers[r as usize][l as usize],
            Target::Sensor(r, k) => {
                let spawn = &self.routes.spawn_sensor;
                self.sensors.entry((r, k)).or_insert_with(|| spawn(r, k))
            }
        }
    }

    /// Takes the next event and sends it to its actor, whose reply ([`Replied`]) steps on.
    fn step(&mut self, ctx: &mut Context<Self>) {
        let (target, mut deliver) = match self.core.next() {
            Next::Finish => return self.finish(),
            Next::Deliver(target, deliver) => (target, deliver),
        };
        if let Some(world) = self.core.ahead_in_world() {
            (self.routes.prefetch)(&world);
        }
        let me = self
            .me
            .get_or_insert_with(|| std::sync::Arc::new(ctx.address().recipient()));
        deliver.reply = Some(ReplyTo::new(me.clone()));
        self.in_flight = Some(target);
        // A closed mailbox drops the delivery, whose `ReplyTo` then says so.
        match target {
            Target::Robot(r) => self.routes.robots[r as usize].do_send(deliver),
            _ => self.route(target).do_send(deliver),
        }
    }

    /// Hands the output over. The actor is not stopped: the run's host drops or leaves the
    /// whole system once it has the output (`simulation::run_then_exit`), so the million
    /// robots' addresses and the queue are not dropped here one by one.
    fn finish(&mut self) {
        let output = self.core.finish();
        if let Some(f) = self.on_finish.take() {
            f(output);
        }
    }

    /// Fails the run when more than `limit` events happen at one instant of virtual time (an
    /// algorithm retrying forever without letting time pass).
    pub fn with_instant_limit(mut self, limit: u64) -> Self {
        self.core.set_instant_limit(limit);
        self
    }

    /// The pending events of a robot (the event manager's listing).
    pub fn future_of(&mut self, robot: RobotId) -> Vec<Event> {
        self.core.queue.future_of(robot)
    }
}

impl Actor for Scheduler {
    type Context = Context<Self>;

    fn started(&mut self, ctx: &mut Self::Context) {
        self.step(ctx);
    }
}

impl Handler<Replied> for Scheduler {
    type Result = ();

    fn handle(&mut self, reply: Replied, ctx: &mut Context<Self>) {
        let target = self
            .in_flight
            .take()
            .expect("a reply to the delivery in flight");
        match reply.0 {
            Ok(reply) => {
                self.core.apply_reply(reply);
                self.step(ctx);
            }
            Err(e) => {
                self.core.no_answer(target, e);
                self.finish();
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::handler::HandleEvent;
    use crate::host::handle_run;
    use crate::world::event::{EventClass, EventId};

    fn timer(robot: RobotId) -> Payload {
        Payload::Timer { robot, ticket: 0 }
    }

    /// Runs a core from timers `(time, robot)` set at the setup, with `handle` as every
    /// actor's handling (given the robot of the event, see `robot_of`); returns the events
    /// taken as `(time, robot)`, in order.
    fn run_timers(
        timers: &[(f64, RobotId)],
        mut handle: impl FnMut(RobotId, &mut Outbox),
    ) -> Vec<(f64, RobotId)> {
        let mut setup = Outbox::new(0.0, 0);
        for &(t, r) in timers {
            setup.schedule(
                t,
                Target::Robot(r),
                EventClass::Eventual,
                [Some(r), None],
                timer(r),
            );
        }
        let mut core = Core::new(10.0, setup, Observers::default());
        let mut order = Vec::new();
        while let Next::Deliver(_, d) = core.next() {
            let r = robot_of(&d.event.payload);
            order.push((d.now, r));
            let mut out = Outbox::new(d.now, d.seq);
            handle(r, &mut out);
            core.apply(out.into_effects());
        }
        order
    }

    /// A core with timers for robots `0..n` at 1, 2, ... s.
    fn timers_core(n: usize) -> Core {
        let mut setup = Outbox::new(0.0, 0);
        for k in 0..n {
            let r = k as RobotId;
            setup.schedule(
                1.0 + k as f64,
                Target::Robot(r),
                EventClass::Eventual,
                [Some(r), None],
                timer(r),
            );
        }
        Core::new(1e9, setup, Observers::default())
    }

    /// The core looks ahead only while the queue holds [`LOOK_AHEAD_FROM`] events or more,
    /// and then sees the routes of the next two events and tells the actor to look ahead in
    /// its run ([`Deliver::look_ahead`]).
    #[test]
    fn the_core_looks_ahead_only_in_a_large_queue() {
        // One event taken leaves LOOK_AHEAD_FROM - 1 pending: no look.
        let mut small = timers_core(LOOK_AHEAD_FROM);
        assert!(matches!(small.next(), Next::Deliver(Target::Robot(0), d) if !d.look_ahead));
        assert_eq!(small.ahead(), Ahead::default());
        let mut large = timers_core(LOOK_AHEAD_FROM + 1);
        assert!(matches!(large.next(), Next::Deliver(Target::Robot(0), d) if d.look_ahead));
        let route = |r: RobotId| Some((Target::Robot(r), [r, crate::world::event::NO_ROBOT]));
        assert_eq!(large.ahead().next, route(1));
        assert_eq!(large.ahead().after, route(2));
    }

    /// The robot an event stands for here: its timer's, 99 for the end of an instant, 100
    /// for a listing's notice.
    fn robot_of(p: &Payload) -> RobotId {
        match p {
            Payload::Timer { robot, .. } => *robot,
            Payload::Notice(_) => 100,
            Payload::Settle => 99,
            other => panic!("unexpected {other:?}"),
        }
    }

    /// Sets robot `r`'s timer now.
    fn wake(out: &mut Outbox, r: RobotId) {
        out.schedule(
            out.now(),
            Target::Robot(r),
            EventClass::Eventual,
            [None, None],
            timer(r),
        );
    }

    /// An instant's end event comes after every other event of its instant, those caused after
    /// it was scheduled included, and before the next instant; its own events at the instant
    /// follow it. A listing of events taken while one is pending waits for it.
    #[test]
    fn an_instants_end_event_comes_after_the_instant_and_before_the_next() {
        let order = run_timers(&[(1.0, 1), (1.0, 2), (2.0, 3)], |r, out| match r {
            // Robot 1 asks for the end of the instant, then causes robot 4's timer now and a
            // listing now.
            1 => {
                out.at_instant_end(Target::MotionManager, [None, None], Payload::Settle);
                wake(out, 4);
                out.schedule(
                    out.now(),
                    Target::EventManager,
                    EventClass::Eventual,
                    [Some(1), None],
                    Payload::ListEvents {
                        robot: 1,
                        of: 1,
                        ticket: 0,
                    },
                );
            }
            // Robot 4 causes robot 5's timer now.
            4 => wake(out, 5),
            // The end of the instant causes robot 6's timer now.
            99 => wake(out, 6),
            _ => {}
        });
        // 100: the listing's notice, sent after the end of the instant.
        assert_eq!(
            order,
            [
                (1.0, 1),
                (1.0, 2),
                (1.0, 4),
                (1.0, 5),
                (1.0, 99),
                (1.0, 6),
                (1.0, 100),
                (2.0, 3)
            ]
        );
    }

    /// An instant's end event withdrawn before it is taken never comes; withdrawing one that
    /// was taken changes nothing.
    #[test]
    fn an_instants_end_event_withdrawn_never_comes() {
        let mut pending = None;
        let order = run_timers(
            &[(1.0, 1), (1.0, 2), (2.0, 3), (2.0, 4)],
            |r, out| match r {
                // Robots 1 and 3 ask for the end of their instant; robot 2 withdraws it at
                // instant 1; at instant 2 the end comes and causes robot 5's timer, which
                // withdraws it after it was taken.
                1 | 3 => {
                    pending = Some(out.at_instant_end(
                        Target::MotionManager,
                        [None, None],
                        Payload::Settle,
                    ));
                }
                2 | 5 => out.withdraw_at_instant_end(pending.expect("asked for")),
                99 => wake(out, 5),
                _ => {}
            },
        );
        assert_eq!(
            order,
            [(1.0, 1), (1.0, 2), (2.0, 3), (2.0, 4), (2.0, 99), (2.0, 5)]
        );
    }

    /// A handler for every actor of a test run, whose handlings make pseudo-random effects
    /// from the run's seed and the event's number: timers for a few robots, now or later,
    /// some cancellable and some of those cancelled later, an instant's end event now and
    /// then, withdrawn now and then. One state for all targets, as the managers share the
    /// world, so that a handling's effects depend on every handling before it.
    struct Scrambler {
        seed: u64,
        robots: RobotId,
        claims: crate::world::queue::Claims,
        handles: Vec<crate::world::event::Handle>,
        closing: Option<EventId>,
        /// `(time, number, robot)` of each handling, in order.
        log: Vec<(f64, u64, RobotId)>,
    }

    impl Scrambler {
        fn new(seed: u64, robots: RobotId) -> Self {
            Self {
                seed,
                robots,
                claims: Default::default(),
                handles: Vec::new(),
                closing: None,
                log: Vec::new(),
            }
        }
    }

    impl HandleEvent for Scrambler {
        fn handle_event(&mut self, event: Event, out: &mut Outbox) {
            let robot = match event.payload {
                Payload::Timer { robot, .. } => robot,
                _ => 99,
            };
            self.log.push((out.now(), out.cause(), robot));
            // SplitMix64 of the seed, the number and what was handled so far.
            let mut x =
                self.seed ^ out.cause().wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ self.log.len() as u64;
            let mut draw = move |n: u64| {
                x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
                let mut z = x;
                z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
                (z ^ (z >> 31)) % n
            };
            let now = out.now();
            for _ in 0..draw(3) {
                let r = draw(u64::from(self.robots)) as RobotId;
                let at = now + [0.0, 0.0, 0.25, 0.5, 1.0][draw(5) as usize];
                let robots = [Some(r), None];
                let payload = Payload::Timer {
                    robot: r,
                    ticket: 0,
                };
                let target = Target::Robot(r);
                if draw(2) == 0 {
                    out.schedule(at, target, EventClass::Eventual, robots, payload);
                } else {
                    let h = out.schedule_in(
                        &mut self.claims,
                        at,
                        target,
                        EventClass::Eventual,
                        robots,
                        payload,
                    );
                    self.handles.push(h);
                }
            }
            if !self.handles.is_empty() && draw(3) == 0 {
                let h = self
                    .handles
                    .swap_remove(draw(self.handles.len() as u64) as usize);
                out.cancel(h);
                self.claims.release(h);
            }
            match draw(12) {
                0 if self.closing.is_none() => {
                    let id = out.at_instant_end(Target::Robot(99), [None, None], Payload::Settle);
                    self.closing = Some(id);
                }
                1 => {
                    if let Some(id) = self.closing.take() {
                        out.withdraw_at_instant_end(id);
                    }
                }
                _ => {}
            }
            if robot == 99 {
                self.closing = None;
            }
        }
    }

    /// Runs a core over a [`Scrambler`], deliveries carrying runs or not; returns the
    /// handlings, the events taken, those cancelled, and how many deliveries there were.
    fn scrambled(
        seed: u64,
        robots: RobotId,
        runs: bool,
    ) -> (Vec<(f64, u64, RobotId)>, u64, u64, u64) {
        let mut setup = Outbox::new(0.0, 0);
        for r in 0..robots {
            setup.schedule(
                0.1 * f64::from(r),
                Target::Robot(r),
                EventClass::Eventual,
                [Some(r), None],
                timer(r),
            );
        }
        let mut core = Core::new(6.0, setup, Observers::default());
        core.set_instant_limit(10_000);
        core.runs = runs;
        let mut actor = Scrambler::new(seed, robots);
        let mut deliveries = 0;
        while let Next::Deliver(_, d) = core.next() {
            deliveries += 1;
            let reply = handle_run(&mut actor, d);
            core.apply_reply(reply);
        }
        let out = core.finish();
        (actor.log, out.stats.events, out.stats.cancelled, deliveries)
    }

    proptest::proptest! {
        /// Deliveries that carry runs take the same events in the same order, with the same
        /// numbers, as deliveries of one event each, whatever the handlings schedule, cancel
        /// or leave to the end of an instant; and they need fewer deliveries.
        #[test]
        fn runs_take_the_events_of_one_by_one_delivery(seed in proptest::prelude::any::<u64>(), robots in 1u32..4) {
            let (one, events, cancelled, singles) = scrambled(seed, robots, false);
            let (run, run_events, run_cancelled, deliveries) = scrambled(seed, robots, true);
            proptest::prop_assert_eq!(&run, &one);
            proptest::prop_assert_eq!((run_events, run_cancelled), (events, cancelled));
            proptest::prop_assert_eq!(singles, events);
            proptest::prop_assert!(deliveries <= singles);
        }
    }

    /// A run stops at the first of its events that the handlings before it cancelled, or that
    /// something they scheduled comes before; the rest go back to the queue and are taken
    /// after.
    #[test]
    fn a_run_stops_where_its_next_event_is_no_longer_next() {
        // Robot 1's timers at 1, 2, 3, 4 and 5 s; robot 2's at 6 s. The handling at 1 s
        // cancels the one at 4 s; the one at 2 s sets robot 2's timer for 2.5 s.
        let mut setup = Outbox::new(0.0, 0);
        let mut claims = crate::world::queue::Claims::default();
        let mut handles = Vec::new();
        for t in [1.0, 2.0, 3.0, 4.0, 5.0] {
            handles.push(setup.schedule_in(
                &mut claims,
                t,
                Target::Robot(1),
                EventClass::Eventual,
                [Some(1), None],
                timer(1),
            ));
        }
        setup.schedule(
            6.0,
            Target::Robot(2),
            EventClass::Eventual,
            [Some(2), None],
            timer(2),
        );
        struct Actor(Vec<(f64, u64)>, crate::world::event::Handle);
        impl HandleEvent for Actor {
            fn handle_event(&mut self, _: Event, out: &mut Outbox) {
                self.0.push((out.now(), out.cause()));
                if out.now() == 1.0 {
                    out.cancel(self.1);
                }
                if out.now() == 2.0 {
                    out.schedule(
                        2.5,
                        Target::Robot(2),
                        EventClass::Eventual,
                        [Some(2), None],
                        timer(2),
                    );
                }
            }
        }
        let mut core = Core::new(10.0, setup, Observers::default());
        core.runs = true;
        let mut actor = Actor(Vec::new(), handles[3]);
        let mut handled = Vec::new();
        while let Next::Deliver(_, d) = core.next() {
            let then: Vec<f64> = d.then.iter().map(|e| e.time).collect();
            let want: &[f64] = match d.now {
                1.0 => &[2.0, 3.0, 4.0, 5.0],
                3.0 => &[5.0],
                _ => &[],
            };
            assert_eq!(then, want, "the run from {}", d.now);
            let reply = handle_run(&mut actor, d);
            handled.push(reply.ends.len());
            core.apply_reply(reply);
        }
        // The run from 1 s handles 1 and 2 s and stops at 3 s, which robot 2's timer at 2.5
        // s now comes before; 3, 4 and 5 s go back. The run from 3 s no longer holds 4 s,
        // which was cancelled.
        assert_eq!(handled, [2, 1, 2, 1]);
        assert_eq!(
            actor.0,
            [(1.0, 1), (2.0, 2), (2.5, 3), (3.0, 4), (5.0, 5), (6.0, 6)]
        );
        assert_eq!(core.finish().stats.cancelled, 1);
    }

    /// A delivery that says the scheduler looks ahead has its actor asked, before each
    /// handling of its run, for what the run's next two events will read; one that does not,
    /// never. What is handled is the same either way.
    #[test]
    fn a_run_asks_ahead_for_its_next_two_events_when_told_to() {
        /// An ask: the last time handled before it, the next event's and the one after's.
        type Ask = (f64, Option<f64>, Option<f64>);
        #[derive(Default)]
        struct Actor {
            handled: Vec<f64>,
            asked: std::cell::RefCell<Vec<Ask>>,
        }
        impl HandleEvent for Actor {
            fn handle_event(&mut self, _: Event, out: &mut Outbox) {
                self.handled.push(out.now());
            }
            fn look_ahead(&self, next: Option<&Event>, after: Option<&Event>) {
                let last = self.handled.last().copied().unwrap_or(0.0);
                let time = |e: Option<&Event>| e.map(|e| e.time);
                self.asked
                    .borrow_mut()
                    .push((last, time(next), time(after)));
            }
        }
        let run = |look_ahead: bool| {
            let mut setup = Outbox::new(0.0, 0);
            for t in [1.0, 2.0, 3.0, 4.0] {
                setup.schedule(
                    t,
                    Target::Robot(1),
                    EventClass::Eventual,
                    [Some(1), None],
                    timer(1),
                );
            }
            let mut core = Core::new(10.0, setup, Observers::default());
            core.runs = true;
            let Next::Deliver(_, mut d) = core.next() else {
                panic!("a delivery");
            };
            assert_eq!(d.then.len(), 3, "the run of 1 s holds 2, 3 and 4 s");
            d.look_ahead = look_ahead;
            let mut actor = Actor::default();
            let reply = handle_run(&mut actor, d);
            assert_eq!(reply.ends.len(), 4);
            (actor.handled, actor.asked.into_inner())
        };
        let (handled, asked) = run(true);
        assert_eq!(handled, [1.0, 2.0, 3.0, 4.0]);
        // (the last time handled before the ask, next, after)
        assert_eq!(
            asked,
            [
                (0.0, Some(2.0), Some(3.0)),
                (1.0, Some(3.0), Some(4.0)),
                (2.0, Some(4.0), None)
            ]
        );
        let (handled, asked) = run(false);
        assert_eq!(handled, [1.0, 2.0, 3.0, 4.0]);
        assert!(asked.is_empty());
    }

    /// In a queue large enough for the look-ahead, where a reply's cancellations are asked
    /// for before they are applied, cancelled events still never fire and are counted.
    #[test]
    fn cancellations_asked_for_ahead_still_cancel() {
        let n = LOOK_AHEAD_FROM + 10;
        let mut setup = Outbox::new(0.0, 0);
        let mut claims = crate::world::queue::Claims::default();
        let handles: Vec<_> = (0..n)
            .map(|k| {
                let r = k as RobotId;
                setup.schedule_in(
                    &mut claims,
                    1.0 + k as f64,
                    Target::Robot(r),
                    EventClass::Eventual,
                    [Some(r), None],
                    timer(r),
                )
            })
            .collect();
        // The first handling cancels the events of robots 5, 7, ..., 13.
        let cancelled: Vec<RobotId> = (5..15).step_by(2).collect();
        let mut core = Core::new(1e9, setup, Observers::default());
        let mut fired = Vec::new();
        while let Next::Deliver(_, d) = core.next() {
            let r = robot_of(&d.event.payload);
            fired.push(r);
            let mut out = Outbox::reusing(d.now, d.seq, d.effects);
            if r == 0 {
                for &c in &cancelled {
                    out.cancel(handles[c as usize]);
                }
            }
            core.apply(out.into_effects());
        }
        assert_eq!(fired.len(), n - cancelled.len());
        assert!(fired.iter().all(|r| !cancelled.contains(r)));
        assert_eq!(core.finish().stats.cancelled, cancelled.len() as u64);
    }
}
