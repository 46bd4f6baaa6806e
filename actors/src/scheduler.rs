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
//!    handling produced (events to schedule, events to cancel, observations to record). To an
//!    actor on the scheduler's own thread the delivery is a call into its host ([`Call`]),
//!    which returns the reply; to one on another arbiter, a message answered by a message.
//!    Only then does it take the next event. Every hop is an event. When the event a handling
//!    schedules at its instant is the next event there is, the actor's host may take it on
//!    at once ([`Deliver::inline`]), or pass it straight on to its actor ([`PassOn`]), which
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

use std::sync::{Arc, Mutex};

use crate::host::{Call, Deliver, Handled, NoReply, PassOn, Replied, Reply, ReplyTo, Route};
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
    pub motion_manager: Route,
    pub sensor_manager: Route,
    pub robots: Vec<Route>,
    pub network: Route,
    /// Each robot's protocol layers, by stack index.
    pub layers: Vec<Vec<Route>>,
    /// Starts a robot's sensor actor on the robot's arbiter when it is first needed.
    pub spawn_sensor: Box<dyn Fn(RobotId, SensorKind) -> Route>,
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

/// Something for each actor of a run but the sensors, found by the actor's target.
struct PerActor<T> {
    motion_manager: T,
    sensor_manager: T,
    robots: Vec<T>,
    network: T,
    layers: Vec<Vec<T>>,
}

impl<T> PerActor<T> {
    /// `target`'s entry; none for the event manager, a sensor, or an actor the run has not.
    fn get(&self, target: Target) -> Option<&T> {
        match target {
            Target::EventManager | Target::Sensor(..) => None,
            Target::Robot(r) => self.robots.get(r as usize),
            Target::MotionManager => Some(&self.motion_manager),
            Target::SensorManager => Some(&self.sensor_manager),
            Target::Network => Some(&self.network),
            Target::Layer(r, l) => self
                .layers
                .get(r as usize)
                .and_then(|ls| ls.get(l as usize)),
        }
    }

    /// Each entry split in two by `f`.
    fn split<A, B>(self, f: impl Fn(T) -> (A, B)) -> (PerActor<A>, PerActor<B>) {
        let (motion_a, motion_b) = f(self.motion_manager);
        let (sensing_a, sensing_b) = f(self.sensor_manager);
        let (network_a, network_b) = f(self.network);
        let (robots_a, robots_b) = self.robots.into_iter().map(&f).unzip();
        let (layers_a, layers_b) = (self.layers.into_iter())
            .map(|ls| ls.into_iter().map(&f).unzip())
            .unzip();
        let a = PerActor {
            motion_manager: motion_a,
            sensor_manager: sensing_a,
            robots: robots_a,
            network: network_a,
            layers: layers_a,
        };
        let b = PerActor {
            motion_manager: motion_b,
            sensor_manager: sensing_b,
            robots: robots_b,
            network: network_b,
            layers: layers_b,
        };
        (a, b)
    }
}

/// A robot's sensors started so far, with each one's entry: a robot has a few sensors at
/// most, and a robot's list is found without hashing.
type Sensors<T> = Vec<Vec<(SensorKind, T)>>;

/// `sensors`' entry for robot `r`'s sensor `k`, if started.
fn sensor<T>(sensors: &Sensors<T>, r: RobotId, k: SensorKind) -> Option<&T> {
    let started = sensors.get(r as usize).map_or(&[][..], Vec::as_slice);
    started.iter().find(|(kind, _)| *kind == k).map(|s| &s.1)
}

/// Every actor's mailbox: the scheduler's, and the hosts' that pass deliveries on
/// ([`PassOn`]) from any thread.
struct Directory {
    mailboxes: PerActor<Recipient<Deliver>>,
    /// The scheduler starts the sensors.
    sensors: Mutex<Sensors<Recipient<Deliver>>>,
}

