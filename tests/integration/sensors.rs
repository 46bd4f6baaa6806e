//! Sensors answer with the exact state at their trigger time, computed here independently from
//! the motion formulas (seed eq. 4.1-4.6); push sensors fire at the exact entry and contact
//! instants.

use std::cell::RefCell;
use std::rc::Rc;

use crate::common::*;
use nekosim::algorithm::ScriptStep;
use nekosim::world::event::Notice;
use nekosim::world::geometry::Point;
use nekosim::world::observation::Observation;
use nekosim::world::sensor::builtins::{Fix, Gap, Seen as Sighting, Touch};
use nekosim::world::sensor::SensorKind;
use nekosim::world::Obstacle;
use nekosim::{Algorithm, AlgorithmFuture, Robot};

#[derive(Debug, Clone)]
struct Asker {
    at: f64,
}

impl Algorithm for Asker {
    fn name(&self) -> &str {
        "Asker"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let at = self.at;
        Box::pin(async move {
            robot.sleep(at).await;
            robot.gps().self_position(0.0).await;
            robot.gps().all_positions(0.0).await;
            robot.robots_in_view(30.0).await;
            robot.proximity(10.0).await;
            robot.gps().self_position(1.0).await;
        })
    }
}

/// Robot 1's MOVETO from (20, 0) facing 0° to (40, 30) at 2 units/s and 45°/s, by hand.
fn robot1_at(t: f64) -> Point {
    let turn = 30f64.atan2(20.0).to_degrees();
    let t_turned = turn / 45.0;
    let s = 2.0 * (t - t_turned).max(0.0);
    let u = (Point::new(40.0, 30.0) - Point::new(20.0, 0.0)).normalize();
    Point::new(20.0, 0.0) + u * s
}

#[test]
fn pull_sensors_report_the_exact_state_at_reply_time() {
    let at = 3.7;
    let out = run(
        infinite(),
        100.0,
        vec![
            (spec(0.0, 0.0, 0.0, 1.0), Box::new(Asker { at })),
            (
                spec(20.0, 0.0, 0.0, 1.0),
                script(vec![ScriptStep::MoveTo {
                    x: 40.0,
                    y: 30.0,
                    move_speed: 2.0,
                    turn_speed: 45.0,
                }]),
            ),
            (spec(5.0, 5.0, 0.0, 1.0), idle()),
        ],
    );
    let replies: Vec<_> = out
        .records
        .iter()
        .filter_map(|r| match &r.obs {
            Observation::SensorReply {
                robot: 0,
                value,
                sensor,
                interrupt: false,
            } => Some((r.t, *sensor, value.clone())),
            _ => None,
        })
        .collect();
    assert_eq!(replies.len(), 5, "{replies:?}");
    assert!(replies.iter().all(|(t, _, _)| *t == at));
    let p1 = robot1_at(at);
    let close = |a: Point, b: Point| (a - b).norm() < 1e-9;
    let pairs = |ps: &[Sighting]| ps.iter().map(|s| (s.robot, s.pos)).collect::<Vec<_>>();
    match &replies[0] {
        (_, SensorKind::GPS, v) => match v.get::<Fix>() {
            Some(Fix::Position(p)) => assert!(close(*p, Point::new(0.0, 0.0))),
            other => panic!("{other:?}"),
        },
        other => panic!("{other:?}"),
    }
    match replies[1].2.get::<Fix>() {
        Some(Fix::Positions(ps)) => {
            let ps = pairs(ps);
            assert_eq!(ps.iter().map(|p| p.0).collect::<Vec<_>>(), vec![0, 1, 2]);
            assert!(close(ps[1].1, p1), "{:?} vs {p1:?}", ps[1].1);
            assert!(close(ps[2].1, Point::new(5.0, 5.0)));
        }
        other => panic!("{other:?}"),
    }
    match &replies[2] {
        (_, SensorKind::VIEW, v) if v.get::<Vec<Sighting>>().is_some() => {
            let ps = pairs(v.get::<Vec<Sighting>>().unwrap());
            assert_eq!(ps.len(), 2);
            assert!(close(ps[0].1, p1) && close(ps[1].1, Point::new(5.0, 5.0)));
        }
        other => panic!("{other:?}"),
    }
    match &replies[3] {
        (_, SensorKind::PROXIMITY, v) if v.get::<Vec<Gap>>().is_some() => {
            let ds: Vec<_> = v
                .get::<Vec<Gap>>()
                .unwrap()
                .iter()
                .map(|g| (g.robot, g.distance))
                .collect();
            assert_eq!(ds.len(), 1);
            assert_eq!(ds[0].0, 2);
            assert!((ds[0].1 - (50f64.sqrt() - 2.0)).abs() < 1e-9);
        }
        other => panic!("{other:?}"),
    }
    match replies[4].2.get::<Fix>() {
        Some(Fix::Position(p)) => {
            let e = (p - Point::new(0.0, 0.0)).norm();
            assert!(e > 0.0 && e < 8.0, "noisy GPS off by {e}");
        }
        other => panic!("{other:?}"),
    }
}

