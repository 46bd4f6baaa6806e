//! A scenario's Look-Compute-Move settings (`lcm: (...)`): the synchrony model, movement,
//! lights, frames, sensing and the adversary. The names and their meaning follow spin-light's
//! Promela model (Défago, Heriban, Tixeuil and Wada, "Using model checking to formally verify
//! rendezvous algorithms for robots with lights in Euclidean space", Robotics and Autonomous
//! Systems 163, 2023; github.com/xdefago/spin-light, Schedulers.pml and Robots.pml).

use std::sync::{Arc, OnceLock};

use serde::{Deserialize, Serialize};

use super::frame::Frames;
pub use super::look::Register;
use crate::world::RobotId;

/// Which robots the adversary activates and how their phases may interleave
/// (spin-light's Schedulers.pml).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Synchrony {
    /// One robot per round, its whole cycle atomic.
    Centralized,
    /// Every robot every round; all Look at the round's start.
    Fsync,
    /// A non-empty subset of the robots each round; those Look at the round's start.
    Ssync,
    /// Every phase of every robot takes an arbitrary time.
    #[default]
    Async,
    /// ASYNC where a robot's Look and Compute take no time (its light changes at its Look).
    AsyncLcAtomic,
    /// ASYNC where a robot's Look and Compute take no time and no other robot acts between
    /// them.
    AsyncLcStrict,
    /// ASYNC where a robot's Compute and Move are one atomic step (simulated by Looks in even
    /// half-cycle slots and Computes with Moves in odd ones).
    AsyncCmAtomic,
    /// ASYNC where a robot's Move is one atomic step (simulated by Looks in even half-cycle
    /// slots and Moves in odd ones).
    AsyncMoveAtomic,
}

impl Synchrony {
    /// Whether robots act in rounds of the scenario's cycle length.
    pub fn in_rounds(self) -> bool {
        matches!(self, Self::Centralized | Self::Fsync | Self::Ssync)
    }
}

/// How far a move goes (Flocchini, Prencipe and Santoro 2019, section 1.1.3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum Movement {
    /// The robot reaches its destination.
    #[default]
    Rigid,
    /// The adversary may stop the robot anywhere once it has moved `delta` [units], or at
    /// its destination if that is closer.
    NonRigid { delta: f64 },
}

/// Who sees a robot's light (Das et al. 2016; Flocchini et al.'s "internal" and "external"
/// lights).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Lights {
    /// The robot and the others.
    #[default]
    Full,
    /// Only the others.
    External,
    /// Only the robot itself.
    Internal,
}

impl Lights {
    pub fn own_visible(self) -> bool {
        self != Self::External
    }
    pub fn others_visible(self) -> bool {
        self != Self::Internal
    }
}

/// Whether a robot can tell how many robots stand at one point.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Detection {
    #[default]
    None,
    /// One, or more than one.
    Weak,
    /// The exact number.
    Strong,
}

/// One activation of a scripted adversary: when `robot` Looks, when its Compute ends, when its
/// Move starts (`start_move`, at the end of the Compute when omitted) and ends, where a
/// non-rigid move stops (the fraction of the way, 1 when omitted), and what the Look reads of a
/// light being written (`read`, where the register allows that colour; the register's draw when
/// omitted).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Activation {
    pub robot: RobotId,
    pub look: f64,
    pub compute: f64,
    #[serde(default)]
    pub start_move: Option<f64>,
    #[serde(rename = "move")]
    pub move_end: f64,
    #[serde(default)]
    pub stop: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub read: Option<super::view::Light>,
}

/// Who schedules the robots.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum AdversaryKind {
    /// Seeded and random within the synchrony model.
    #[default]
    Random,
    /// Exactly these activations, each robot's in time order; a robot stops after its last.
    Scripted(Vec<Activation>),
}

/// The Look-Compute-Move robots of a run: which robots they are, filled once the scenario has
/// built its robots (the adversary of a round picks among them).
#[derive(Clone, Debug, Default)]
pub struct Roster(Arc<OnceLock<Vec<RobotId>>>);

impl Roster {
    /// Sets the roster (the first call wins).
    pub fn set(&self, robots: Vec<RobotId>) {
        let _ = self.0.set(robots);
    }

