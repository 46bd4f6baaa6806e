//! Sensors defined only in this test file (seed 4.2.2: exact data gathered at the trigger,
//! the reply computed on the robot's sensor with its seeded stream): a pull sensor and a push
//! sensor that re-senses every interval, checked against closed-form positions.

use crate::common::*;
use nekosim::algorithm::ScriptStep;
use nekosim::world::event::Notice;
use nekosim::world::observation::Observation;
use nekosim::world::sensor::{SensorKind, SensorModel, SensorValue, Sensors, Trigger, WorldView};
use nekosim::world::RobotId;
use nekosim::{Algorithm, AlgorithmFuture, Robot, SimConfig};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Pull: the nearest other robot within `range` and its centre distance, plus uniform noise
/// of at most `noise` units drawn on the robot's sensor.
#[derive(Debug)]
struct Nearest;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct NearestQuery {
    range: f64,
    noise: f64,
}

impl SensorModel for Nearest {
    type Query = NearestQuery;
    type Reading = Option<(RobotId, f64)>;
    type Reply = Option<(RobotId, f64)>;

    fn check(q: &NearestQuery) -> Result<(), String> {
        if q.range >= 0.0 {
            Ok(())
        } else {
            Err(format!("range is {}; expected >= 0", q.range))
        }
    }

    fn sense(q: &NearestQuery, world: &dyn WorldView) -> Self::Reading {
        world
            .within(q.range)
            .into_iter()
            .map(|(id, _, d)| (id, d))
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }

    fn reply(q: &NearestQuery, r: Self::Reading, rng: &mut ChaCha8Rng) -> Self::Reply {
        r.map(|(id, d)| (id, d + q.noise * (2.0 * rng.gen::<f64>() - 1.0)))
    }
}

/// Push: interrupts while at least `at_least` other robots are within `range`, re-sensing
/// every `interval` seconds; the reply is their number.
#[derive(Debug)]
struct Crowd;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct CrowdQuery {
    range: f64,
    at_least: usize,
    interval: f64,
}

impl SensorModel for Crowd {
    type Query = CrowdQuery;
    type Reading = usize;
    type Reply = usize;

    fn sense(q: &CrowdQuery, world: &dyn WorldView) -> usize {
        world.within(q.range).len()
    }

    fn reply(_: &CrowdQuery, n: usize, _: &mut ChaCha8Rng) -> usize {
        n
    }

    fn trigger(q: &CrowdQuery) -> Trigger {
        Trigger::Every(q.interval)
    }

    fn fires(q: &CrowdQuery, n: &usize) -> bool {
        *n >= q.at_least
    }
}

/// Activates Crowd, waits for its first interrupt, deactivates it, reads Nearest and logs
/// what it got.
#[derive(Debug)]
struct Lookout;

impl Algorithm for Lookout {
    fn name(&self) -> &str {
        "Lookout"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        Box::pin(async move {
            let crowd = CrowdQuery {
                range: 9.5,
                at_least: 1,
                interval: 0.5,
            };
            robot.activate::<Crowd>("Crowd", &crowd).await.unwrap();
            let n = loop {
                if let Notice::Interrupt { sensor, value } = robot.next_notice().await {
                    assert_eq!(sensor, SensorKind::named("Crowd"));
                    break value.decode::<usize>().unwrap();
                }
            };
            robot.deactivate("Crowd").await;
            let exact = robot
                .read::<Nearest>(
                    "Nearest",
                    &NearestQuery {
                        range: 50.0,
                        noise: 0.0,
                    },
                )
                .await
                .unwrap();
            let noisy = robot
                .read::<Nearest>(
                    "Nearest",
                    &NearestQuery {
                        range: 50.0,
                        noise: 0.5,
                    },
                )
                .await
                .unwrap();
            let refused = robot
                .read::<Nearest>(
                    "Nearest",
                    &NearestQuery {
                        range: -1.0,
                        noise: 0.0,
                    },
                )
                .await;
            robot.log(format!("{n} {exact:?} {noisy:?} {refused:?}"));
        })
    }
}

