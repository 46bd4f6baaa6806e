//! What a run shows: the observations the engine records, one per traced event, in
//! processing order. The scenario layer turns them into the Neko log and the JSONL trace.

use serde::Serialize;

use super::geometry::Point;
pub use super::log_text::{num, obstacle_text, point_text};
use super::motion::{Kinematics, Motion, Progress, StepKind};
use super::sensor::{Plan, SensorKind, SensorQuery, SensorValue};
use super::{MotionOutcome, Obstacle, RobotId};
use nekosim_protocols::{MsgId, Payload};

/// One observation with its instant and sequence number.
#[derive(Clone, Debug, PartialEq)]
pub struct Record {
    /// Simulated time [s].
    pub t: f64,
    /// Strictly increasing over a run.
    pub seq: u64,
    pub obs: Observation,
}

/// A traced event: one definition of what a run records. The JSON Lines trace is this enum
/// projected by serde (`kind` is the tag; docs/trace.md lists every field); the Neko log and
/// the Rerun recording read the same records.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Observation {
    /// A robot exists (one per robot at t = 0).
    Spawn {
        robot: RobotId,
        pos: Point,
        angle: f64,
        radius: f64,
    },
    /// A motion request was accepted.
    MotionRequest {
        robot: RobotId,
        /// The request's number among the robot's requests (the seed log's "Task ID").
        ticket: u64,
        /// The request itself: the trace shows its pattern's name as `motion` and each of its
        /// parameters as a field of its own ([`Motion::name`], [`Motion::params`]). Kept as
        /// the request itself and written out only when the record is serialized, so that
        /// recording a request allocates nothing.
        #[serde(flatten, serialize_with = "ser::motion")]
        motion: Motion,
    },
    /// A motion ended.
    MotionFinish {
        robot: RobotId,
        #[serde(flatten, serialize_with = "ser::pose")]
        state: Kinematics,
        #[serde(flatten)]
        outcome: MotionOutcome,
    },
    /// `robot` touched `other` at `pos`; `other_pos` is the other robot's centre or the contact
    /// point on the boundary.
    Collision {
        robot: RobotId,
        other: Obstacle,
        pos: Point,
        /// `robot`'s heading then [deg].
        angle: f64,
        other_pos: Point,
    },
    /// A sensor request (`sensor` and `value` in the trace); `plan` is what the query asks of
    /// its sensor (`None` for a deactivation or a query its sensor refuses).
    SensorRequest {
        robot: RobotId,
        #[serde(flatten)]
        query: SensorQuery,
        #[serde(skip)]
        plan: Option<Plan>,
    },
    /// The algorithm wrote a line to the log (seed 5.3's `logger.info(..)`).
    Log { robot: RobotId, text: String },
    /// The algorithm asked a protocol layer to `op` ("broadcast", "propose", "send") `msg`.
    Request {
        robot: RobotId,
        layer: String,
        op: String,
        #[serde(serialize_with = "ser::rendered")]
        msg: Payload,
    },
    /// A message handed to the network by `layer` ("app" for the algorithm).
    Send {
        robot: RobotId,
        to: Vec<RobotId>,
        layer: String,
        #[serde(flatten, serialize_with = "ser::msg_and_type")]
        msg: Payload,
        /// When each copy arrives, as the network decided at the send (aligned with `to`;
        /// `None`: lost). Empty where unknown (a model checker's path).
        #[serde(skip_serializing_if = "Vec::is_empty")]
        arrive: Vec<Option<f64>>,
    },
    /// A message arrived from the network at `layer` of `robot`.
    Receive {
        robot: RobotId,
        from: RobotId,
        layer: String,
        #[serde(flatten, serialize_with = "ser::msg_and_type")]
        msg: Payload,
    },
    /// A broadcast layer delivered message `id` to the algorithm.
    Deliver {
        robot: RobotId,
        layer: String,
        #[serde(flatten, serialize_with = "ser::msg_id")]
        id: MsgId,
        #[serde(rename = "content", serialize_with = "ser::rendered")]
        msg: Payload,
    },
    /// A consensus layer decided `value` for instance `k`.
    Decide {
        robot: RobotId,
        layer: String,
        #[serde(rename = "instance")]
        k: u64,
        #[serde(serialize_with = "ser::rendered")]
        value: Payload,
    },
    /// A failure detector (or Omega) told the algorithm something about `process`.
    Suspect {
        robot: RobotId,
        layer: String,
        process: RobotId,
    },
    Trust {
        robot: RobotId,
        layer: String,
        process: RobotId,
    },
    Leader {
        robot: RobotId,
        layer: String,
        process: RobotId,
    },
    /// The robot crashed: it stops moving, sensing and communicating.
    Crash {
        robot: RobotId,
        #[serde(flatten, serialize_with = "ser::pose")]
        state: Kinematics,
    },
    /// A robot's light changed ([`crate::lcm`]): the light others see, and the light it
    /// computes while it computes one (a Look then may see either, as the register allows).
    Light {
        robot: RobotId,
        light: crate::lcm::Light,
        #[serde(skip_serializing_if = "Option::is_none")]
        pending: Option<crate::lcm::Light>,
    },
    /// A sensor's reply; `interrupt` when a push sensor fired on its own.
    SensorReply {
        robot: RobotId,
        sensor: SensorKind,
        value: SensorValue,
        interrupt: bool,
    },
    /// A motion event; `state` is the exact kinematic state from this instant on. Its trace
    /// `kind` is the step's name (`start_turn`, ..., or a custom pattern's).
    #[serde(untagged)]
    MotionStep {
        #[serde(rename = "kind", serialize_with = "ser::step")]
        step: StepKind,
        robot: RobotId,
        #[serde(flatten)]
        state: Kinematics,
        #[serde(skip)]
        progress: Progress,
    },
    /// A Look-Compute-Move robot's cycle ([`crate::lcm::record`]).
    #[serde(untagged)]
    Lcm(crate::lcm::record::LcmRecord),
}

