//! Conditional events (seed 4.3.3): a predicted collision is cancelled when a robot changes
//! its path before it.

use crate::common::*;
use nekosim::world::geometry::Point;
use nekosim::world::motion::Motion;
use nekosim::world::observation::Observation;
use nekosim::world::MotionOutcome;
use nekosim::{Algorithm, AlgorithmFuture, Robot};

/// Starts forward at 1 unit/s, then after `react` seconds does `then` (replacing the motion).
#[derive(Debug, Clone)]
struct Swerve {
    react: Option<f64>,
    then: Option<Motion>,
}

impl Algorithm for Swerve {
    fn name(&self) -> &str {
        "Swerve"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let me = self.clone();
        Box::pin(async move {
            let first = robot.start_motion(Motion::Forward {
                distance: 100.0,
                move_speed: 1.0,
            });
            match me.react {
                None => {
                    robot.wait_motion(first).await;
                }
                Some(d) => {
                    robot.sleep(d).await;
                    if let Some(m) = me.then {
                        let end = robot.motion(m).await;
                        assert_ne!(end.outcome, MotionOutcome::Replaced);
                    }
                    let replaced = robot.wait_motion(first).await;
                    assert_eq!(replaced.outcome, MotionOutcome::Replaced);
                }
            }
        })
    }
}

fn scenario(react: Option<f64>, then: Option<Motion>) -> nekosim::scheduler::RunOutput {
    run(
        infinite(),
        500.0,
        vec![
            (spec(0.0, 0.0, 0.0, 1.0), Box::new(Swerve { react, then })),
            (spec(50.0, 0.0, 0.0, 1.0), idle()),
        ],
    )
}

fn collisions(out: &nekosim::scheduler::RunOutput) -> Vec<f64> {
    out.records
        .iter()
        .filter(|r| matches!(r.obs, Observation::Collision { .. }))
        .map(|r| r.t)
        .collect()
}

#[test]
fn the_collision_happens_when_nobody_reacts() {
    let out = scenario(None, None);
    assert_eq!(collisions(&out), vec![48.0]);
}

#[test]
fn turning_away_cancels_the_predicted_collision() {
    let out = scenario(
        Some(10.0),
        Some(Motion::Turn {
            angle: 90.0,
            turn_speed: 45.0,
        }),
    );
    assert!(collisions(&out).is_empty());
    assert!(
        out.stats.cancelled >= 1,
        "the predicted collision was cancelled, not just skipped"
    );
    // The robot stands where it stopped, 10 units along, facing up.
    let last = out.records.iter().rev().find_map(|r| match &r.obs {
        Observation::MotionFinish {
            robot: 0, state, ..
        } => Some(*state),
        _ => None,
    });
    let s = last.unwrap();
    assert!((s.pos - Point::new(10.0, 0.0)).norm() < 1e-12 && (s.angle - 90.0).abs() < 1e-9);
}

#[test]
fn stopping_short_cancels_the_predicted_collision_and_a_later_push_collides_on_time() {
    // Replace the long forward by a short one that ends 10 units before contact.
    let out = scenario(
        Some(10.0),
        Some(Motion::Forward {
            distance: 28.0,
            move_speed: 1.0,
        }),
    );
    assert!(collisions(&out).is_empty());
    // Replacing it by a faster forward moves the collision earlier: 10 + 38 / 2.
    let out = scenario(
        Some(10.0),
        Some(Motion::Forward {
            distance: 100.0,
            move_speed: 2.0,
        }),
    );
    assert_eq!(collisions(&out), vec![29.0]);
}

#[derive(Debug)]
struct Lookahead;

impl Algorithm for Lookahead {
    fn name(&self) -> &str {
        "Lookahead"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        Box::pin(async move {
            robot.start_motion(Motion::Forward {
                distance: 100.0,
                move_speed: 1.0,
            });
            let events = robot.future_events().await;
            // The event manager lists the predicted collision and the motion's finish.
            let collision = events
                .iter()
                .find(|e| e.kind == "collision")
                .expect("collision listed");
            assert_eq!(collision.time, 48.0);
            assert_eq!(
                collision.class,
                nekosim::world::event::EventClass::Conditional
            );
            assert!(events
                .iter()
                .any(|e| e.kind == "motion_step" && e.time == 100.0));
            assert!(events.windows(2).all(|w| w[0].time <= w[1].time));
            // Seeing it coming, stop short: the collision is cancelled.
            robot
                .motion(Motion::Forward {
                    distance: 10.0,
                    move_speed: 1.0,
                })
                .await;
            assert!(robot
                .future_events()
                .await
                .iter()
                .all(|e| e.kind != "collision"));
        })
    }
}

