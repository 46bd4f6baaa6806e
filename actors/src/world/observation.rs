//! What a run shows: the observations the engine records, one per traced event, in
//! processing order. The scenario layer turns them into the Neko log and the JSONL trace.

use serde::{Deserialize, Serialize};

use super::geometry::Point;
use super::motion::{Kinematics, Progress, StepKind};
use super::sensor::{SensorKind, SensorQuery, SensorValue};
use super::{MotionOutcome, Obstacle, RobotId};
use nekosim_protocols::{MsgId, Payload};

/// One observation with its instant and sequence number.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// Simulated time [s].
    pub t: f64,
    /// Strictly increasing over a run.
    pub seq: u64,
    pub obs: Observation,
}

/// A traced event.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
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
        motion: String,
        params: Vec<(String, f64)>,
    },
    /// A motion event; `state` is the exact kinematic state from this instant on.
    MotionStep {
        robot: RobotId,
        step: StepKind,
        state: Kinematics,
        progress: Progress,
    },
    /// A motion ended.
    MotionFinish {
        robot: RobotId,
        state: Kinematics,
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
    SensorRequest {
        robot: RobotId,
        query: SensorQuery,
    },
    /// The algorithm wrote a line to the log (seed 5.3's `logger.info(..)`).
    Log {
        robot: RobotId,
        text: String,
    },
    /// The algorithm asked a protocol layer to `op` ("broadcast", "propose", "send") `msg`.
    Request {
        robot: RobotId,
        layer: String,
        op: String,
        msg: Payload,
    },
    /// A message handed to the network by `layer` ("app" for the algorithm).
    Send {
        robot: RobotId,
        to: Vec<RobotId>,
        layer: String,
        msg: Payload,
    },
    /// A message arrived from the network at `layer` of `robot`.
    Receive {
        robot: RobotId,
        from: RobotId,
        layer: String,
        msg: Payload,
    },
    /// A broadcast layer delivered message `id` to the algorithm.
    Deliver {
        robot: RobotId,
        layer: String,
        id: MsgId,
        msg: Payload,
    },
    /// A consensus layer decided `value` for instance `k`.
    Decide {
        robot: RobotId,
        layer: String,
        k: u64,
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
        state: Kinematics,
    },
    /// A sensor's reply; `interrupt` when a push sensor fired on its own.
    SensorReply {
        robot: RobotId,
        sensor: SensorKind,
        value: SensorValue,
        interrupt: bool,
    },
}
