//! The built-in sensors (seed 3.1.2, 6.3.2), each a [`SensorModel`] registered by one line in
//! [`register`], exactly as a user's sensor is:
//! - GPS: the robot's own position or all robots' positions, each coordinate perturbed by
//!   `error` × N(0, 1) on the robot's sensor;
//! - View: positions of the other robots whose centres are within a range;
//! - Proximity: free distances (border to border) to the other robots within a range;
//! - Push proximity: interrupts at the exact instant another robot's border comes within a
//!   range; after an interrupt it is quiet for an interval and re-senses at its end;
//! - Contact: interrupts when the robot touches a robot or the world boundary.
//!
//! Their queries and replies serialize to the trace's documented forms (docs/trace.md).

use std::fmt::Write;

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use super::{Reach, SensorModel, Sensors, Trigger, WorldView};
use crate::world::geometry::Point;
use crate::world::log_text::{num, obstacle_text, point_text};
use crate::world::{Obstacle, RobotId};

/// Registers the built-in sensors under their names.
pub fn register(s: &mut Sensors) {
    s.sensor::<Gps>("gps")
        .sensor::<View>("view")
        .sensor::<Proximity>("proximity")
        .sensor::<PushProximity>("push_proximity")
        .sensor::<Contact>("contact")
        .sensor::<crate::lcm::look::Look>(crate::lcm::look::LOOK);
}

impl Default for Sensors {
    fn default() -> Self {
        Self::with_builtins()
    }
}

impl Sensors {
    /// The built-in sensors.
    pub fn with_builtins() -> Self {
        let mut s = Self::empty();
        register(&mut s);
        s
    }

    /// The built-in sensors (as [`Sensors::with_builtins`]).
    pub fn new() -> Self {
        Self::with_builtins()
    }
}

fn nonneg(what: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(format!("{what} must be a finite number >= 0, got {v}"))
    }
}

/// A robot and its position.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Seen {
    pub robot: RobotId,
    pub pos: Point,
}

/// A robot and its free distance (border to border).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Gap {
    pub robot: RobotId,
    pub distance: f64,
}

fn seen_text(seen: &[Seen]) -> String {
    let mut s = String::new();
    for (i, x) in seen.iter().enumerate() {
        let sep = if i > 0 { " " } else { "" };
        let _ = write!(s, "{sep}p{}{}", x.robot, point_text(x.pos));
    }
    s
}

fn gaps_text(gaps: &[Gap]) -> String {
    let mut s = String::new();
    for (i, g) in gaps.iter().enumerate() {
        let sep = if i > 0 { " " } else { "" };
        let _ = write!(s, "{sep}p{}:{}", g.robot, num(g.distance));
    }
    s
}

/// The GPS sensor (seed 6.3.2).
#[derive(Debug)]
pub struct Gps;

/// A GPS query; `error` is the standard deviation of the noise on each coordinate [units].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "query", rename_all = "snake_case")]
pub enum GpsQuery {
    SelfPosition { error: f64 },
    AllPositions { error: f64 },
}

/// A GPS fix: the robot's own position, or every robot's by id.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Fix {
    Position(Point),
    Positions(Vec<Seen>),
}

impl SensorModel for Gps {
    type Query = GpsQuery;
    type Reading = Fix;
    type Reply = Fix;

    fn check(q: &GpsQuery) -> Result<(), String> {
        let (GpsQuery::SelfPosition { error } | GpsQuery::AllPositions { error }) = *q;
        nonneg("error factor", error)
    }

    fn sense(q: &GpsQuery, world: &dyn WorldView) -> Fix {
        match q {
            GpsQuery::SelfPosition { .. } => Fix::Position(world.position(world.robot())),
            GpsQuery::AllPositions { .. } => Fix::Positions(
                (0..world.count() as RobotId)
                    .map(|robot| Seen {
                        robot,
                        pos: world.position(robot),
                    })
                    .collect(),
            ),
        }
    }