fn run_lookout(seed: u64) -> Vec<nekosim::world::observation::Record> {
    let mut sensors = Sensors::new();
    sensors
        .sensor::<Nearest>("Nearest")
        .sensor::<Crowd>("Crowd");
    // Drives towards robot 0 at 2 units/s: centre distance 30 - 2t until t = 12.5.
    watched_approach(sensors, seed, Box::new(Lookout), 25.0)
}

/// Robot 0 runs `watcher` at the origin; robot 1, born at (30, 0) heading to it, drives
/// `distance` units at 2 units/s. Radius 1 each, an infinite world, 60 simulated seconds.
fn watched_approach(
    sensors: Sensors,
    seed: u64,
    watcher: Box<dyn Algorithm>,
    distance: f64,
) -> Vec<nekosim::world::observation::Record> {
    nekosim::run(SimConfig {
        sensors,
        seed,
        until: 60.0,
        world: infinite(),
        robots: vec![
            (spec(0.0, 0.0, 0.0, 1.0), watcher),
            (
                spec(30.0, 0.0, 180.0, 1.0),
                script(vec![ScriptStep::Forward {
                    distance,
                    move_speed: 2.0,
                }]),
            ),
        ],
        arbiters: 1,
        record: true,
        observers: Default::default(),
        comms: Default::default(),
    })
    .expect("run")
    .records
}

