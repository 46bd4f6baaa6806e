//! Virtual time jumps from event to event: a long simulated horizon costs only its events.

use std::time::Instant;

use crate::common::*;
use nekosim::algorithm::ScriptStep;
use nekosim::world::observation::Observation;

#[test]
fn a_billion_simulated_seconds_take_well_under_a_wall_clock_second() {
    // The wall clock is read here, in the test, only to show the engine never waits on it.
    let started = Instant::now();
    let out = run(
        infinite(),
        2e9,
        vec![
            (
                spec(0.0, 0.0, 0.0, 1.0),
                script(vec![
                    ScriptStep::Wait(1e8),
                    ScriptStep::Forward {
                        distance: 100.0,
                        move_speed: 1e-7,
                    },
                    ScriptStep::Turn {
                        angle: 180.0,
                        turn_speed: 1e-6,
                    },
                ]),
            ),
            (spec(0.0, 50.0, 0.0, 1.0), idle()),
        ],
    );
    let wall = started.elapsed().as_secs_f64();
    assert!(wall < 1.0, "took {wall} s of wall-clock time");
    let last = out.records.last().unwrap();
    // 1e8 s waiting, 1e9 s moving, 1.8e8 s turning.
    assert!((last.t - 1.28e9).abs() < 1e-3, "{}", last.t);
    assert_eq!(out.stats.end_time, last.t);
    assert!(matches!(last.obs, Observation::MotionFinish { .. }));
    assert!(out.stats.events < 1_000, "{} events", out.stats.events);
}

/// An algorithm that panics at its second handling.
#[derive(Debug)]
struct Faulty;

impl nekosim::Algorithm for Faulty {
    fn name(&self) -> &str {
        "Faulty"
    }
    fn run(&self, robot: nekosim::Robot) -> nekosim::AlgorithmFuture {
        Box::pin(async move {
            robot.sleep(2.0).await;
            panic!("a bug in the user's algorithm");
        })
    }
}

/// A robot whose handling panics never answers its event: the run ends there with
/// `NoAnswer` for that robot (the records up to then kept), on every number of arbiters,
/// instead of waiting for the reply forever.
#[test]
fn a_panicking_algorithm_ends_the_run_instead_of_hanging_it() {
    assert_no_answer_from_robot_1(|| Box::new(Faulty));
}

/// Runs an idle robot 0 and robot 1 with the algorithm `faulty` makes, on 1 and 2 arbiters;
/// asserts each run ends with `NoAnswer` from robot 1 (within a minute, not hanging).
fn assert_no_answer_from_robot_1(faulty: fn() -> Box<dyn nekosim::Algorithm>) {
    for arbiters in [1, 2] {
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            let out = nekosim::run(nekosim::SimConfig {
                sensors: Default::default(),
                seed: 1,
                until: 10.0,
                world: infinite(),
                robots: vec![
                    (spec(0.0, 0.0, 0.0, 1.0), idle()),
                    (spec(10.0, 0.0, 0.0, 1.0), faulty()),
                ],
                arbiters,
                record: true,
                observers: Default::default(),
                comms: Default::default(),
            });
            let _ = tx.send(out.map(|o| o.stats));
        });
        let out = rx
            .recv_timeout(std::time::Duration::from_secs(60))
            .expect("the run ended");
        match out {
            Err(nekosim::SimError::Stopped(nekosim::scheduler::RunFailure::NoAnswer {
                target,
                ..
            })) => assert_eq!(target, "Robot(1)"),
            other => panic!("expected NoAnswer from robot 1, got {other:?}"),
        }
    }
}

/// An algorithm that panics when its first motion ends: the motion manager's handling of the
/// end notifies the robot at that instant, so the notice is passed on to the robot.
#[derive(Debug)]
struct FaultyAfterMoving;