    fn reply(q: &GpsQuery, fix: Fix, rng: &mut ChaCha8Rng) -> Fix {
        let (GpsQuery::SelfPosition { error } | GpsQuery::AllPositions { error }) = *q;
        if error == 0.0 {
            return fix;
        }
        let mut jitter = |p: Point| {
            let dx: f64 = rng.sample(StandardNormal);
            let dy: f64 = rng.sample(StandardNormal);
            Point::new(p.x + error * dx, p.y + error * dy)
        };
        match fix {
            Fix::Position(p) => Fix::Position(jitter(p)),
            Fix::Positions(ps) => Fix::Positions(
                ps.into_iter()
                    .map(|s| Seen {
                        robot: s.robot,
                        pos: jitter(s.pos),
                    })
                    .collect(),
            ),
        }
    }

    fn query_text(q: &GpsQuery) -> Option<String> {
        Some(match q {
            GpsQuery::SelfPosition { error } => {
                format!("SelfPositioning with errorFactor {error:?}")
            }
            GpsQuery::AllPositions { error } => format!("Positioning with errorFactor {error:?}"),
        })
    }

    fn reply_text(fix: &Fix) -> Option<String> {
        Some(match fix {
            Fix::Position(p) => point_text(*p),
            Fix::Positions(ps) => seen_text(ps),
        })
    }
}

/// The view sensor: positions of the other robots whose centres are within `range`.
#[derive(Debug)]
pub struct View;

/// A view query [units].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "query", rename = "view")]
pub struct ViewQuery {
    pub range: f64,
    /// Only robots in sight (no obstacle on the line between the centres); default true.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub line_of_sight: Option<bool>,
}

impl SensorModel for View {
    type Query = ViewQuery;
    type Reading = Vec<Seen>;
    type Reply = Vec<Seen>;

    fn check(q: &ViewQuery) -> Result<(), String> {
        nonneg("range", q.range)
    }

    fn sense(q: &ViewQuery, world: &dyn WorldView) -> Vec<Seen> {
        let sight = q.line_of_sight.unwrap_or(true);
        world
            .within(q.range)
            .into_iter()
            .filter(|(robot, _, _)| !sight || world.in_sight(*robot))
            .map(|(robot, pos, _)| Seen { robot, pos })
            .collect()
    }

    fn reply(_: &ViewQuery, seen: Vec<Seen>, _: &mut ChaCha8Rng) -> Vec<Seen> {
        seen
    }

    fn query_text(q: &ViewQuery) -> Option<String> {
        Some(format!("View with range {}", num(q.range)))
    }

    fn reply_text(seen: &Vec<Seen>) -> Option<String> {
        Some(seen_text(seen))
    }

    fn reach(q: &ViewQuery) -> Option<Reach> {
        Some(Reach::Centres(q.range))
    }
}

/// The (pull) proximity sensor: free distances to the other robots within `range`.
#[derive(Debug)]
pub struct Proximity;

/// A proximity query: the largest free distance reported [units].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "query", rename = "proximity")]
pub struct ProximityQuery {
    pub range: f64,
    /// Only robots in sight (no obstacle on the line between the centres); default true.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub line_of_sight: Option<bool>,
}

impl SensorModel for Proximity {
    type Query = ProximityQuery;
    type Reading = Vec<Gap>;
    type Reply = Vec<Gap>;

    fn check(q: &ProximityQuery) -> Result<(), String> {
        nonneg("range", q.range)
    }

    fn sense(q: &ProximityQuery, world: &dyn WorldView) -> Vec<Gap> {
        gaps(world, q.range, q.line_of_sight.unwrap_or(true))
    }

    fn reply(_: &ProximityQuery, gaps: Vec<Gap>, _: &mut ChaCha8Rng) -> Vec<Gap> {
        gaps
    }

