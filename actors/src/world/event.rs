//! Events: what happens at an instant of virtual time (seed 3.6 and 4.3).
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

use super::motion::Motion;
use super::observation::Observation;
use super::sensor::{SensorKind, SensorQuery, SensorValue};
use super::{MotionOutcome, Obstacle, RobotId};
use crate::world::motion::Kinematics;
use nekosim_protocols::{Indication, Input, LayerIx};

/// Identity and tie-break key of an event: `(cause, index)`, see the module doc. Packed to 12
/// bytes (an event carries one, and a large run holds millions of events).
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
/// holds millions of them.
#[derive(Clone, Debug)]
pub enum Payload {
    /// Robot -> motion manager: start `motion`, replacing the current one, first writing
    /// `note`, the robot's own record of it, when the robot asked ahead of time
    /// ([`crate::robot::Robot::start_motion_at`]).
    MotionRequest {
        robot: RobotId,
        ticket: u64,
        motion: Box<Motion>,
        note: Option<Box<Observation>>,
    },
    /// The `step`-th to `through`-th events of the robot's current motion, all at this
    /// instant: steps of a motion that happen at the same instant are one event (a MOVETO's
    /// finish-turn and start-forward), and a listing shows each of them.
    MotionStep {
        robot: RobotId,
        step: usize,
        through: usize,
    },
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
    /// Robot -> sensor manager: the light the robot shows from now on ([`crate::lcm`]).
    Light {
        robot: RobotId,
        light: crate::lcm::LightState,
    },
    /// The end of an instant at which robots stopped ([`Outbox::at_instant_end`]): the motion
    /// manager predicts for those still at rest.
    Settle,
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
    /// How many of the seed's events this one stands for: one, or each step of a motion
    /// step event (the steps of a motion at one instant are one event).
    pub fn stands_for(&self) -> usize {
        match self {
            Payload::MotionStep { step, through, .. } => through - step + 1,
            _ => 1,
        }
    }

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
            Payload::Light { .. } => "light",
            Payload::Settle => "settle",
        }
    }
}

/// A scheduled event: 80 bytes (a million robots keep about seven million pending).
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
    /// Schedules a cancellable event in the queue slot its handle names ([`Outbox::schedule_in`]).
    ScheduleIn(Event, u32),
    Cancel(Handle),
    Record(Observation),
    /// An event at the end of the current instant ([`Outbox::at_instant_end`]).
    AtInstantEnd(Event),
    /// Withdraws an event at the end of the current instant that has not been taken yet
    /// ([`Outbox::withdraw_at_instant_end`]).
    WithdrawAtInstantEnd(EventId),
}

/// A cancellable event's handle: its id and the queue slot it is kept in, which whoever keeps
/// the handle chose from its [`Claims`] (the world, for its conditional events). Cancelling
/// through it looks nothing up: the slot is checked for the id (a table from ids to slots
/// would be a cache miss per scheduled event at a million robots).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C, packed(4))]
pub struct Handle {
    pub id: EventId,
    pub slot: u32,
}

impl From<Handle> for EventId {
    fn from(h: Handle) -> Self {
        h.id
    }
}
