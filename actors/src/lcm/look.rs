//! The Look: a sensor that takes an instantaneous snapshot of the robots a robot sees, their
//! exact positions at that instant (robots in mid-move included, from the motion formulas) and
//! their lights. A light being written is read through the scenario's register: its shown
//! colour (atomic), the old or the new one (regular), or any colour (safe); the choice is the
//! sensor's own seeded stream's, unless a scripted adversary names the colour.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::view::{Light, LightState};
use crate::world::geometry::Point;
use crate::world::sensor::{Reach, SensorModel, WorldView};
use crate::world::RobotId;

/// The name the Look sensor is registered under.
pub const LOOK: &str = "look";

/// What a Look asks: how far it sees (`None`: everything), which register lights are read
/// through, how many colours a safe register may return, and the colour a scripted adversary
/// has a light being written read as, where the register allows it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LookQuery {
    pub range: Option<f64>,
    pub register: Register,
    pub colours: u8,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub read: Option<Light>,
}

/// One robot as the world holds it at the Look instant.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Sighting {
    pub robot: RobotId,
    pub at: Point,
    pub light: Option<LightState>,
}

/// What a Look reads from a light being written (during its robot's Compute).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Register {
    /// The colour shown before the write.
    #[default]
    Atomic,
    /// The old colour or the new one.
    Regular,
    /// Any colour of the palette.
    Safe,
}

/// One robot as the Look returns it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sighted {
    pub robot: RobotId,
    pub at: Point,
    pub light: Option<Light>,
}

/// The Look's reply: where the robot is and what its own light shows, and the others it sees
/// (world coordinates; the robot's host maps them into its local frame), by id.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    pub me: Point,
    pub light: Option<Light>,
    pub others: Vec<Sighted>,
}

/// The Look sensor.
#[derive(Debug)]
pub struct Look;

impl SensorModel for Look {
    type Query = LookQuery;
    type Reading = (Sighting, Vec<Sighting>);
    type Reply = Snapshot;

    fn check(q: &LookQuery) -> Result<(), String> {
        match q.range {
            Some(r) if !(r.is_finite() && r > 0.0) => {
                Err(format!("a Look's range must be a number > 0, got {r}"))
            }
            _ if q.colours == 0 => Err("a Look's palette has no colour".into()),
            _ => Ok(()),
        }
    }

    fn sense(q: &LookQuery, world: &dyn WorldView) -> Self::Reading {
        let me = world.robot();
        let sighting = |robot: RobotId, at: Point| Sighting {
            robot,
            at,
            light: world.light(robot),
        };
        let others = match q.range {
            Some(range) => world
                .within(range)
                .into_iter()
                .map(|(id, at, _)| sighting(id, at))
                .collect(),
            None => (0..world.count() as RobotId)
                .filter(|&id| id != me)
                .map(|id| sighting(id, world.position(id)))
                .collect(),
        };
        (sighting(me, world.position(me)), others)
    }

    fn reply(q: &LookQuery, (me, others): Self::Reading, rng: &mut ChaCha8Rng) -> Snapshot {
        let read = |l: Option<LightState>, rng: &mut ChaCha8Rng| {
            l.map(|l| match (l.pending, q.register, q.read) {
                (None, _, _) | (Some(_), Register::Atomic, _) => l.shown,
                // A scripted adversary's choice, among what the register may return.
                (Some(new), Register::Regular, Some(c)) if c == new || c == l.shown => c,
                (Some(_), Register::Safe, Some(c)) if c < q.colours => c,
                (Some(new), Register::Regular, _) => {
                    if rng.gen_bool(0.5) {
                        new
                    } else {
                        l.shown
                    }
                }
                (Some(_), Register::Safe, _) => rng.gen_range(0..q.colours),
            })
        };
        Snapshot {
            me: me.at,
            light: me.light.map(|l| l.shown),
            others: others
                .into_iter()
                .map(|s| Sighted {
                    robot: s.robot,
                    at: s.at,
                    light: read(s.light, rng),
                })
                .collect(),
        }
    }

    fn reach(q: &LookQuery) -> Option<Reach> {
        q.range.map(Reach::Centres)
    }
}