    fn query_text(q: &ProximityQuery) -> Option<String> {
        Some(format!("Proximity with range {}", num(q.range)))
    }

    fn reply_text(gaps: &Vec<Gap>) -> Option<String> {
        Some(gaps_text(gaps))
    }

    fn reach(q: &ProximityQuery) -> Option<Reach> {
        Some(Reach::Borders(q.range))
    }
}

/// The robots within `range` (free distance), those hidden by obstacles left out when
/// `sight` asks for it.
fn gaps(world: &dyn WorldView, range: f64, sight: bool) -> Vec<Gap> {
    world
        .near(range)
        .into_iter()
        .filter(|(robot, _)| !sight || world.in_sight(*robot))
        .map(|(robot, distance)| Gap { robot, distance })
        .collect()
}

/// The push proximity sensor: interrupts at the exact instant another robot's border comes
/// within `range` of the robot's border, reporting every robot then within range.
#[derive(Debug)]
pub struct PushProximity;

/// Activates (with the range and the quiet interval after each interrupt [s]) or
/// deactivates push proximity.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "query", rename_all = "snake_case")]
pub enum PushProximityQuery {
    ActivateProximity { range: f64, interval: f64 },
    DeactivateProximity,
}

impl SensorModel for PushProximity {
    type Query = PushProximityQuery;
    type Reading = Vec<Gap>;
    type Reply = Vec<Gap>;

    fn check(q: &PushProximityQuery) -> Result<(), String> {
        match *q {
            PushProximityQuery::ActivateProximity { range, interval } => {
                nonneg("range", range)?;
                nonneg("interval", interval)
            }
            PushProximityQuery::DeactivateProximity => Ok(()),
        }
    }

    fn trigger(q: &PushProximityQuery) -> Trigger {
        match *q {
            PushProximityQuery::ActivateProximity { range, interval } => Trigger::Entry {
                range,
                quiet: interval,
            },
            PushProximityQuery::DeactivateProximity => Trigger::Off,
        }
    }

    fn sense(q: &PushProximityQuery, world: &dyn WorldView) -> Vec<Gap> {
        match *q {
            // Entries are predicted without obstacles; one hidden behind an obstacle senses
            // nobody, so it does not interrupt.
            PushProximityQuery::ActivateProximity { range, .. } => gaps(world, range, true),
            PushProximityQuery::DeactivateProximity => Vec::new(),
        }
    }

    fn fires(_: &PushProximityQuery, gaps: &Vec<Gap>) -> bool {
        !gaps.is_empty()
    }

    fn reply(_: &PushProximityQuery, gaps: Vec<Gap>, _: &mut ChaCha8Rng) -> Vec<Gap> {
        gaps
    }

    fn query_text(q: &PushProximityQuery) -> Option<String> {
        Some(match *q {
            PushProximityQuery::ActivateProximity { range, interval } => format!(
                "ActivateProximity with range {} interval {}",
                num(range),
                num(interval)
            ),
            PushProximityQuery::DeactivateProximity => "DeactivateProximity".into(),
        })
    }

    fn reply_text(gaps: &Vec<Gap>) -> Option<String> {
        Some(gaps_text(gaps))
    }

    fn reach(q: &PushProximityQuery) -> Option<Reach> {
        match *q {
            PushProximityQuery::ActivateProximity { range, .. } => Some(Reach::Borders(range)),
            PushProximityQuery::DeactivateProximity => None,
        }
    }
}

/// The contact sensor: interrupts when the robot touches a robot or the world boundary.
#[derive(Debug)]
pub struct Contact;

/// Activates or deactivates the contact sensor.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "query", rename_all = "snake_case")]
pub enum ContactQuery {
    ActivateContact,
    DeactivateContact,
}

/// What the robot touched.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Touch {
    pub contact: Obstacle,
}

impl SensorModel for Contact {
    type Query = ContactQuery;
    type Reading = Option<Touch>;
    type Reply = Option<Touch>;