impl Directory {
    /// Calls `f` with `target`'s mailbox, if its actor is running.
    fn with<R>(&self, target: Target, f: impl FnOnce(Option<&Recipient<Deliver>>) -> R) -> R {
        match target {
            Target::Sensor(r, k) => f(sensor(&self.sensors.lock().expect("sensors"), r, k)),
            _ => f(self.mailboxes.get(target)),
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

/// The calls into the hosts on the scheduler's thread ([`Call`]), by actor.
struct Calls {
    hosts: PerActor<Option<Call>>,
    sensors: Sensors<Call>,
}

impl Calls {
    /// `target`'s host, if it runs on the scheduler's thread.
    fn get(&self, target: Target) -> Option<&Call> {
        match target {
            Target::Sensor(r, k) => sensor(&self.sensors, r, k),
            _ => self.hosts.get(target)?.as_ref(),
        }
    }
}

/// The scheduler actor.
pub struct Scheduler {
    core: Core,
    actors: Arc<Directory>,
    calls: Calls,
    /// Starts a robot's sensor actor ([`Routes::spawn_sensor`]).
    spawn_sensor: Box<dyn Fn(RobotId, SensorKind) -> Route>,
    prefetch: Prefetch,
    /// Where the replies to messages go ([`ReplyTo`]): the scheduler, once started.
    me: Option<Arc<Recipient<Replied>>>,
    /// Whether a delivery sent as a message awaits its reply.
    in_flight: bool,
    on_finish: Option<Box<dyn FnOnce(RunOutput)>>,
}

impl std::fmt::Debug for Scheduler {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scheduler")
            .field("now", &self.core.now)
            .field("seq", &self.core.seq)
            .field("pending", &self.core.queue.len())
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
        let routes = PerActor {
            motion_manager,
            sensor_manager,
            robots,
            network,
            layers,
        };
        let (mailboxes, hosts) = routes.split(|r| (r.mailbox, r.call));
        let actors = Arc::new(Directory {
            mailboxes,
            sensors: Mutex::new(Vec::new()),
        });
        let mut core = Core::new(until, setup, observers);
        core.chains = true;
        core.pass_on = Some(actors.clone() as Arc<dyn PassOn>);
        Self {
            core,
            actors,
            calls: Calls {
                hosts,
                sensors: Vec::new(),
            },
            spawn_sensor,
            prefetch,
            me: None,
            in_flight: false,
            on_finish: Some(on_finish),
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

    /// Starts robot `r`'s sensor `k` if it is not running yet.
    fn start_sensor(&mut self, r: RobotId, k: SensorKind) {
        let mut sensors = self.actors.sensors.lock().expect("sensors");
        if sensor(&sensors, r, k).is_some() {
            return;
        }
        let i = r as usize;
        if sensors.len() <= i {
            sensors.resize_with(i + 1, Vec::new);
        }
        let route = (self.spawn_sensor)(r, k);
        sensors[i].push((k, route.mailbox));
        if let Some(call) = route.call {
            let calls = &mut self.calls.sensors;
            if calls.len() <= i {
                calls.resize_with(i + 1, Vec::new);
            }
            calls[i].push((k, call));
        }
    }

    /// Takes the events in turn and hands each to its actor, until the run ends or a delivery
    /// goes out as a message (its reply then steps on).
    fn step(&mut self) {
        loop {
            let (target, deliver) = match self.core.next() {
                Next::Finish => return self.finish(),
                Next::Deliver(target, deliver) => (target, deliver),
            };
            if let Some(world) = self.core.ahead_in_world() {
                (self.prefetch)(&world);
            }
            match self.deliver(target, deliver) {
                Some(Ok(reply)) => self.core.apply_reply(reply),
                Some(Err(e)) => return self.failed(e),
                None => {
                    self.in_flight = true;
                    return;
                }
            }
        }
    }

    /// Hands `deliver` to `target`'s actor, and each delivery its host passes on
    /// ([`Handled::PassOn`]) to the next: by a call while the actor runs on this thread, and
    /// then the reply; else as a message, and then nothing (the reply comes as a message).
    fn deliver(
        &mut self,
        mut target: Target,
        mut deliver: Deliver,
    ) -> Option<Result<Reply, NoReply>> {
        loop {
            if let Target::Sensor(r, k) = target {
                self.start_sensor(r, k);
            }
            let Some(call) = self.calls.get(target) else {
                let me = self.me.clone().expect("the scheduler started");
                deliver.reply = Some(ReplyTo::new(me, target));
                // A closed mailbox drops the delivery, whose `ReplyTo` then says so.
                self.actors.pass(target, deliver);
                return None;
            };
            match call.deliver(deliver) {
                Ok(Handled::Reply(reply)) => return Some(Ok(reply)),
                Ok(Handled::PassOn(next, passed)) => (target, deliver) = (next, passed),
                Err(error) => {
                    return Some(Err(NoReply {
                        with: target,
                        error,
                    }))
                }
            }
        }
    }

    /// Applies the reply to the delivery sent as a message, then steps on.
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
            Err(e) => self.failed(e),
        }
    }

    /// Ends the run: `e`'s actor gave no answer.
    fn failed(&mut self, e: NoReply) {
        self.core.no_answer(e.with, e.error);
        self.finish();
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
}

impl Actor for Scheduler {
    type Context = Context<Self>;

    fn started(&mut self, ctx: &mut Self::Context) {
        self.me = Some(Arc::new(ctx.address().recipient()));
        self.step();
    }
}

impl Handler<Replied> for Scheduler {
    type Result = ();

    fn handle(&mut self, reply: Replied, _: &mut Context<Self>) {
        self.replied(reply.0);
    }
}
