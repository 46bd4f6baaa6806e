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
//!    handling produced (events to schedule, events to cancel, observations to record): a
//!    call from a host on the scheduler's thread ([`Here`]), a message from any other. Only
//!    then does it take the next event. A delivery may carry a run: the events that come
//!    next for the same actor ([`Deliver::then`]). The actor handles each in turn only while
//!    the handlings before it leave it the next event ([`handle_run`]) and hands the rest
//!    back, so the events taken and their order are those of one delivery per event. Every
//!    hop is an event. When the event a handling schedules at its instant is the next event
//!    there is, the actor's host may pass it straight on to its actor ([`PassOn`]), which
//!    replies for both: that is the delivery the scheduler would send next, numbered as it
//!    would number it, so again the events and their order are those of one delivery per
//!    event. The scheduler allows it only where it would deliver the event itself: nothing
//!    else pending at the instant, no robot crashed, no livelock in reach.
//! 4. Quiescence is therefore structural: an actor's work at instant `t` is exactly the handling
//!    of events at `t`, and everything it causes is an event at `t` or later. Virtual time
//!    cannot advance while work at the current instant remains, because that work is an event
//!    at the current instant and sorts first. A robot's algorithm runs inside its actor's
//!    handler until it blocks on a motion, sensor, timer or notice, so every request it makes
//!    is in the reply before the scheduler moves on.
//! 5. Because of 2 and 3, the order does not depend on which arbiter (thread) hosts an actor
//!    or on mailbox timing; a run spread over several arbiters gives the same events in the
//!    same order as a run on one.

mod event_manager;

use actix::prelude::*;

use std::cell::RefCell;
use std::rc::Rc;
use std::sync::{Arc, Mutex};

use crate::host::{Deliver, Here, NoReply, PassOn, Replied, Reply, ReplyTo, TakesReplies};
use crate::world::event::{Event, Target};
use crate::world::outbox::Outbox;
use crate::world::sensor::SensorKind;
use crate::world::RobotId;

pub(crate) use event_manager::{Core, Next};
pub use event_manager::{
    Observers, RunFailure, RunOutput, RunStats, Sink, WorldAhead, PROGRESS_EVERY, STARTUP_EVERY,
};

/// Who handles which events.
pub struct Routes {
    pub motion_manager: Recipient<Deliver>,
    pub sensor_manager: Recipient<Deliver>,
    pub robots: Vec<Recipient<Deliver>>,
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

impl std::fmt::Debug for Routes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Routes")
            .field("robots", &self.robots.len())
            .finish()
    }
}

/// Every actor's mailbox: the scheduler's, and the hosts' that pass deliveries on
/// ([`PassOn`]).
struct Directory {
    motion_manager: Recipient<Deliver>,
    sensor_manager: Recipient<Deliver>,
    robots: Vec<Recipient<Deliver>>,
    network: Recipient<Deliver>,
    layers: Vec<Vec<Recipient<Deliver>>>,
    /// Each robot's sensor actors started so far, by robot: a robot has a few sensors at
    /// most, and a robot's list is found without hashing. The scheduler starts them.
    sensors: Mutex<Vec<Started>>,
}

/// A robot's sensor actors started so far.
type Started = Vec<(SensorKind, Recipient<Deliver>)>;

impl Directory {
    /// Calls `f` with `target`'s mailbox, if its actor is running.
    fn with<R>(&self, target: Target, f: impl FnOnce(Option<&Recipient<Deliver>>) -> R) -> R {
        match target {
            Target::EventManager => f(None),
            Target::Robot(r) => f(self.robots.get(r as usize)),
            Target::MotionManager => f(Some(&self.motion_manager)),
            Target::SensorManager => f(Some(&self.sensor_manager)),
            Target::Network => f(Some(&self.network)),
            Target::Layer(r, l) => f(self
                .layers
                .get(r as usize)
                .and_then(|ls| ls.get(l as usize))),
            Target::Sensor(r, k) => {
                let sensors = self.sensors.lock().expect("sensor directory");
                let started = sensors.get(r as usize).map_or(&[][..], Vec::as_slice);
                f(started.iter().find(|(kind, _)| *kind == k).map(|s| &s.1))
            }
        }
    }
}

impl PassOn for Directory {
    fn reaches(&self, target: Target) -> bool {
        self.with(target, |to| to.is_some())
    }

    fn pass(&self, target: Target, msg: Deliver) {
        // A closed mailbox drops the delivery, whose `ReplyTo` then says so.
        self.with(target, |to| to.expect("a running actor").do_send(msg));
    }
}

/// The scheduler actor. Its state is shared, on its own thread, with the hosts there: they
/// hand it their replies by a call instead of a message ([`Here`]).
pub struct Scheduler {
    /// Borrowed by whoever steps it: the scheduler actor, or a host on its thread with a reply
    /// ([`TakesReplies`]). One delivery is in flight at a time, so the two never overlap.
    state: Rc<RefCell<State>>,
}

