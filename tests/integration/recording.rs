//! What the recorder draws, checked against the records it was drawn from: every pose (event
//! or animation frame) lies on the trajectory rebuilt from the trace, frames come at exactly
//! `k / framerate`, every collision gets one marker, and the same run draws the same picture.

use nekosim::algorithm::RandomMovement;
use nekosim::recording::{Canvas, Flight, Metrics, Recorder, Rgb, Stamp, ROBOT_GROUP};
use nekosim::world::geometry::Point;
use nekosim::world::observation::{Observation, Record};
use nekosim::world::virtual_world::RobotSpec;
use nekosim::world::RobotId;
use nekosim::{Algorithm, SimConfig};

use crate::common::*;

/// Keeps poses and collision markers.
#[derive(Debug, Default)]
struct Poses {
    poses: Vec<(Stamp, RobotId, Point)>,
    collisions: Vec<(u64, Point)>,
}

impl Canvas for Poses {
    fn world(&mut self, _: Option<(Point, Point)>) {}
    fn spawn(&mut self, _: RobotId, _: f64, _: Rgb) {}
    fn colour(&mut self, _: RobotId, _: Rgb) {}
    fn leg(&mut self, _: Stamp, _: RobotId, _: Point, _: Point) {}
    fn destination(&mut self, _: RobotId, _: Option<Point>) {}
    fn sensor(&mut self, _: RobotId, _: Option<f64>) {}
    fn pose(&mut self, _: Stamp, _: RobotId, _: Point, _: f64) {}
    fn poses(&mut self, at: Stamp, first: RobotId, poses: &[(Point, f64)]) {
        assert_eq!(
            first % ROBOT_GROUP,
            0,
            "groups start at multiples of the group size"
        );
        for (i, (p, _)) in poses.iter().enumerate() {
            self.poses.push((at, first + i as RobotId, *p));
        }
    }
    fn query(&mut self, _: Stamp, _: RobotId, _: Option<(Point, f64)>) {}
    fn collision(&mut self, _: Stamp, k: u64, p: Point, _: &str) {
        self.collisions.push((k, p));
    }
    fn messages(&mut self, _: Stamp, _: &str, _: Rgb, _: &[Flight]) {}
    fn log(&mut self, _: Stamp, _: nekosim::recording::Level, _: &str) {}
    fn metrics(&mut self, _: Stamp, _: &Metrics) {}
}

fn random_run() -> (Vec<Record>, f64) {
    // Two groups: 32 robots and 8.
    let robots: Vec<(RobotSpec, Box<dyn Algorithm>)> = (0..40)
        .map(|i| {
            let (x, y) = (15.0 + 25.0 * (i % 6) as f64, 15.0 + 30.0 * (i / 6) as f64);
            (
                spec(x, y, 12.0 * i as f64, 4.0),
                Box::new(RandomMovement::default()) as Box<dyn Algorithm>,
            )
        })
        .collect();
    let out = nekosim::run(SimConfig {
        sensors: Default::default(),
        seed: 9,
        until: 40.0,
        world: bounded(200.0, 200.0),
        robots,
        arbiters: 1,
        record: true,
        observers: Default::default(),
        comms: Default::default(),
    })
    .expect("run");
    (out.records, out.stats.end_time)
}

fn draw(records: &[Record], end: f64, framerate: f64) -> Poses {
    let mut r = Recorder::new(Poses::default(), &bounded(200.0, 200.0).size, framerate);
    for rec in records {
        r.record(rec);
    }
    r.finish(end);
    r.into_canvas()
}

#[test]
fn every_drawn_pose_lies_on_the_trajectory_rebuilt_from_the_trace() {
    let (records, end) = random_run();
    let paths = trajectories(&records);
    let drawn = draw(&records, end, 25.0);
    let frames: Vec<_> = drawn.poses.iter().filter(|p| p.0.seq.is_none()).collect();
    assert!(frames.len() > 10_000, "{} frame poses", frames.len());
    for (at, robot, pos) in &drawn.poses {
        let want = pos_at(&paths[*robot as usize], at.t);
        assert!(
            (pos - want).norm() < 1e-9,
            "p{robot} at {at:?}: drawn {pos}, trace {want}"
        );
    }
    // Frames are at k / 25 exactly, up to the end of the run.
    for (at, _, _) in &frames {
        let k = (at.t * 25.0).round();
        assert_eq!(at.t, k / 25.0);
        assert!(at.t <= end);
    }
    // One marker per collision record, numbered in order.
    let collisions = records
        .iter()
        .filter(|r| matches!(r.obs, Observation::Collision { .. }))
        .count();
    assert!(collisions > 0);
    assert_eq!(drawn.collisions.len(), collisions);
    assert!(drawn
        .collisions
        .iter()
        .enumerate()
        .all(|(i, (k, _))| *k == i as u64));
}

#[test]
fn framerate_zero_draws_event_instants_only_and_drawings_are_a_function_of_the_run() {
    let (records, end) = random_run();
    let drawn = draw(&records, end, 0.0);
    assert!(drawn.poses.iter().all(|p| p.0.seq.is_some()));
    let again = draw(&random_run().0, end, 0.0);
    assert_eq!(format!("{:?}", drawn), format!("{:?}", again));
}