#[test]
fn an_algorithm_can_list_its_future_events_and_avoid_a_predicted_collision() {
    // Collisions are predicted once robots are in neighbouring cells of the spatial index;
    // wide cells make the prediction immediate here.
    let mut world = infinite();
    world.cell_size = Some(100.0);
    let out = run(
        world,
        500.0,
        vec![
            (spec(0.0, 0.0, 0.0, 1.0), Box::new(Lookahead)),
            (spec(50.0, 0.0, 0.0, 1.0), idle()),
        ],
    );
    assert!(collisions(&out).is_empty());
    // The algorithm's assertions ran to the end: its last motion finished.
    assert!(out.records.iter().any(|r| matches!(
        &r.obs,
        Observation::MotionFinish {
            robot: 0,
            outcome: MotionOutcome::Arrived,
            ..
        }
    ) && r.t == 10.0));
}

/// Lists another robot's future events and writes what it saw to the log.
#[derive(Debug)]
struct Watcher;

impl Algorithm for Watcher {
    fn name(&self) -> &str {
        "Watcher"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        Box::pin(async move {
            robot.sleep(1.0).await;
            let events = robot.future_events_of(0).await;
            let arrival = events
                .iter()
                .find(|e| e.kind == "motion_step" && e.robots[0] == Some(0))
                .map(|e| e.time);
            let mine = events.iter().filter(|e| e.robots[0] == Some(1)).count();
            robot.log(format!(
                "robot 0 arrives at {arrival:?}; {mine} events of mine"
            ));
        })
    }
}

#[test]
fn an_algorithm_can_list_another_robots_future_events_and_log_what_it_saw() {
    let out = run(
        infinite(),
        100.0,
        vec![
            (
                spec(0.0, 0.0, 0.0, 1.0),
                script(vec![nekosim::algorithm::ScriptStep::Forward {
                    distance: 100.0,
                    move_speed: 2.0,
                }]),
            ),
            (spec(0.0, 50.0, 0.0, 1.0), Box::new(Watcher)),
        ],
    );
    // Robot 0 moves 100 units at 2 units/s from t = 0: its motion ends at t = 50.
    let logs: Vec<(f64, u32, &str)> = out
        .records
        .iter()
        .filter_map(|r| match &r.obs {
            Observation::Log { robot, text } => Some((r.t, *robot, text.as_str())),
            _ => None,
        })
        .collect();
    assert_eq!(
        logs,
        vec![(1.0, 1, "robot 0 arrives at Some(50.0); 0 events of mine")]
    );
    let log = out
        .records
        .iter()
        .find(|r| matches!(r.obs, Observation::Log { .. }))
        .unwrap();
    assert_eq!(
        nekosim::log::NekoLog::new().line(log).unwrap(),
        "1.000 p1 Info: robot 0 arrives at Some(50.0); 0 events of mine"
    );
    let json = nekosim::trace::to_json(log);
    assert_eq!(json["kind"], "log");
    assert_eq!(json["robot"], 1);
    assert_eq!(
        json["text"],
        "robot 0 arrives at Some(50.0); 0 events of mine"
    );
}

/// Starts a MOVETO and lists its own future events at once, logging its motion's steps.
#[derive(Debug)]
struct ListsItsSteps;

impl Algorithm for ListsItsSteps {
    fn name(&self) -> &str {
        "ListsItsSteps"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        Box::pin(async move {
            robot.start_motion(Motion::MoveTo {
                dest: Point::new(0.0, 10.0),
                move_speed: 1.0,
                turn_speed: 45.0,
            });
            let listed: Vec<String> = robot
                .future_events()
                .await
                .iter()
                .filter(|e| e.kind == "motion_step")
                .map(|e| format!("{}@{}", e.kind, e.time))
                .collect();
            robot.log(listed.join(" "));
        })
    }
}

#[test]
fn a_listing_and_the_trace_show_each_step_of_a_motion_also_those_at_one_instant() {
    // A quarter turn at 45 deg/s (2 s), then 10 units at 1 unit/s: the finish-turn and the
    // start-forward happen at t = 2, and the queue keeps them as one event.
    let out = run(
        infinite(),
        100.0,
        vec![(spec(0.0, 0.0, 0.0, 1.0), Box::new(ListsItsSteps))],
    );
    assert_eq!(
        log_texts(&out),
        vec!["motion_step@0 motion_step@2 motion_step@2 motion_step@12"]
    );
    let steps: Vec<(f64, u64, &str)> = out
        .records
        .iter()
        .filter_map(|r| match &r.obs {
            Observation::MotionStep { step, .. } => Some((r.t, r.seq, step.name())),
            _ => None,
        })
        .collect();
    let kinds: Vec<(f64, &str)> = steps.iter().map(|s| (s.0, s.2)).collect();
    assert_eq!(
        kinds,
        vec![
            (0.0, "start_turn"),
            (2.0, "finish_turn"),
            (2.0, "start_forward"),
            (12.0, "finish_forward")
        ]
    );
    // Nothing comes between the two steps at t = 2.
    assert_eq!(steps[2].1, steps[1].1 + 1);
    assert!(out.records.iter().any(|r| r.t == 12.0
        && matches!(
            r.obs,
            Observation::MotionFinish {
                outcome: MotionOutcome::Arrived,
                ..
            }
        )));
}
