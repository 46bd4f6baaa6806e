//! The scheduler's state apart from the actor machinery (the event manager of seed 4.2.3):
//! the event queue, the virtual clock, the crashed robots, the run's output and who watches
//! it. The scheduler actor hosts it; the kernel-alone reference ([`crate::kernel`]) drives the
//! same core from a plain loop, so both take the same events in the same order.

use std::collections::VecDeque;

use std::sync::Arc;

use crate::host::{Deliver, PassOn, Reply, CHAIN};
use crate::world::event::{Effect, Event, FutureEvent, Notice, Payload, Target};
use crate::world::observation::{Observation, Record};
use crate::world::outbox::Outbox;
use crate::world::queue::{Ahead, EventQueue, Route};
use crate::world::RobotId;

/// What the next two pending events read in the world ([`Core::ahead_in_world`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WorldAhead {
    /// The robots of the next event, when its handling reads the world,
    pub next: Option<[RobotId; 2]>,
    /// and those of the event after it, likewise.
    pub after: Option<[RobotId; 2]>,
}

impl WorldAhead {
    /// Asks `world` for all of it ([`VirtualWorld::prefetch`](crate::world::virtual_world::VirtualWorld::prefetch)).
    pub fn prefetch(&self, world: &crate::world::virtual_world::VirtualWorld) {
        world.prefetch(self.next, self.after);
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
    /// One robot's events outnumbered all other robots' at the instant `t` by `lead`: the
    /// robot's algorithm keeps acting without letting time pass.
    #[error("livelock at t={t}: robot {robot} acted {lead} times more than all other robots together without virtual time advancing (its algorithm keeps retrying at the same instant, e.g. a motion blocked by a collision or a move of length 0, without waiting)")]
    RobotLivelock { t: f64, robot: RobotId, lead: u64 },
    /// An actor did not answer an event (an internal error).
    #[error("{target} did not answer: {error}")]
    NoAnswer { target: String, error: String },
}

/// The scheduler's state apart from the actor machinery: the event queue, the virtual clock,
/// the crashed robots and the run's output. The scheduler actor hosts it; the kernel-alone
/// reference ([`crate::kernel`]) drives the same core without actors, so both take the same
/// events in the same order.
pub(crate) struct Core {
    pub(crate) queue: EventQueue,
    pub(crate) now: f64,
    pub(crate) seq: u64,
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
    /// The robot whose deliveries lead at the current instant and by how many (a majority
    /// vote over the robots' deliveries: a robot that acts again and again at one instant
    /// leads by a growing count, however many robots the run has), and the lead at which the
    /// run is declared a livelock.
    leader: (RobotId, u64),
    lead_limit: u64,
    /// The effects buffer that the next delivery carries (see [`Deliver::effects`]).
    spare: Vec<Effect>,
    /// The routes of the next two pending events, seen when the last was taken
    /// ([`EventQueue::look_ahead`]).
    ahead: Ahead,
    /// Events for the end of the current instant ([`Outbox::at_instant_end`]), in the order
    /// they were scheduled.
    closing: VecDeque<Event>,
    /// Whether deliveries may take on events at once ([`Deliver::inline`]): the scheduler
    /// actor's may, the kernel-alone reference's not (it has no hop to save).
    pub(crate) chains: bool,
    /// Whether anything reads the robots' step records ([`Observers::summary_only`]).
    steps: bool,
    /// Where the hosts may pass deliveries on ([`Deliver::pass_on`]): the scheduler actor's
    /// actors.
    pub(crate) pass_on: Option<Arc<dyn PassOn>>,
}

/// The fewest pending events at which the core looks ahead ([`EventQueue::look_ahead`]) and
/// the scheduler asks for what the next handlings will read. A world that small (about 2.75
/// pending events a robot in random movement: some 6,000 robots) is in cache anyway, and the
/// look-ahead is then only work, while a world of 100,000 robots runs faster with it
/// (docs/performance.md lists the gain).
pub(crate) const LOOK_AHEAD_FROM: usize = 1 << 14;

/// The lead by which one robot's deliveries at one instant may outnumber all other robots'
/// before the run is declared a livelock ([`RunFailure::RobotLivelock`]). A robot retrying
/// at one instant gains one a retry, so a million retries, a few seconds of a release
/// build's work whatever the number of robots, end the run; a robot that legitimately acts
/// often at one instant (hearing from many others) is outnumbered by the others' own events.
pub const LEAD_LIMIT: u64 = 1_000_000;

/// The largest effects buffer kept for reuse: the setup's million start notices are not.
const SPARE_EFFECTS: usize = 1 << 10;

/// What the core says to do next. Made once an event and taken apart at once, so the
/// delivery is not boxed.
#[allow(clippy::large_enum_variant)]
pub(crate) enum Next {
    /// Hand this event to the actor behind `Target` and apply its reply.
    Deliver(Target, Deliver),
    /// The run is over: `until` passed, no event left, a stop, a livelock.
    Finish,
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
    /// The sink reads only what a run's summary counts, none of the robots' step records
    /// ([`Observation::is_step`]): the handlers then leave those out instead of making
    /// records that nothing reads.
    pub summary_only: bool,
}

impl Observers {
    /// Whether anything reads the robots' step records ([`Observation::is_step`]): kept
    /// records, or a sink that reads more than the summary.
    pub fn read_steps(&self) -> bool {
        self.keep || (self.sink.is_some() && !self.summary_only)
    }
}

impl std::fmt::Debug for Observers {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Observers")
            .field("keep", &self.keep)
            .field("sink", &self.sink.is_some())
            .field("progress", &self.progress.is_some())
            .field("startup", &self.startup.is_some())
            .field("stop", &self.stop)
            .field("summary_only", &self.summary_only)
            .finish()
    }
}