impl Observation {
    /// Whether this is a record of a robot's own steps (its motions and their steps, its
    /// sensor requests and replies, its light, its Look-Compute-Move phases, its algorithm's
    /// log lines), which only a run's outputs show (the log, the trace, a recording, an
    /// observer), as opposed to what a run's summary also counts (births, collisions,
    /// protocol requests, messages, decisions, suspicions, crashes). A run whose records
    /// only its summary reads leaves the step records out ([`Observers::summary_only`]).
    ///
    /// [`Observers::summary_only`]: crate::scheduler::Observers::summary_only
    pub fn is_step(&self) -> bool {
        use Observation::*;
        matches!(
            self,
            MotionRequest { .. }
                | MotionFinish { .. }
                | MotionStep { .. }
                | SensorRequest { .. }
                | SensorReply { .. }
                | Light { .. }
                | Log { .. }
                | Lcm(_)
        )
    }

    /// The robot the observation is about (every observation has one).
    pub fn robot(&self) -> RobotId {
        use Observation::*;
        match self {
            Spawn { robot, .. }
            | MotionRequest { robot, .. }
            | MotionFinish { robot, .. }
            | Collision { robot, .. }
            | SensorRequest { robot, .. }
            | Log { robot, .. }
            | Request { robot, .. }
            | Send { robot, .. }
            | Receive { robot, .. }
            | Deliver { robot, .. }
            | Decide { robot, .. }
            | Suspect { robot, .. }
            | Trust { robot, .. }
            | Leader { robot, .. }
            | Crash { robot, .. }
            | SensorReply { robot, .. }
            | Light { robot, .. }
            | MotionStep { robot, .. } => *robot,
            Lcm(r) => r.robot(),
        }
    }
}

/// How the fields that are not plain data reach the trace.
mod ser {
    use serde::ser::{SerializeMap, Serializer};

    use super::*;
    use nekosim_protocols::codec::type_word;

    /// Names of the fields every trace object has; custom motion parameters never take them.
    const RESERVED: [&str; 6] = ["t", "seq", "kind", "robot", "ticket", "motion"];

    /// A motion request: `motion`, its pattern's name, then its parameters.
    pub fn motion<S: Serializer>(motion: &Motion, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(None)?;
        m.serialize_entry("motion", motion.name())?;
        for (k, v) in motion.params() {
            if !RESERVED.contains(&k.as_str()) {
                m.serialize_entry(&k, &v)?;
            }
        }
        m.end()
    }

    /// Only the pose of a kinematic state: `pos` and `angle`.
    pub fn pose<S: Serializer>(state: &Kinematics, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(2))?;
        m.serialize_entry("pos", &state.pos)?;
        m.serialize_entry("angle", &state.angle)?;
        m.end()
    }

    /// A message rendered through the stack's codecs.
    pub fn rendered<S: Serializer>(msg: &Payload, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(msg)
    }

    /// A message rendered (`msg`) and its type, the rendering's first word (`type`).
    pub fn msg_and_type<S: Serializer>(msg: &Payload, s: S) -> Result<S::Ok, S::Error> {
        let text = msg.to_string();
        let mut m = s.serialize_map(Some(2))?;
        m.serialize_entry("msg", &text)?;
        m.serialize_entry("type", type_word(&text))?;
        m.end()
    }

    /// A broadcast message's id (`msg`, as `origin:n`) and its `origin`.
    pub fn msg_id<S: Serializer>(id: &MsgId, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(2))?;
        m.serialize_entry("msg", &id.to_string())?;
        m.serialize_entry("origin", &id.origin)?;
        m.end()
    }

    pub fn step<S: Serializer>(step: &StepKind, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(step.name())
    }
}

/// A record as one trace object: `t`, `seq`, then the observation's fields (`kind` first).
impl Serialize for Record {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        #[derive(Serialize)]
        struct Line<'a> {
            t: f64,
            seq: u64,
            #[serde(flatten)]
            obs: &'a Observation,
        }
        Line {
            t: self.t,
            seq: self.seq,
            obs: &self.obs,
        }
        .serialize(s)
    }
}