impl nekosim::Algorithm for FaultyAfterMoving {
    fn name(&self) -> &str {
        "FaultyAfterMoving"
    }
    fn run(&self, robot: nekosim::Robot) -> nekosim::AlgorithmFuture {
        Box::pin(async move {
            let forward = nekosim::world::motion::Motion::Forward {
                distance: 2.0,
                move_speed: 1.0,
            };
            let t = robot.start_motion_at(1.0, forward, None);
            robot.wait_motion(t).await;
            panic!("a bug in the user's algorithm");
        })
    }
}

/// A robot that panics in a handling passed on to it from another actor's (here the motion
/// manager's) is named as the actor that did not answer, on every number of arbiters.
#[test]
fn a_panic_in_a_delivery_passed_on_names_the_robot() {
    assert_no_answer_from_robot_1(|| Box::new(FaultyAfterMoving));
}

/// Asks at t = 0 for a 10-unit forward motion at 2 units/s to start at t = 5, with a note to
/// write as it starts, then waits for its end.
#[derive(Debug, Clone)]
struct AskAhead;

impl nekosim::Algorithm for AskAhead {
    fn name(&self) -> &str {
        "AskAhead"
    }
    fn run(&self, robot: nekosim::Robot) -> nekosim::AlgorithmFuture {
        Box::pin(async move {
            let note = Observation::Log {
                robot: robot.id(),
                text: "off".into(),
            };
            let forward = nekosim::world::motion::Motion::Forward {
                distance: 10.0,
                move_speed: 2.0,
            };
            let t = robot.start_motion_at(5.0, forward, Some(note));
            robot.wait_motion(t).await;
        })
    }
}

/// A motion asked for ahead of time starts at its instant, its note written then and in
/// front of the motion's own records, the robot not woken before its end; a robot that
/// crashes before the instant neither moves nor writes the note.
#[test]
fn a_motion_asked_ahead_starts_at_its_instant_and_not_after_a_crash() {
    let mut cfg = nekosim::SimConfig {
        sensors: Default::default(),
        seed: 1,
        until: 20.0,
        world: infinite(),
        robots: vec![
            (spec(0.0, 0.0, 0.0, 1.0), Box::new(AskAhead)),
            (spec(0.0, 50.0, 0.0, 1.0), Box::new(AskAhead)),
        ],
        arbiters: 1,
        record: true,
        observers: Default::default(),
        comms: Default::default(),
    };
    cfg.comms.faults = vec![nekosim::Fault::Crash { robot: 1, at: 3.0 }];
    let out = nekosim::run(cfg).expect("run");
    let of = |robot: u32| -> Vec<(f64, &Observation)> {
        (out.records.iter())
            .filter(|r| r.obs.robot() == robot)
            .map(|r| (r.t, &r.obs))
            .collect()
    };
    let zero = of(0);
    let off = zero
        .iter()
        .position(|(_, o)| matches!(o, Observation::Log { text, .. } if text == "off"))
        .expect("robot 0's note");
    assert_eq!(zero[off].0, 5.0, "the note is written as the motion starts");
    assert!(
        matches!(zero[off + 1], (t, Observation::MotionRequest { .. }) if t == 5.0),
        "{:?}",
        zero.get(off + 1)
    );
    let finish = zero
        .iter()
        .find_map(|(t, o)| match o {
            Observation::MotionFinish { state, .. } => Some((*t, state.pos)),
            _ => None,
        })
        .expect("robot 0's motion ends");
    assert_eq!(finish.0, 10.0);
    assert!(
        (finish.1 - nekosim::world::geometry::Point::new(10.0, 0.0)).norm() < 1e-9,
        "{:?}",
        finish.1
    );
    let one = of(1);
    assert!(
        one.iter().all(|(_, o)| !matches!(
            o,
            Observation::Log { .. } | Observation::MotionRequest { .. }
        )),
        "{one:?}"
    );
    assert!(one
        .iter()
        .any(|(t, o)| *t == 3.0 && matches!(o, Observation::Crash { .. })));
}