/// How many events pass between two progress calls.
pub const PROGRESS_EVERY: u64 = 4096;

/// How many of the setup's effects go in between two looks at the stop flag.
const STOP_EVERY: usize = 1024;

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
            leader: (0, 0),
            lead_limit: LEAD_LIMIT,
            spare: Vec::new(),
            ahead: Ahead::default(),
            closing: VecDeque::new(),
            chains: false,
            steps: false,
            pass_on: None,
        };
        core.steps = core.observers.read_steps();
        core.apply_setup(setup.into_effects());
        core
    }

    /// Applies the setup's effects in order, as [`Core::apply`] does, unless the run is
    /// stopped from outside meanwhile: a million robots' setup records take a while to write,
    /// and the user's Ctrl-C then cuts them where it comes. The records so far are the first
    /// records of the whole run, and the run ends before its first event.
    fn apply_setup(&mut self, mut effects: Vec<Effect>) {
        self.prefetch_cancelled(&effects);
        for (i, e) in effects.drain(..).enumerate() {
            if i % STOP_EVERY == 0 && self.stopped() {
                self.output.stats.interrupted = true;
                break;
            }
            self.apply_one(e);
        }
        self.keep_spare(effects);
    }

    /// Applies the effects of one handling, in order.
    pub(crate) fn apply(&mut self, mut effects: Vec<Effect>) {
        self.prefetch_cancelled(&effects);
        for e in effects.drain(..) {
            self.apply_one(e);
        }
        self.keep_spare(effects);
    }

    /// Applies a delivery's reply ([`Reply`]): each handled event is taken in turn (as
    /// [`Core::next`] would have taken it: its time, its number, the count) and its effects
    /// applied. Since each event taken on at once was the next one after the effects before
    /// it, this is the order of delivering them one by one.
    pub(crate) fn apply_reply(&mut self, reply: Reply) {
        let Reply {
            mut effects,
            ends,
            robots,
        } = reply;
        self.prefetch_cancelled(&effects);
        let handled = ends.len() - 1;
        // The events taken on at once are at the instant of the delivered one.
        let now = self.now;
        let mut j = 0;
        for (k, e) in effects.drain(..).enumerate() {
            while k as u32 >= ends[j] {
                j += 1;
                self.enter(now);
            }
            self.apply_one(e);
        }
        while j < handled {
            j += 1;
            self.enter(now);
        }
        // The robots' events taken on count in the vote as if delivered one by one; the room
        // given ([`Core::inline_room`]) keeps the lead below the limit.
        for r in robots {
            let livelock = self.leads(r);
            debug_assert!(!livelock, "a chain stays below the lead limit");
        }
        self.keep_spare(effects);
    }

    /// In a large queue (as [`EventQueue::look_ahead`]), asks for the slots of the events that
    /// `effects` cancel, all at once before the first is read: at a million robots each is a
    /// cache miss of its own.
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
            self.leader = (0, 0);
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

    /// How many events an actor may take on at once after the one being delivered
    /// ([`Deliver::inline`]), and where it may pass those for other actors on
    /// ([`Deliver::pass_on`]): the events the handlings schedule at the instant, which come
    /// next when nothing else is pending at that instant (their causes are the newest), so
    /// long as the instant's event limit allows them and no instant's end event is pending. A
    /// manager may take on its own events in any case. Robots, their sensors and layers, and
    /// events passed on, need more, as the scheduler watches robots for crashes and
    /// livelocks: no robot crashed, and a lead in the robots' vote that the chain cannot bring
    /// to the limit.
    fn inline_room(&mut self, target: Target) -> (u32, Option<Arc<dyn PassOn>>) {
        let manager = matches!(
            target,
            Target::MotionManager | Target::SensorManager | Target::Network
        );
        let passing =
            self.crashed.is_empty() && self.leader.1 + 2 * (CHAIN as u64) < self.lead_limit;
        if !(manager || passing)
            || !self.chains
            || !self.closing.is_empty()
            || self.stopped()
            || self.queue.peek_time().is_some_and(|p| p <= self.now)
        {
            return (0, None);
        }
        let left = self.instant_limit.saturating_sub(self.at_instant);
        let room = u32::try_from(left.min(CHAIN as u64 - 1)).expect("below CHAIN");
        let pass_on = self.pass_on.clone().filter(|_| passing && room > 0);
        if pass_on.is_none() && !manager {
            return (0, None);
        }
        (room, pass_on)
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
                if !self.steps && obs.is_step() {
                    return;
                }
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
            if let Target::Robot(r) = target {
                if self.leads(r) {
                    self.output.failure = Some(RunFailure::RobotLivelock {
                        t: self.now,
                        robot: r,
                        lead: self.leader.1,
                    });
                    return Next::Finish;
                }
            }
            if target == Target::EventManager {
                self.handle_inline(event);
                continue;
            }
            self.ahead = if self.queue.len() >= LOOK_AHEAD_FROM {
                self.queue.look_ahead()
            } else {
                Ahead::default()
            };
            let (inline, pass_on) = self.inline_room(target);
            let deliver = Deliver {
                now: self.now,
                seq: self.seq,
                event,
                effects: std::mem::take(&mut self.spare),
                reply: None,
                inline,
                steps: self.steps,
                pass_on,
                chain: None,
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
        (next.is_some() || after.is_some()).then_some(WorldAhead { next, after })
    }

    /// Counts a delivery to robot `r` at the current instant in the vote for the robot that
    /// acts most (Boyer and Moore's majority vote: constant work and memory per event);
    /// whether the leading robot's lead reached the limit.
    #[inline]
    fn leads(&mut self, r: RobotId) -> bool {
        let (leader, lead) = &mut self.leader;
        if *leader == r {
            *lead += 1;
        } else if *lead == 0 {
            (*leader, *lead) = (r, 1);
        } else {
            *lead -= 1;
        }
        *lead >= self.lead_limit
    }

    /// Fails the run when one robot's deliveries at one instant outnumber all other robots'
    /// by `lead` ([`LEAD_LIMIT`] by default).
    #[cfg(test)]
    pub(crate) fn set_lead_limit(&mut self, lead: u64) {
        self.lead_limit = lead;
    }

    /// Fails the run when more than `limit` events happen at one instant of virtual time.
    pub(crate) fn set_instant_limit(&mut self, limit: u64) {
        self.instant_limit = limit;
    }
}

#[cfg(test)]
mod tests;