#[test]
fn user_pull_and_push_sensors_read_the_exact_world_at_their_trigger() {
    let records = run_lookout(1);
    // Crowd re-senses at 0, 0.5, 1, ...: the first sense with the other robot within 9.5 is
    // at t = 10.5 (distance 30 - 21 = 9; at t = 10 it was 10).
    let interrupts: Vec<(f64, &SensorValue)> = records
        .iter()
        .filter_map(|r| match &r.obs {
            Observation::SensorReply {
                sensor,
                value,
                interrupt: true,
                ..
            } if *sensor == SensorKind::named("Crowd") => Some((r.t, value)),
            _ => None,
        })
        .collect();
    assert_eq!(interrupts.len(), 1, "{interrupts:?}");
    assert_eq!(interrupts[0].0, 10.5);
    assert_eq!(interrupts[0].1.decode::<usize>(), Ok(1));
    // Deactivated: no re-sense fires later although the robot stays within range.
    let log: Vec<(f64, &str)> = records
        .iter()
        .filter_map(|r| match &r.obs {
            Observation::Log { text, .. } => Some((r.t, text.as_str())),
            _ => None,
        })
        .collect();
    assert_eq!(log.len(), 1);
    assert_eq!(log[0].0, 10.5);
    let (n, rest) = log[0].1.split_once(' ').unwrap();
    assert_eq!(n, "1");
    assert!(
        rest.starts_with("Some((1, 9.0)) Some((1, "),
        "the exact reading is the closed-form distance: {rest}"
    );
    assert!(
        rest.ends_with(r#"Err("range is -1; expected >= 0")"#),
        "{rest}"
    );
    // The noisy reply is within its bound, and drawn from the sensor's seeded stream.
    let noisy = |records: &[nekosim::world::observation::Record]| -> f64 {
        let text = records
            .iter()
            .find_map(|r| match &r.obs {
                Observation::Log { text, .. } => Some(text.clone()),
                _ => None,
            })
            .unwrap();
        let at = text.find("Some((1, 9.0)) Some((1, ").unwrap() + "Some((1, 9.0)) Some((1, ".len();
        text[at..text[at..].find(')').unwrap() + at]
            .parse()
            .unwrap()
    };
    let (a, b, c) = (
        noisy(&records),
        noisy(&run_lookout(1)),
        noisy(&run_lookout(2)),
    );
    assert!((a - 9.0).abs() <= 0.5 && a != 9.0, "{a}");
    assert_eq!(a, b, "same seed, same noise");
    assert_ne!(a, c, "another seed, other noise");
}

/// Push on entry: interrupts at the exact instant another robot's border comes within
/// `range`, with the entering robots' free distances (the same trigger push proximity uses).
#[derive(Debug)]
struct Approach;

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
struct ApproachQuery {
    range: f64,
}

impl SensorModel for Approach {
    type Query = ApproachQuery;
    type Reading = Vec<(RobotId, f64)>;
    type Reply = Vec<(RobotId, f64)>;

    fn trigger(q: &ApproachQuery) -> Trigger {
        Trigger::Entry {
            range: q.range,
            quiet: 0.0,
        }
    }

    fn sense(q: &ApproachQuery, world: &dyn WorldView) -> Self::Reading {
        world.near(q.range)
    }

    fn fires(_: &ApproachQuery, near: &Self::Reading) -> bool {
        !near.is_empty()
    }

    fn reply(_: &ApproachQuery, near: Self::Reading, _: &mut ChaCha8Rng) -> Self::Reply {
        near
    }
}

/// Push on contact: what the robot touched and where the other robot's centre is then.
#[derive(Debug)]
struct Bumper;

impl SensorModel for Bumper {
    type Query = ();
    type Reading = Option<(nekosim::world::Obstacle, nekosim::world::geometry::Point)>;
    type Reply = Option<(nekosim::world::Obstacle, nekosim::world::geometry::Point)>;

    fn trigger(_: &()) -> Trigger {
        Trigger::Contact
    }

    fn sense(_: &(), world: &dyn WorldView) -> Self::Reading {
        world.contact().map(|o| match o {
            nekosim::world::Obstacle::Robot(r) => (o, world.position(r)),
            _ => (o, world.position(world.robot())),
        })
    }

    fn reply(_: &(), r: Self::Reading, _: &mut ChaCha8Rng) -> Self::Reply {
        r
    }
}

/// Arms both and waits.
#[derive(Debug)]
struct Guard;

impl Algorithm for Guard {
    fn name(&self) -> &str {
        "Guard"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        Box::pin(async move {
            robot
                .activate::<Approach>("Approach", &ApproachQuery { range: 4.0 })
                .await
                .unwrap();
            robot.activate::<Bumper>("Bumper", &()).await.unwrap();
            robot.sleep(100.0).await;
        })
    }
}

#[test]
fn user_push_sensors_trigger_on_exact_entries_and_contacts() {
    let mut sensors = Sensors::new();
    sensors
        .sensor::<Approach>("Approach")
        .sensor::<Bumper>("Bumper");
    // Towards robot 0 at 2 units/s: free distance 28 - 2t, contact at t = 14.
    let records = watched_approach(sensors, 1, Box::new(Guard), 40.0);
    let interrupts: Vec<(f64, SensorKind, &SensorValue)> = records
        .iter()
        .filter_map(|r| match &r.obs {
            Observation::SensorReply {
                robot: 0,
                sensor,
                value,
                interrupt: true,
            } => Some((r.t, *sensor, value)),
            _ => None,
        })
        .collect();
    assert_eq!(interrupts.len(), 2, "{interrupts:?}");
    // Free distance 4 when robot 1 has come 24 units: t = 12.
    let (t, sensor, value) = interrupts[0];
    assert_eq!(sensor, SensorKind::named("Approach"));
    assert!((t - 12.0).abs() < 1e-9, "entry at {t}");
    let near = value.decode::<Vec<(RobotId, f64)>>().unwrap();
    assert_eq!(near.len(), 1);
    assert_eq!(near[0].0, 1);
    assert!((near[0].1 - 4.0).abs() < 1e-9, "{near:?}");
    // Contact when the centres are 2 apart: robot 1's centre at (2, 0), t = 14.
    let (t, sensor, value) = interrupts[1];
    assert_eq!(sensor, SensorKind::named("Bumper"));
    assert!((t - 14.0).abs() < 1e-9, "contact at {t}");
    let (with, at) = value
        .decode::<Option<(nekosim::world::Obstacle, nekosim::world::geometry::Point)>>()
        .unwrap()
        .unwrap();
    assert_eq!(with, nekosim::world::Obstacle::Robot(1));
    assert!((at - nekosim::world::geometry::Point::new(2.0, 0.0)).norm() < 1e-9);
}