    /// The robots, in id order (empty until set).
    pub fn robots(&self) -> &[RobotId] {
        self.0.get().map_or(&[], Vec::as_slice)
    }
}

impl PartialEq for Roster {
    /// A roster is part of a run, not of a scenario's settings.
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// The settings of the scenario's `lcm` section. Every field has a default: ASYNC, rigid,
/// full lights, atomic registers, frames the adversary picks at every activation, unlimited
/// visibility, no multiplicity detection, cycles of one second, a random adversary.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LcmSettings {
    #[serde(default)]
    pub synchrony: Synchrony,
    #[serde(default)]
    pub movement: Movement,
    #[serde(default)]
    pub lights: Lights,
    #[serde(default)]
    pub register: Register,
    #[serde(default)]
    pub frames: Frames,
    /// How far a robot sees [units]; `None`: everything.
    #[serde(default)]
    pub visibility: Option<f64>,
    #[serde(default)]
    pub multiplicity: Detection,
    /// A round's length, or an ASYNC cycle's mean length [s].
    #[serde(default = "one")]
    pub cycle: f64,
    #[serde(default)]
    pub adversary: AdversaryKind,
    /// What the run reports on: when each first held, and whether it kept holding.
    #[serde(default)]
    pub predicates: Vec<super::predicate::Predicate>,
    /// The robots' first lights, by robot id (a checker's counterexample replays from its
    /// own); robots beyond the list start with a light the adversary draws.
    #[serde(default)]
    pub initial_lights: Vec<super::view::Light>,
    #[serde(skip)]
    pub roster: Roster,
}

fn one() -> f64 {
    1.0
}

impl Default for LcmSettings {
    fn default() -> Self {
        Self {
            synchrony: Synchrony::default(),
            movement: Movement::default(),
            lights: Lights::default(),
            register: Register::default(),
            frames: Frames::default(),
            visibility: None,
            multiplicity: Detection::default(),
            cycle: 1.0,
            adversary: AdversaryKind::default(),
            predicates: Vec::new(),
            initial_lights: Vec::new(),
            roster: Roster::default(),
        }
    }
}

/// Why a scenario's `lcm` settings are refused: the field and what it expects.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct SettingsError {
    pub field: String,
    pub message: String,
    pub expected: String,
}

impl LcmSettings {
    /// Checks the settings as a scenario states them.
    pub fn check(&self) -> Result<(), SettingsError> {
        let err = |field: &str, message: String, expected: &str| SettingsError {
            field: field.into(),
            message,
            expected: expected.into(),
        };
        if let Movement::NonRigid { delta } = self.movement {
            if !(delta.is_finite() && delta > 0.0) {
                return Err(err(
                    "movement.delta",
                    format!("delta is {delta}"),
                    "a number > 0",
                ));
            }
        }
        if let Some(v) = self.visibility {
            if !(v.is_finite() && v > 0.0) {
                return Err(err(
                    "visibility",
                    format!("visibility is {v}"),
                    "a number > 0",
                ));
            }
        }
        if !(self.cycle.is_finite() && self.cycle > 0.0) {
            return Err(err(
                "cycle",
                format!("cycle is {}", self.cycle),
                "a number > 0",
            ));
        }
        for (i, p) in self.predicates.iter().enumerate() {
            p.check().map_err(|e| {
                err(
                    &format!("predicates[{i}]"),
                    format!("{}: {e}", p.name()),
                    "a number > 0",
                )
            })?;
        }
        if let AdversaryKind::Scripted(acts) = &self.adversary {
            for (i, a) in acts.iter().enumerate() {
                let start = a.start_move.unwrap_or(a.compute);
                let ok = a.look.is_finite()
                    && a.look >= 0.0
                    && a.compute >= a.look
                    && start >= a.compute
                    && a.move_end > start
                    && a.move_end.is_finite()
                    && a.stop.is_none_or(|s| (0.0..=1.0).contains(&s));
                if !ok {
                    return Err(err(
                        &format!("adversary[0][{i}]"),
                        format!(
                            "activation of robot {} at look {}, compute {}, start_move {:?}, move {}, stop {:?}",
                            a.robot, a.look, a.compute, a.start_move, a.move_end, a.stop
                        ),
                        "0 <= look <= compute <= start_move < move, finite, stop within [0, 1]",
                    ));
                }
            }
        }
        Ok(())
    }
}
