//! The pure world kernel: geometry, motion patterns, collision prediction, the spatial index,
//! sensors' data and the virtual world itself (seed 3.2, 4.2.4). Nothing here depends on actix,
//! so it can be property-tested directly; the actors in the crate root host it.

use serde::{Deserialize, Serialize};

pub mod born;
pub mod collision;
pub mod event;
pub mod geometry;
pub mod grid;
pub mod motion;
pub mod network;
pub mod observation;
pub mod sensor;
pub mod virtual_world;

/// A robot's identity number (seed 3.1).
pub type RobotId = u32;

/// What a robot touched.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Obstacle {
    Robot(RobotId),
    /// The boundary of a bounded world.
    Boundary,
}

/// How a motion ended.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum MotionOutcome {
    /// It ran to its end.
    Arrived,
    /// It was stopped by a collision.
    Collided { with: Obstacle },
    /// A newer motion request replaced it.
    Replaced,
    /// The request was invalid; the robot did not move.
    Rejected(String),
    /// The robot crashed.
    Crashed,
}

impl MotionOutcome {
    /// Trace name: `arrived`, `collided`, `replaced` or `rejected`.
    pub fn name(&self) -> &'static str {
        match self {
            MotionOutcome::Arrived => "arrived",
            MotionOutcome::Collided { .. } => "collided",
            MotionOutcome::Replaced => "replaced",
            MotionOutcome::Rejected(_) => "rejected",
            MotionOutcome::Crashed => "crashed",
        }
    }
}