struct State {
    core: Core,
    actors: Arc<Directory>,
    /// Starts a robot's sensor actor ([`Routes::spawn_sensor`]).
    spawn_sensor: Box<dyn Fn(RobotId, SensorKind) -> Recipient<Deliver>>,
    prefetch: Prefetch,
    /// Where the replies go ([`ReplyTo`]): the scheduler, once started.
    me: Option<Arc<Recipient<Replied>>>,
    /// The scheduler's number, which its deliveries' [`ReplyTo`]s carry.
    id: u64,
    /// While the run goes on: replies made on this thread reach the scheduler by a call.
    here: Option<Here>,
    /// Whether a delivery is in flight.
    in_flight: bool,
    on_finish: Option<Box<dyn FnOnce(RunOutput)>>,
}

impl std::fmt::Debug for Scheduler {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let state = self.state.borrow();
        f.debug_struct("Scheduler")
            .field("now", &state.core.now)
            .field("seq", &state.core.seq)
            .field("pending", &state.core.queue.len())
            .finish()
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
        let Routes {
            motion_manager,
            sensor_manager,
            robots,
            network,
            layers,
            spawn_sensor,
            prefetch,
        } = routes;
        let actors = Arc::new(Directory {
            motion_manager,
            sensor_manager,
            robots,
            network,
            layers,
            sensors: Mutex::new(Vec::new()),
        });
        let mut core = Core::new(until, setup, observers);
        core.runs = true;
        core.pass_on = Some(actors.clone() as Arc<dyn PassOn>);
        let state = State {
            core,
            actors,
            spawn_sensor,
            prefetch,
            me: None,
            id: Here::number(),
            here: None,
            in_flight: false,
            on_finish: Some(on_finish),
        };
        Self {
            state: Rc::new(RefCell::new(state)),
        }
    }

    /// Fails the run when more than `limit` events happen at one instant of virtual time (an
    /// algorithm retrying forever without letting time pass).
    pub fn with_instant_limit(self, limit: u64) -> Self {
        self.state.borrow_mut().core.set_instant_limit(limit);
        self
    }

    /// The pending events of a robot (the event manager's listing).
    pub fn future_of(&mut self, robot: RobotId) -> Vec<Event> {
        self.state.borrow_mut().core.queue.future_of(robot)
    }
}

impl State {
    /// Sends `deliver` to `target`'s actor, starting it first if it is a sensor not yet
    /// needed.
    fn send(&mut self, target: Target, deliver: Deliver) {
        if let Target::Sensor(r, k) = target {
            let mut sensors = self.actors.sensors.lock().expect("sensor directory");
            let i = r as usize;
            if sensors.len() <= i {
                sensors.resize_with(i + 1, Vec::new);
            }
            let started = &mut sensors[i];
            if !started.iter().any(|(kind, _)| *kind == k) {
                started.push((k, (self.spawn_sensor)(r, k)));
            }
        }
        // A closed mailbox drops the delivery, whose `ReplyTo` then says so.
        self.actors.pass(target, deliver);
    }

    /// Takes the next event and sends it to its actor, whose reply steps on.
    fn step(&mut self) {
        let (target, mut deliver) = match self.core.next() {
            Next::Finish => return self.finish(),
            Next::Deliver(target, deliver) => (target, deliver),
        };
        if let Some(world) = self.core.ahead_in_world() {
            (self.prefetch)(&world);
        }
        let me = self.me.clone().expect("the scheduler started");
        deliver.reply = Some(ReplyTo::new(me, target, self.id));
        self.in_flight = true;
        self.send(target, deliver);
    }

    /// Applies the reply to the delivery in flight, then steps on.
    fn replied(&mut self, reply: Result<Reply, NoReply>) {
        assert!(
            std::mem::take(&mut self.in_flight),
            "a reply to the delivery in flight"
        );
        match reply {
            Ok(reply) => {
                self.core.apply_reply(reply);
                self.step();
            }
            Err(e) => {
                self.core.no_answer(e.with, e.error);
                self.finish();
            }
        }
    }

    /// Hands the output over. The actor is not stopped: the run's host drops or leaves the
    /// whole system once it has the output (`simulation::run_then_exit`), so the million
    /// robots' addresses and the queue are not dropped here one by one.
    fn finish(&mut self) {
        self.here = None;
        let output = self.core.finish();
        if let Some(f) = self.on_finish.take() {
            f(output);
        }
    }
}

impl TakesReplies for RefCell<State> {
    fn replied(&self, reply: Result<Reply, NoReply>) {
        self.borrow_mut().replied(reply);
    }
}

impl Actor for Scheduler {
    type Context = Context<Self>;

    fn started(&mut self, ctx: &mut Self::Context) {
        let mut state = self.state.borrow_mut();
        state.me = Some(Arc::new(ctx.address().recipient()));
        state.here = Some(Here::new(state.id, self.state.clone()));
        state.step();
    }
}

impl Handler<Replied> for Scheduler {
    type Result = ();

    fn handle(&mut self, reply: Replied, _: &mut Context<Self>) {
        self.state.borrow_mut().replied(reply.0);
    }
}