    fn trigger(q: &ContactQuery) -> Trigger {
        match q {
            ContactQuery::ActivateContact => Trigger::Contact,
            ContactQuery::DeactivateContact => Trigger::Off,
        }
    }

    fn sense(_: &ContactQuery, world: &dyn WorldView) -> Option<Touch> {
        world.contact().map(|contact| Touch { contact })
    }

    fn fires(_: &ContactQuery, touch: &Option<Touch>) -> bool {
        touch.is_some()
    }

    fn reply(_: &ContactQuery, touch: Option<Touch>, _: &mut ChaCha8Rng) -> Option<Touch> {
        touch
    }

    fn query_text(q: &ContactQuery) -> Option<String> {
        Some(match q {
            ContactQuery::ActivateContact => "ActivateContact".into(),
            ContactQuery::DeactivateContact => "DeactivateContact".into(),
        })
    }

    fn reply_text(touch: &Option<Touch>) -> Option<String> {
        Some(match touch {
            Some(t) => format!("contact {}", obstacle_text(t.contact)),
            None => "no contact".into(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn gps_noise_has_the_requested_spread_and_is_seeded() {
        let q = GpsQuery::SelfPosition { error: 2.0 };
        let sample = |seed| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            (0..4000)
                .map(
                    |_| match Gps::reply(&q, Fix::Position(Point::new(10.0, 0.0)), &mut rng) {
                        Fix::Position(p) => p.x - 10.0,
                        Fix::Positions(_) => unreachable!(),
                    },
                )
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

    #[test]
    fn queries_and_replies_serialize_to_the_documented_trace_forms() {
        let j = |v: serde_json::Value| v.to_string();
        let q = |v: &dyn erased::Json| v.json();
        assert_eq!(
            j(q(&GpsQuery::SelfPosition { error: 0.5 })),
            r#"{"query":"self_position","error":0.5}"#
        );
        assert_eq!(
            j(q(&ViewQuery {
                range: 3.0,
                line_of_sight: None,
            })),
            r#"{"query":"view","range":3.0}"#
        );
        assert_eq!(
            j(q(&ProximityQuery {
                range: 3.0,
                line_of_sight: None,
            })),
            r#"{"query":"proximity","range":3.0}"#
        );
        assert_eq!(
            j(q(&PushProximityQuery::ActivateProximity {
                range: 1.0,
                interval: 2.0
            })),
            r#"{"query":"activate_proximity","range":1.0,"interval":2.0}"#
        );
        assert_eq!(
            j(q(&PushProximityQuery::DeactivateProximity)),
            r#"{"query":"deactivate_proximity"}"#
        );
        assert_eq!(
            j(q(&ContactQuery::ActivateContact)),
            r#"{"query":"activate_contact"}"#
        );
        assert_eq!(
            j(q(&Fix::Positions(vec![Seen {
                robot: 2,
                pos: Point::new(1.0, -2.5)
            }]))),
            r#"[{"robot":2,"pos":[1.0,-2.5]}]"#
        );
        assert_eq!(j(q(&Fix::Position(Point::new(1.0, 2.0)))), "[1.0,2.0]");
        assert_eq!(
            j(q(&vec![Gap {
                robot: 1,
                distance: 0.25
            }])),
            r#"[{"robot":1,"distance":0.25}]"#
        );
        assert_eq!(
            j(q(&Some(Touch {
                contact: Obstacle::Robot(3)
            }))),
            r#"{"contact":3}"#
        );
        assert_eq!(
            j(q(&Some(Touch {
                contact: Obstacle::Boundary
            }))),
            r#"{"contact":"boundary"}"#
        );
    }

    mod erased {
        pub trait Json {
            fn json(&self) -> serde_json::Value;
        }
        impl<T: serde::Serialize> Json for T {
            fn json(&self) -> serde_json::Value {
                serde_json::to_value(self).unwrap()
            }
        }
    }
}
