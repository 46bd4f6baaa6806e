//! Composable behaviours (actors/src/behaviour.rs, docs/behaviours.md): the seed's examples as
//! compositions trace exactly as the built-ins, and each combinator does what it says, checked
//! against closed-form expectations on the recorded trace.

use std::process::Command;

use crate::common::*;
use nekosim::algorithm::{Gathering, RandomMovement};
use nekosim::behaviour::{Behaviour, Condition};
use nekosim::scheduler::RunOutput;
use nekosim::world::geometry::{vector_heading, Point};
use nekosim::world::observation::{Observation, Record};
use nekosim::world::MotionOutcome;
use nekosim::{Algorithm, AlgorithmFuture, Robot};

fn nekosim(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_nekosim"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(args)
        .output()
        .expect("nekosim runs")
}

/// The trace of `file` run by the `nekosim` command.
fn trace_of(file: &str) -> Vec<u8> {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("t.jsonl");
    let o = nekosim(&["run", file, "--trace", trace.to_str().unwrap()]);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{file}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    std::fs::read(trace).unwrap()
}

#[test]
fn the_seeds_examples_as_compositions_trace_byte_identically_to_the_built_ins() {
    for name in ["random_movement", "gathering"] {
        let built_in = trace_of(&format!("examples/scenarios/{name}.ron"));
        let composed = trace_of(&format!("examples/behaviours/{name}.ron"));
        let requests = String::from_utf8_lossy(&built_in)
            .matches("\"kind\":\"motion_request\"")
            .count();
        assert!(requests >= 50, "{name}: only {requests} motion requests");
        assert!(built_in == composed, "{name}: the traces differ");
    }
}

/// Motions that ended at the instant they were requested (other than by a newer request).
fn zero_time_moves(records: &[Record]) -> usize {
    let mut asked: std::collections::HashMap<u32, f64> = Default::default();
    let mut n = 0;
    for r in records {
        match &r.obs {
            Observation::MotionRequest { robot, .. } => {
                asked.insert(*robot, r.t);
            }
            Observation::MotionFinish { robot, outcome, .. }
                if *outcome != MotionOutcome::Replaced && asked.get(robot) == Some(&r.t) =>
            {
                n += 1
            }
            _ => {}
        }
    }
    n
}

/// A 5 × 5 crowd of touching-close robots in a 60 × 60 box, every robot running `algorithm`.
fn crowd(algorithm: impl Fn() -> Box<dyn Algorithm>) -> RunOutput {
    let robots = (0..25)
        .map(|k| {
            let (i, j) = ((k % 5) as f64, (k / 5) as f64);
            (spec(8.0 + 11.0 * i, 8.0 + 11.0 * j, 0.0, 5.0), algorithm())
        })
        .collect();
    run(bounded(60.0, 60.0), 60.0, robots)
}

#[test]
fn compositions_equal_the_built_ins_in_a_crowd_where_moves_collide_or_take_no_time() {
    // In a crowd, moves keep ending in collisions: the same draws, the same requests.
    let built_in = crowd(|| Box::new(RandomMovement::default()));
    let composed = crowd(|| Box::new(Behaviour::wander().forever()));
    let collisions = (built_in.records.iter())
        .filter(|r| matches!(r.obs, Observation::Collision { .. }))
        .count();
    assert!(collisions > 10, "{collisions}");
    assert!(built_in.records == composed.records);

    // Gathered robots touch and face the centroid: many moves take no time and both wait
    // `retry`.
    let built_in = crowd(|| Box::new(Gathering::default()));
    let composed = crowd(|| Box::new(Behaviour::go_to_centroid().forever()));
    assert!(zero_time_moves(&built_in.records) > 10);
    assert!(built_in.records == composed.records);
}

fn of(records: &[Record], robot: u32) -> Vec<&Record> {
    records.iter().filter(|r| r.obs.robot() == robot).collect()
}

/// A motion request: when, which pattern, its parameters.
type Asked = (f64, String, Vec<(String, f64)>);

fn requests(records: &[&Record]) -> Vec<Asked> {
    records
        .iter()
        .filter_map(|r| match &r.obs {
            Observation::MotionRequest { motion, .. } => {
                Some((r.t, motion.name().to_string(), motion.params()))
            }
            _ => None,
        })
        .collect()
}