type Seen = Rc<RefCell<Vec<(f64, Notice)>>>;

/// Robots run on the test's own thread (one arbiter), so a thread-local collects what the
/// watching algorithm was told, with the virtual time it was told it.
#[derive(Debug, Clone)]
struct WatcherCfg;

impl Algorithm for WatcherCfg {
    fn name(&self) -> &str {
        "Watcher"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let seen = WATCHED.with(|s| s.clone());
        Box::pin(async move {
            robot.activate_proximity(5.0, 0.0).await;
            robot.activate_contact().await;
            for _ in 0..2 {
                let n = robot.next_notice().await;
                seen.borrow_mut().push((robot.now(), n));
            }
        })
    }
}

thread_local! {
    static WATCHED: Seen = Rc::new(RefCell::new(Vec::new()));
}

#[test]
fn push_proximity_fires_at_entry_and_contact_at_collision() {
    WATCHED.with(|s| s.borrow_mut().clear());
    let out = run(
        infinite(),
        100.0,
        vec![
            (spec(0.0, 0.0, 0.0, 1.0), Box::new(WatcherCfg)),
            (
                spec(50.0, 0.0, 180.0, 1.0),
                script(vec![ScriptStep::Forward {
                    distance: 100.0,
                    move_speed: 2.0,
                }]),
            ),
        ],
    );
    let seen = WATCHED.with(|s| s.borrow().clone());
    assert_eq!(seen.len(), 2, "{seen:?}");
    // Free distance 5 means centres 7 apart: 43 units at 2 units/s.
    let (t, n) = &seen[0];
    assert!((t - 21.5).abs() < 1e-9, "entry at {t}");
    match n {
        Notice::Interrupt {
            sensor: SensorKind::PUSH_PROXIMITY,
            value,
        } if value.get::<Vec<Gap>>().is_some() => {
            let d = value.get::<Vec<Gap>>().unwrap();
            assert_eq!(d.len(), 1);
            assert!((d[0].distance - 5.0).abs() < 1e-9);
        }
        other => panic!("{other:?}"),
    }
    // Contact when the centres are 2 apart: 48 units.
    let (t, n) = &seen[1];
    assert!((t - 24.0).abs() < 1e-9, "contact at {t}");
    match n {
        Notice::Interrupt {
            sensor: SensorKind::CONTACT,
            value,
        } => assert_eq!(
            value.decode::<Option<Touch>>(),
            Ok(Some(Touch {
                contact: Obstacle::Robot(1)
            }))
        ),
        other => panic!("{other:?}"),
    }
    assert_eq!(
        out.records
            .iter()
            .filter(|r| matches!(r.obs, Observation::Collision { .. }))
            .count(),
        1
    );
}

thread_local! {
    static LATE: Seen = Rc::new(RefCell::new(Vec::new()));
}

