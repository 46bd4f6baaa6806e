//! Sensors (seed 3.1.2, 4.2.2 and 6.3.2): what can be asked, what comes back, and how a
//! sensor turns the world's exact data into a reply.
//!
//! Pull sensors answer one request: GPS (own position or all positions, with an error factor),
//! View (positions of robots whose centres are within a range) and Proximity (free distances,
//! border to border, to robots within a range). Push sensors interrupt the robot after being
//! activated: Proximity (another robot's border comes within range; the re-sense interval is a
//! quiet period after each interrupt) and Contact (the robot touches a robot or the boundary).

use rand::Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use super::geometry::Point;
use super::{Obstacle, RobotId};

/// Which sensor of a robot.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum SensorKind {
    Gps,
    View,
    Proximity,
    PushProximity,
    Contact,
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
        }
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
