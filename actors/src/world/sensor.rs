//! Sensors (seed 3.1.2, 4.2.2 and 6.3.2): what can be asked, what comes back, and how a
//! sensor turns the world's exact data into a reply.
//!
//! Pull sensors answer one request: GPS (own position or all positions, with an error factor),
//! View (positions of robots whose centres are within a range) and Proximity (free distances,
//! border to border, to robots within a range). Push sensors interrupt the robot after being
//! activated: Proximity (another robot's border comes within range; the re-sense interval is a
//! quiet period after each interrupt) and Contact (the robot touches a robot or the boundary).

use std::fmt;

use nekosim_protocols::registry::{intern, Named};
use nekosim_protocols::wire::compact_ron;

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use super::geometry::Point;
use super::{Obstacle, RobotId};

/// Which sensor of a robot (serialized as its name).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum SensorKind {
    Gps,
    View,
    Proximity,
    PushProximity,
    Contact,
    /// A sensor registered under this name ([`Sensors`]).
    User(&'static str),
}

impl SensorKind {
    /// Name used in traces and logs.
    pub fn name(self) -> &'static str {
        match self {
            SensorKind::Gps => "gps",
            SensorKind::View => "view",
            SensorKind::Proximity => "proximity",
            SensorKind::PushProximity => "push_proximity",
            SensorKind::Contact => "contact",
            SensorKind::User(name) => name,
        }
    }

    /// The sensor named `name` (a built-in's name, or a registered sensor's).
    pub fn from_name(name: &str) -> Self {
        match name {
            "gps" => SensorKind::Gps,
            "view" => SensorKind::View,
            "proximity" => SensorKind::Proximity,
            "push_proximity" => SensorKind::PushProximity,
            "contact" => SensorKind::Contact,
            other => SensorKind::User(intern(other)),
        }
    }

    /// The number that derives the sensor's random stream from the run's seed.
    pub fn stream(self) -> u64 {
        match self {
            SensorKind::Gps => 0,
            SensorKind::View => 1,
            SensorKind::Proximity => 2,
            SensorKind::PushProximity => 3,
            SensorKind::Contact => 4,
            // FNV-1a of the name, clear of the built-ins' numbers.
            SensorKind::User(name) => {
                let mut h: u64 = 0xcbf2_9ce4_8422_2325;
                for b in name.bytes() {
                    h = (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
                }
                16 + (h % 240)
            }
        }
    }
}

impl Serialize for SensorKind {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for SensorKind {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let name = String::deserialize(d)?;
        Ok(SensorKind::from_name(&name))
    }
}

/// A sensor request.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum SensorQuery {
    /// GPS: own position, each coordinate perturbed by `error` × N(0, 1) [units].
    SelfPosition {
        error: f64,
    },
    /// GPS: all robots' positions (including the requester), perturbed as above.
    AllPositions {
        error: f64,
    },
    /// View: positions of the other robots whose centres are within `range` [units].
    View {
        range: f64,
    },
    /// Proximity: free distances (border to border) to the other robots within `range`.
    Proximity {
        range: f64,
    },
    /// Push proximity: interrupt when another robot's border comes within `range`; after an
    /// interrupt the sensor is quiet for `interval` [s] and re-senses at its end.
    ActivateProximity {
        range: f64,
        interval: f64,
    },
    DeactivateProximity,
    /// Contact: interrupt when the robot touches a robot or the world boundary.
    ActivateContact,
    DeactivateContact,
    /// A registered sensor `sensor`, with its query as RON text: a reading (pull sensor) or an
    /// activation (push sensor).
    User {
        sensor: String,
        query: String,
    },
    /// Deactivates the registered push sensor `sensor`.
    UserOff {
        sensor: String,
    },
}

impl SensorQuery {
    /// The sensor that serves the query.
    pub fn kind(&self) -> SensorKind {
        match self {
            SensorQuery::SelfPosition { .. } | SensorQuery::AllPositions { .. } => SensorKind::Gps,
            SensorQuery::View { .. } => SensorKind::View,
            SensorQuery::Proximity { .. } => SensorKind::Proximity,
            SensorQuery::ActivateProximity { .. } | SensorQuery::DeactivateProximity => {
                SensorKind::PushProximity
            }
            SensorQuery::ActivateContact | SensorQuery::DeactivateContact => SensorKind::Contact,
            SensorQuery::User { sensor, .. } | SensorQuery::UserOff { sensor } => {
                SensorKind::User(intern(sensor))
            }
        }
    }