fn finishes(records: &[&Record]) -> Vec<(f64, MotionOutcome, Point, f64)> {
    records
        .iter()
        .filter_map(|r| match &r.obs {
            Observation::MotionFinish { outcome, state, .. } => {
                Some((r.t, outcome.clone(), state.pos, state.angle))
            }
            _ => None,
        })
        .collect()
}

/// The sensor requests' JSON (`{"query": ...}`) with their instants.
fn sensor_requests(records: &[&Record]) -> Vec<(f64, String)> {
    records
        .iter()
        .filter(|r| matches!(r.obs, Observation::SensorRequest { .. }))
        .map(|r| (r.t, serde_json::to_string(&r.obs).unwrap()))
        .collect()
}

fn alone(b: Behaviour, until: f64) -> RunOutput {
    run(
        infinite(),
        until,
        vec![(spec(0.0, 0.0, 0.0, 1.0), Box::new(b))],
    )
}

#[test]
fn race_cancels_the_losing_motion_at_the_winners_instant() {
    // Along +x at 1 unit/s (no turn): the wait wins at t = 2 and the move stops at (2, 0).
    let out = alone(
        Behaviour::Wait(2.0).race(Behaviour::go_to(100.0, 0.0, 1.0, 90.0)),
        50.0,
    );
    let mine = of(&out.records, 0);
    let asked = requests(&mine);
    assert_eq!(asked.len(), 2, "{asked:?}");
    assert_eq!((asked[0].0, asked[0].1.as_str()), (0.0, "move_to"));
    // The stop: a zero-length forward at the winner's instant.
    assert_eq!((asked[1].0, asked[1].1.as_str()), (2.0, "forward"));
    assert_eq!(asked[1].2[0], ("distance".to_string(), 0.0));
    let ends = finishes(&mine);
    assert_eq!(ends[0].0, 2.0);
    assert_eq!(ends[0].1, MotionOutcome::Replaced);
    assert!((ends[0].2 - Point::new(2.0, 0.0)).norm() < 1e-9, "{ends:?}");
    // Nothing moves after.
    let path = &trajectories(&out.records)[0];
    assert_eq!(pos_at(path, 2.0), pos_at(path, 50.0));

    // Cancelling a branch cancels what runs inside it: here an Until whose body moves and
    // whose condition senses; both stop at the winner's instant.
    let out = alone(
        Behaviour::Wait(2.0)
            .race(Behaviour::go_to(100.0, 0.0, 1.0, 90.0).until(Condition::Proximity(1.0))),
        50.0,
    );
    let mine = of(&out.records, 0);
    let asked = requests(&mine);
    assert_eq!(asked.len(), 2, "{asked:?}");
    assert_eq!((asked[1].0, asked[1].1.as_str()), (2.0, "forward"));
    assert_eq!(finishes(&mine)[0].0, 2.0);
    assert_eq!(finishes(&mine)[0].1, MotionOutcome::Replaced);
    let sensed = sensor_requests(&mine);
    assert_eq!(sensed.len(), 2, "{sensed:?}");
    assert!(sensed[1].1.contains("deactivate_proximity") && sensed[1].0 == 2.0);

    // The motion wins at t = 3: the losing condition's push sensor is switched off then.
    let out = alone(
        Behaviour::go_to(3.0, 0.0, 1.0, 90.0).until(Condition::Proximity(1.0)),
        50.0,
    );
    let mine = of(&out.records, 0);
    let sensed = sensor_requests(&mine);
    assert_eq!(sensed.len(), 2, "{sensed:?}");
    assert!(sensed[0].1.contains("activate_proximity") && sensed[0].0 == 0.0);
    assert!(sensed[1].1.contains("deactivate_proximity"), "{sensed:?}");
    assert_eq!(sensed[1].0, 3.0);
    assert_eq!(
        requests(&mine).len(),
        1,
        "nothing to stop: the motion had ended"
    );
}

