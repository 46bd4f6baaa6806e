//! What a Look-Compute-Move run records: every activation, Look (with the frame and the
//! snapshot), Compute (the decision in the local frame and in the world) and Move, typed. The
//! trace writes each as an object of its `kind`; the Neko log as one line; the recording draws
//! them. A replay reads them back alone (tests/integration/lcm.rs).

use serde::Serialize;

use super::frame::Frame;
use super::look::Sighted;
use super::view::Light;
use crate::world::geometry::Point;
use crate::world::log_text::{num, point_text};
use crate::world::RobotId;

/// One record of a robot's cycle (`cycle` counts the robot's activations from 0).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum LcmRecord {
    /// The adversary activates the robot: when its Look happens, its Compute ends and its
    /// Move ends [s], and its round under a synchrony model of rounds.
    Activate {
        robot: RobotId,
        cycle: u64,
        look: f64,
        compute_end: f64,
        move_end: f64,
        #[serde(skip_serializing_if = "Option::is_none")]
        round: Option<u64>,
    },
    /// The Look: the robot's local frame, where it is, the light it sees itself show, and the
    /// robots it sees, in world coordinates.
    Look {
        robot: RobotId,
        cycle: u64,
        frame: Frame,
        me: Point,
        #[serde(skip_serializing_if = "Option::is_none")]
        light: Option<Light>,
        seen: Vec<Sighted>,
    },
    /// The Compute: the decision in the local frame (`local_to`), its destination in the
    /// world (`to`; none: stay) and the new light (none: keep).
    Compute {
        robot: RobotId,
        cycle: u64,
        local_to: Option<Point>,
        to: Option<Point>,
        light: Option<Light>,
    },
    /// The Move starts: from `from` towards `to`, stopping at `stop` (the adversary's point on
    /// a non-rigid move), at `end` [s].
    Move {
        robot: RobotId,
        cycle: u64,
        from: Point,
        to: Point,
        stop: Point,
        end: f64,
    },
    /// The cycle ended; the robot waits for its next activation.
    Wait {
        robot: RobotId,
        cycle: u64,
        at: Point,
    },
}

impl LcmRecord {
    /// The robot it is about.
    pub fn robot(&self) -> RobotId {
        match self {
            Self::Activate { robot, .. }
            | Self::Look { robot, .. }
            | Self::Compute { robot, .. }
            | Self::Move { robot, .. }
            | Self::Wait { robot, .. } => *robot,
        }
    }

    /// The Neko log's line after the time and robot columns.
    pub fn log_text(&self) -> String {
        let opt = |p: &Option<Point>| p.map_or("stay".to_string(), point_text);
        let light = |l: &Option<Light>| l.map_or("-".to_string(), |l| l.to_string());
        match self {
            Self::Activate {
                cycle,
                look,
                compute_end,
                move_end,
                ..
            } => format!(
                "Activate: cycle {cycle} | look {} | compute until {} | move until {}",
                num(*look),
                num(*compute_end),
                num(*move_end)
            ),
            Self::Look {
                cycle,
                frame,
                me,
                light: own,
                seen,
                ..
            } => {
                let seen: Vec<String> = seen
                    .iter()
                    .map(|s| format!("p{} {} {}", s.robot, point_text(s.at), light(&s.light)))
                    .collect();
                format!(
                    "Look: cycle {cycle} | {} | light {} | frame {} {} {} | {}",
                    point_text(*me),
                    light(own),
                    num(frame.rotation),
                    if frame.mirrored { "mirrored" } else { "direct" },
                    num(frame.unit),
                    seen.join(", ")
                )
            }
            Self::Compute {
                cycle,
                local_to,
                to,
                light: new,
                ..
            } => format!(
                "Compute: cycle {cycle} | local {} | to {} | light {}",
                opt(local_to),
                opt(to),
                light(new)
            ),
            Self::Move {
                cycle,
                from,
                to,
                stop,
                end,
                ..
            } => format!(
                "Move: cycle {cycle} | {} -> {} | stops at {} | until {}",
                point_text(*from),
                point_text(*to),
                point_text(*stop),
                num(*end)
            ),
            Self::Wait { cycle, at, .. } => {
                format!("Wait: cycle {cycle} | {}", point_text(*at))
            }
        }
    }
}