    /// Checks the query's parameters; `Err` says what is expected.
    pub fn validate(&self) -> Result<(), String> {
        let nonneg = |what: &str, v: f64| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(format!("{what} must be a finite number >= 0, got {v}"))
            }
        };
        match *self {
            SensorQuery::SelfPosition { error } | SensorQuery::AllPositions { error } => {
                nonneg("error factor", error)
            }
            SensorQuery::View { range } | SensorQuery::Proximity { range } => {
                nonneg("range", range)
            }
            SensorQuery::ActivateProximity { range, interval } => {
                nonneg("range", range)?;
                nonneg("interval", interval)
            }
            _ => Ok(()),
        }
    }

    fn error(&self) -> f64 {
        match self {
            SensorQuery::SelfPosition { error } | SensorQuery::AllPositions { error } => *error,
            _ => 0.0,
        }
    }
}

/// A sensor's answer (and the exact data a sensor manager hands a sensor).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum SensorValue {
    Position(Point),
    /// `(robot, position)` sorted by robot id.
    Positions(Vec<(RobotId, Point)>),
    /// `(robot, free distance)` sorted by robot id.
    Distances(Vec<(RobotId, f64)>),
    Contact(Obstacle),
    /// A push sensor was (de)activated.
    Done,
    /// The request was invalid.
    Rejected(String),
    /// A registered sensor's reading or reply, as RON text.
    User(String),
}

impl SensorValue {
    /// A registered sensor's reply read as an `R` (its [`SensorModel::Reply`]).
    pub fn decode<R: DeserializeOwned>(&self) -> Result<R, String> {
        match self {
            SensorValue::User(text) => ron::from_str(text).map_err(|e| e.to_string()),
            SensorValue::Rejected(e) => Err(e.clone()),
            other => Err(format!("not a registered sensor's value: {other:?}")),
        }
    }
}

/// The exact data a sensor manager gives a sensor at trigger time.
pub type Snapshot = SensorValue;

/// Computes a reply from exact data (the seed's `calReply`): GPS adds Gaussian noise with
/// standard deviation `error` to each coordinate; other sensors are exact.
pub fn cal_reply(query: &SensorQuery, snapshot: Snapshot, rng: &mut impl Rng) -> SensorValue {
    let error = query.error();
    if error == 0.0 {
        return snapshot;
    }
    let mut jitter = |p: Point| {
        let dx: f64 = rng.sample(StandardNormal);
        let dy: f64 = rng.sample(StandardNormal);
        Point::new(p.x + error * dx, p.y + error * dy)
    };
    match snapshot {
        SensorValue::Position(p) => SensorValue::Position(jitter(p)),
        SensorValue::Positions(ps) => {
            SensorValue::Positions(ps.into_iter().map(|(id, p)| (id, jitter(p))).collect())
        }
        other => other,
    }
}

/// A push sensor's re-sense interval [s].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interval(pub f64);

/// What a sensor sees of the world at its trigger instant (the seed's `doSensor` runs on the
/// sensor manager, which alone reaches the world): exact positions from the motion formulas.
pub trait WorldView {
    /// The trigger instant [s].
    fn now(&self) -> f64;
    /// The robot whose sensor it is.
    fn robot(&self) -> RobotId;
    /// Number of robots.
    fn count(&self) -> usize;
    /// A robot's exact position now.
    fn position(&self, robot: RobotId) -> Point;
    /// A robot's radius.
    fn radius(&self, robot: RobotId) -> f64;
    /// The other robots whose centres are within `range` of this robot's centre, with their
    /// positions and centre distances, by id (found through the spatial index).
    fn within(&self, range: f64) -> Vec<(RobotId, Point, f64)>;
}

/// A sensor written against the seed's split (4.2.2): [`SensorModel::sense`] gathers exact
/// data from the world at the trigger instant, [`SensorModel::reply`] computes the robot's
/// reply on the robot's sensor actor with that sensor's own seeded random stream (the seed's
/// `calReply`). A push sensor ([`SensorModel::push_interval`]) re-senses every interval while
/// active and interrupts its robot whenever [`SensorModel::fires`] holds.
pub trait SensorModel: fmt::Debug + Send + Sync + 'static {
    /// What the robot asks (read from and written to RON).
    type Query: Serialize + DeserializeOwned;
    /// The exact data gathered at the trigger.
    type Reading: Serialize + DeserializeOwned;
    /// What the robot gets.
    type Reply: Serialize + DeserializeOwned;

    /// Checks a query; `Err` says what is wrong (the robot gets it as a rejection).
    fn check(_query: &Self::Query) -> Result<(), String> {
        Ok(())
    }

    /// The exact data for `query` now.
    fn sense(query: &Self::Query, world: &dyn WorldView) -> Self::Reading;

    /// The reply from the exact data; `rng` is the sensor's own seeded stream.
    fn reply(query: &Self::Query, reading: Self::Reading, rng: &mut ChaCha8Rng) -> Self::Reply;

    /// `Some(interval)` for a push sensor: activating it re-senses every `interval` seconds
    /// (from the activation) until it is deactivated. `None` (the default): a pull sensor.
    fn push_interval(_query: &Self::Query) -> Option<f64> {
        None
    }

    /// For a push sensor: whether a reading interrupts the robot.
    fn fires(_query: &Self::Query, _reading: &Self::Reading) -> bool {
        true
    }
}

