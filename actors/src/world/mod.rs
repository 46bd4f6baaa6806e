//! The pure world kernel: geometry, motion patterns, collision prediction, the spatial index,
//! sensors' data and the virtual world itself (seed 3.2, 4.2.4). Nothing here depends on actix,
//! so it can be property-tested directly; the actors in the crate root host it.

use serde::{Deserialize, Serialize};

pub mod born;
pub mod collision;
pub mod event;
pub mod geometry;
pub mod grid;
pub mod log_text;
pub mod motion;
pub mod network;
pub mod observation;
pub mod obstacle;
pub mod outbox;
pub mod piece;
pub mod prefetch;
pub mod queue;
pub mod radix;
pub mod sensor;
pub mod virtual_world;

/// A robot's identity number (seed 3.1).
pub type RobotId = u32;

/// What a robot touched (serialized as the robot's id or `"boundary"`, as the trace shows it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Obstacle {
    Robot(RobotId),
    /// The boundary of a bounded world.
    Boundary,
    /// Obstacle number K of the world's list (`"obstacle:K"` in the trace).
    Object(u32),
}

impl std::fmt::Display for Obstacle {
    /// `p7`, `boundary`, `obstacle:2`: as logs name what a robot touched.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Obstacle::Robot(id) => write!(f, "p{id}"),
            Obstacle::Boundary => f.write_str("boundary"),
            Obstacle::Object(k) => write!(f, "obstacle:{k}"),
        }
    }
}

impl Serialize for Obstacle {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Obstacle::Robot(id) => s.serialize_u32(*id),
            Obstacle::Boundary => s.serialize_str("boundary"),
            Obstacle::Object(k) => s.serialize_str(&format!("obstacle:{k}")),
        }
    }
}

impl<'de> Deserialize<'de> for Obstacle {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Form {
            Robot(RobotId),
            Named(String),
        }
        match Form::deserialize(d)? {
            Form::Robot(id) => Ok(Obstacle::Robot(id)),
            Form::Named(n) if n == "boundary" => Ok(Obstacle::Boundary),
            Form::Named(n)
                if n.strip_prefix("obstacle:")
                    .is_some_and(|k| k.parse::<u32>().is_ok()) =>
            {
                Ok(Obstacle::Object(
                    n["obstacle:".len()..].parse().expect("checked"),
                ))
            }
            Form::Named(n) => Err(serde::de::Error::custom(format!(
                "expected a robot id, \"boundary\" or \"obstacle:K\", got {n:?}"
            ))),
        }
    }
}

/// How a motion ended (serialized as the trace shows it: `outcome`, with `other` for a
/// collision and `reason` for a rejection).
#[derive(Clone, Debug, PartialEq)]
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

impl Serialize for MotionOutcome {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(None)?;
        m.serialize_entry("outcome", self.name())?;
        match self {
            MotionOutcome::Collided { with } => m.serialize_entry("other", with)?,
            MotionOutcome::Rejected(reason) => m.serialize_entry("reason", reason)?,
            _ => {}
        }
        m.end()
    }
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