#[test]
fn until_time_stops_at_that_time_and_the_sequence_goes_on() {
    let b = Behaviour::wander()
        .forever()
        .until(Condition::Time(5.0))
        .then(Behaviour::Wait(10.0))
        .then(Behaviour::go_to(0.0, 0.0, 10.0, 90.0));
    let out = alone(b, 200.0);
    let mine = of(&out.records, 0);
    let asked = requests(&mine);
    // Wandering until 5, then the stop at 5, then the way home at 15.
    let n = asked.len();
    assert!(n >= 3);
    assert!(asked[..n - 2].iter().all(|a| a.0 < 5.0 && a.1 == "move_to"));
    assert_eq!((asked[n - 2].0, asked[n - 2].1.as_str()), (5.0, "forward"));
    assert_eq!((asked[n - 1].0, asked[n - 1].1.as_str()), (15.0, "move_to"));
    let stopped = finishes(&mine)
        .into_iter()
        .find(|f| f.1 == MotionOutcome::Replaced)
        .expect("the wander was stopped");
    assert_eq!(stopped.0, 5.0);
    let path = &trajectories(&out.records)[0];
    assert_eq!(pos_at(path, 5.0), stopped.2);
    assert_eq!(pos_at(path, 15.0), stopped.2);
    assert!((pos_at(path, 200.0) - Point::origin()).norm() < 1e-9);
}

/// Sends a message to robot 0 at each of `at`.
#[derive(Debug, Clone)]
struct Sender {
    at: Vec<f64>,
}

impl Algorithm for Sender {
    fn name(&self) -> &str {
        "Sender"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let at = self.at.clone();
        Box::pin(async move {
            for t in at {
                robot.sleep(t - robot.now()).await;
                robot.send(vec![0], &"STOP");
            }
        })
    }
}

#[test]
fn until_message_ends_on_the_first_receive() {
    let b = Behaviour::wander()
        .forever()
        .until(Condition::Message)
        .then(Behaviour::Wait(1000.0));
    let out = run(
        infinite(),
        100.0,
        vec![
            (spec(0.0, 0.0, 0.0, 1.0), Box::new(b)),
            (
                spec(-500.0, -500.0, 0.0, 1.0),
                Box::new(Sender { at: vec![3.0, 6.0] }),
            ),
        ],
    );
    let mine = of(&out.records, 0);
    let received: Vec<f64> = mine
        .iter()
        .filter(|r| matches!(r.obs, Observation::Receive { .. }))
        .map(|r| r.t)
        .collect();
    // Reliable(delay: 1.0).
    assert_eq!(received, vec![4.0, 7.0]);
    let asked = requests(&mine);
    let last = asked.last().unwrap();
    assert_eq!((last.0, last.1.as_str()), (4.0, "forward"));
    assert!(asked[..asked.len() - 1].iter().all(|a| a.0 < 4.0));
    let ends = finishes(&mine);
    assert!(ends
        .iter()
        .any(|f| f.0 == 4.0 && f.1 == MotionOutcome::Replaced));
    let path = &trajectories(&out.records)[0];
    assert_eq!(pos_at(path, 4.0), pos_at(path, 100.0));
}

#[test]
fn repeat_runs_its_behaviour_n_times() {
    let b = Behaviour::go_to(10.0, 0.0, 5.0, 90.0)
        .then(Behaviour::go_to(0.0, 0.0, 5.0, 90.0))
        .times(3);
    let out = alone(b, 100.0);
    let mine = of(&out.records, 0);
    let asked = requests(&mine);
    assert_eq!(asked.len(), 6, "{asked:?}");
    let ends = finishes(&mine);
    assert_eq!(ends.len(), 6);
    assert!(ends.iter().all(|f| f.1 == MotionOutcome::Arrived));
    // Each leg: 2 s forward, and a 180° turn at 90°/s before each but the first.
    let t = ends.last().unwrap().0;
    assert!((t - (6.0 * 2.0 + 5.0 * 2.0)).abs() < 1e-9, "{t}");
}