/// Arms a proximity sensor (free distance 5) only at t = 10, then waits for two notices.
#[derive(Debug, Clone)]
struct LateWatcher;

impl Algorithm for LateWatcher {
    fn name(&self) -> &str {
        "LateWatcher"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let seen = LATE.with(|s| s.clone());
        Box::pin(async move {
            robot.sleep(10.0).await;
            robot.activate_proximity(5.0, 0.0).await;
            for _ in 0..2 {
                let n = robot.next_notice().await;
                seen.borrow_mut().push((robot.now(), n));
            }
        })
    }
}

/// In ghost mode robots pass through each other, so entries are the only events two robots
/// can have: a sensor armed late still sees a robot that was already moving towards it when
/// it was armed, and one that starts moving later, each at the instant the motion formulas
/// give.
#[test]
fn push_proximity_armed_late_in_ghost_mode_sees_robots_moving_before_and_after() {
    LATE.with(|s| s.borrow_mut().clear());
    let mut world = infinite();
    world.ghost_mode = true;
    run(
        world,
        100.0,
        vec![
            (spec(0.0, 0.0, 0.0, 1.0), Box::new(LateWatcher)),
            // Moving towards the watcher from t = 0: centres 7 apart after 43 units.
            (
                spec(50.0, 0.0, 180.0, 1.0),
                script(vec![ScriptStep::Forward {
                    distance: 100.0,
                    move_speed: 2.0,
                }]),
            ),
            // Sets off at t = 30 from 60 units below: centres 7 apart after 53 units.
            (
                spec(0.0, -60.0, 90.0, 1.0),
                script(vec![
                    ScriptStep::Wait(30.0),
                    ScriptStep::Forward {
                        distance: 100.0,
                        move_speed: 2.0,
                    },
                ]),
            ),
        ],
    );
    let seen = LATE.with(|s| s.borrow().clone());
    assert_eq!(seen.len(), 2, "{seen:?}");
    for ((t, n), (want_t, want_robot)) in seen.iter().zip([(21.5, 1), (56.5, 2)]) {
        assert!((t - want_t).abs() < 1e-9, "entry of {want_robot} at {t}");
        match n {
            Notice::Interrupt {
                sensor: SensorKind::PUSH_PROXIMITY,
                value,
            } => {
                let gaps = value.get::<Vec<Gap>>().expect("gaps");
                assert_eq!(gaps.len(), 1, "{gaps:?}");
                assert_eq!(gaps[0].robot, want_robot);
                assert!((gaps[0].distance - 5.0).abs() < 1e-9);
            }
            other => panic!("{other:?}"),
        }
    }
}

#[test]
fn push_proximity_reports_robots_already_in_range_at_activation_and_re_entries() {
    WATCHED.with(|s| s.borrow_mut().clear());
    run(
        infinite(),
        100.0,
        vec![
            (spec(0.0, 0.0, 0.0, 1.0), Box::new(WatcherCfg)),
            // Starts 4 apart (free distance 2), leaves along +y, then comes back.
            (
                spec(0.0, 4.0, 90.0, 1.0),
                script(vec![
                    ScriptStep::Forward {
                        distance: 20.0,
                        move_speed: 1.0,
                    },
                    ScriptStep::Turn {
                        angle: 180.0,
                        turn_speed: 90.0,
                    },
                    ScriptStep::Forward {
                        distance: 20.0,
                        move_speed: 1.0,
                    },
                ]),
            ),
        ],
    );
    let seen = WATCHED.with(|s| s.borrow().clone());
    assert_eq!(seen.len(), 2, "{seen:?}");
    assert_eq!(seen[0].0, 0.0);
    // Back within free distance 5 (centres 7 apart): at y = 7 on the way down, after
    // 20 s up, 2 s turning and 17 s down.
    assert!((seen[1].0 - 39.0).abs() < 1e-9, "{}", seen[1].0);
}