/// One registered sensor, its types erased behind RON text.
#[derive(Clone, Copy)]
struct SensorEntry {
    sense: fn(&str, &dyn WorldView) -> Result<String, String>,
    reply: fn(&str, &str, &mut ChaCha8Rng) -> Result<String, String>,
    push: fn(&str) -> Result<Option<f64>, String>,
    fires: fn(&str, &str) -> bool,
}

fn ron_text<T: Serialize>(v: &T) -> Result<String, String> {
    compact_ron(v).map_err(|e| e.to_string())
}

fn read<T: DeserializeOwned>(text: &str) -> Result<T, String> {
    ron::from_str(text).map_err(|e| e.to_string())
}

fn sense_entry<S: SensorModel>(query: &str, world: &dyn WorldView) -> Result<String, String> {
    let q: S::Query = read(query)?;
    S::check(&q)?;
    ron_text(&S::sense(&q, world))
}

fn reply_entry<S: SensorModel>(
    query: &str,
    reading: &str,
    rng: &mut ChaCha8Rng,
) -> Result<String, String> {
    let q: S::Query = read(query)?;
    ron_text(&S::reply(&q, read(reading)?, rng))
}

fn push_entry<S: SensorModel>(query: &str) -> Result<Option<f64>, String> {
    let q: S::Query = read(query)?;
    S::check(&q)?;
    match S::push_interval(&q) {
        Some(i) if !(i.is_finite() && i > 0.0) => Err(format!(
            "push interval is {i}; expected a finite number > 0"
        )),
        other => Ok(other),
    }
}

fn fires_entry<S: SensorModel>(query: &str, reading: &str) -> bool {
    match (read::<S::Query>(query), read::<S::Reading>(reading)) {
        (Ok(q), Ok(r)) => S::fires(&q, &r),
        _ => false,
    }
}

/// Sensors registered by name, beside the built-in GPS, view, proximity, push proximity and
/// contact sensors: `robot.read::<S>("Name", &query)` reads one.
#[derive(Clone, Debug)]
pub struct Sensors {
    entries: Named<SensorEntry>,
}

impl Default for Sensors {
    fn default() -> Self {
        Self::new()
    }
}

impl Sensors {
    /// No registered sensor.
    pub fn new() -> Self {
        Self {
            entries: Named::new("sensor"),
        }
    }

    /// Registers the sensor `S` under `name`.
    pub fn sensor<S: SensorModel>(&mut self, name: &str) -> &mut Self {
        self.entries.insert(
            name,
            SensorEntry {
                sense: sense_entry::<S>,
                reply: reply_entry::<S>,
                push: push_entry::<S>,
                fires: fires_entry::<S>,
            },
        );
        self
    }

    fn entry(&self, name: &str) -> Result<&SensorEntry, String> {
        self.entries.by_name(name)
    }

    /// The exact reading of `name` for `query` (RON), as RON.
    pub fn sense(&self, name: &str, query: &str, world: &dyn WorldView) -> Result<String, String> {
        (self.entry(name)?.sense)(query, world)
    }

    /// The reply of `name` from a reading, as RON.
    pub fn reply(
        &self,
        name: &str,
        query: &str,
        reading: &str,
        rng: &mut ChaCha8Rng,
    ) -> Result<String, String> {
        (self.entry(name)?.reply)(query, reading, rng)
    }

    /// `Some(interval)` when `name` is a push sensor for `query`.
    pub fn push_interval(&self, name: &str, query: &str) -> Result<Option<f64>, String> {
        (self.entry(name)?.push)(query)
    }

    /// Whether a push reading interrupts.
    pub fn fires(&self, name: &str, query: &str, reading: &str) -> bool {
        self.entry(name).is_ok_and(|e| (e.fires)(query, reading))
    }
}

/// A query as RON text, for [`SensorQuery::User`].
pub fn query_text<Q: Serialize>(query: &Q) -> Result<String, String> {
    ron_text(query)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn gps_noise_has_the_requested_spread_and_is_seeded() {
        let q = SensorQuery::SelfPosition { error: 2.0 };
        let sample = |seed| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            (0..4000)
                .map(|_| {
                    match cal_reply(&q, SensorValue::Position(Point::new(10.0, 0.0)), &mut rng) {
                        SensorValue::Position(p) => p.x - 10.0,
                        _ => unreachable!(),
                    }
                })
                .collect::<Vec<_>>()
        };
        let xs = sample(1);
        assert_eq!(xs, sample(1));
        assert_ne!(xs, sample(2));
        let mean = xs.iter().sum::<f64>() / xs.len() as f64;
        let sd = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / xs.len() as f64).sqrt();
        assert!(
            mean.abs() < 0.15 && (sd - 2.0).abs() < 0.15,
            "mean {mean} sd {sd}"
        );
    }
}