#[test]
fn follow_keeps_within_distance_of_its_target() {
    // The target drives along +x at v = 1 from x = 20; the follower (speed 2, period 0.5,
    // distance 10) starts at the origin facing +x. It aims at 10 units behind where the target
    // was at the last reading, so it never comes closer than 10; once caught up it reaches
    // that point within each period, so it is never farther than 10 + v × period.
    let (d, v, p) = (10.0, 1.0, 0.5);
    let follower = Behaviour::Follow {
        robot: 1,
        distance: d,
        move_speed: 2.0,
        turn_speed: 90.0,
        period: p,
    };
    let target = script(vec![nekosim::algorithm::ScriptStep::Forward {
        distance: 100.0,
        move_speed: v,
    }]);
    let out = run(
        infinite(),
        90.0,
        vec![
            (spec(0.0, 0.0, 0.0, 1.0), Box::new(follower)),
            (spec(20.0, 0.0, 0.0, 1.0), target),
        ],
    );
    let paths = trajectories(&out.records);
    let mut t = 0.0;
    while t <= 90.0 {
        let (a, b) = (pos_at(&paths[0], t), pos_at(&paths[1], t));
        let gap = (b - a).norm();
        assert!(gap >= d - 1e-9, "t = {t}: {gap}");
        if t >= 20.0 {
            assert!(gap <= d + v * p + 1e-9, "t = {t}: {gap}");
        }
        assert!(a.y.abs() < 1e-9);
        t += 0.05;
    }
    // It did follow: the target stopped at x = 120 (t = 100 > 90: still driving at 90).
    assert!(pos_at(&paths[0], 90.0).x > 110.0 - d - v * p - 1e-9);
}

#[test]
fn avoid_stops_and_turns_away_from_the_robot_that_came_close() {
    // Driving along +x, the robot's border comes within 5 of the idle robot at (30, 3) when
    // the centres are 5 + 2 apart: at x = 30 - sqrt(7² - 3²). It stops there and turns to face
    // away from (30, 3).
    let b = Behaviour::go_to(100.0, 0.0, 5.0, 90.0).race(Behaviour::Avoid {
        range: 5.0,
        turn_speed: 90.0,
        back_off: Some(0.0),
        move_speed: 5.0,
        retry: 1.0,
    });
    let out = run(
        infinite(),
        60.0,
        vec![
            (spec(0.0, 0.0, 0.0, 1.0), Box::new(b)),
            (spec(30.0, 3.0, 0.0, 1.0), idle()),
        ],
    );
    let mine = of(&out.records, 0);
    let ends = finishes(&mine);
    let x = 30.0 - (49.0f64 - 9.0).sqrt();
    let stop = &ends[0];
    assert_eq!(stop.1, MotionOutcome::Replaced);
    assert!((stop.2 - Point::new(x, 0.0)).norm() < 1e-9, "{ends:?}");
    assert!((stop.0 - x / 5.0).abs() < 1e-9);
    let turned = ends.last().unwrap();
    let away = vector_heading(turned.2 - Point::new(30.0, 3.0));
    assert!((turned.3 - away).abs() < 1e-9, "{turned:?} vs {away}");
    assert!(away > 180.0 && away < 270.0);
    // The sensor was switched off after the first interrupt; nothing moves after the turn.
    let sensed = sensor_requests(&mine);
    assert!(sensed.iter().any(|s| s.1.contains("deactivate_proximity")));
    let path = &trajectories(&out.records)[0];
    assert_eq!(pos_at(path, turned.0), pos_at(path, 60.0));

    // With the default back-off, it then drives `range` units away.
    let b = Behaviour::go_to(100.0, 0.0, 5.0, 90.0).race(Behaviour::avoid(5.0));
    let out = run(
        infinite(),
        60.0,
        vec![
            (spec(0.0, 0.0, 0.0, 1.0), Box::new(b)),
            (spec(30.0, 3.0, 0.0, 1.0), idle()),
        ],
    );
    let end = pos_at(&trajectories(&out.records)[0], 60.0);
    let from = Point::new(x, 0.0);
    assert!(((end - from).norm() - 5.0).abs() < 1e-9);
    assert!((vector_heading(end - from) - away).abs() < 1e-9);
}

#[test]
fn the_race_until_avoid_follow_example_runs_deterministically() {
    let file = "examples/behaviours/escort.ron";
    let v = nekosim(&["validate", file]);
    assert_eq!(
        v.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&v.stderr)
    );
    let a = trace_of(file);
    assert!(a == trace_of(file));
    let text = String::from_utf8_lossy(&a);
    // Followers were stopped when their time was up, and the leader avoided someone.
    assert!(text.contains("\"outcome\":\"replaced\""));
    assert!(text.contains("deactivate_proximity"));
    assert!(text.contains("activate_contact"));
}
