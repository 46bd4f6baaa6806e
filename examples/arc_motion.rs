//! A custom motion pattern: an arc of a circle, driven at constant speed while turning.
//!
//! The pattern implements the seed's two operations (state at any instant, events of the
//! motion) and describes its path as one curved piece, so collisions with it are predicted by
//! conservative advancement (exact to 1e-10 units, no time slicing).
//!
//! Run: `cargo run --example arc_motion`. Test: `cargo test --example arc_motion`.

use std::sync::Arc;

use nekosim::algorithm::Idle;
use nekosim::world::geometry::{heading_vector, normalize_deg, Point, Vector};
use nekosim::world::motion::{
    Kinematics, Motion, MotionError, MotionPattern, MotionSpec, MotionStep, Piece, Pose, Shape,
    StepKind,
};
#[cfg(test)]
use nekosim::world::observation::Observation;
use nekosim::world::virtual_world::{RobotSpec, WorldConfig, WorldSize};
use nekosim::{Algorithm, AlgorithmFuture, MotionEnd, Robot, SimConfig};

/// Request: drive along an arc of `radius` for `angle` degrees (positive = turning left) at
/// `speed` units/s.
#[derive(Debug)]
struct ArcSpec {
    radius: f64,
    angle: f64,
    speed: f64,
}

/// A started arc.
#[derive(Debug)]
struct ArcMotion {
    t0: f64,
    centre: Point,
    radius: f64,
    /// Polar angle of the robot around the centre at t0 [rad].
    phase: f64,
    /// [rad/s], signed.
    rate: f64,
    duration: f64,
    heading0: f64,
}

impl MotionSpec for ArcSpec {
    fn name(&self) -> &str {
        "arc"
    }
    fn params(&self) -> Vec<(String, f64)> {
        vec![
            ("radius".into(), self.radius),
            ("angle".into(), self.angle),
            ("speed".into(), self.speed),
        ]
    }
    fn begin(&self, t0: f64, from: Pose) -> Result<Box<dyn MotionPattern>, MotionError> {
        if !(self.radius > 0.0 && self.speed > 0.0 && self.angle.is_finite()) {
            return Err(MotionError::BadValue {
                what: "arc",
                expected: "radius > 0, speed > 0, finite angle",
                value: self.radius,
            });
        }
        let left = self.angle >= 0.0;
        // The centre is one radius to the robot's left (or right).
        let h = heading_vector(from.angle);
        let normal = if left {
            Vector::new(-h.y, h.x)
        } else {
            Vector::new(h.y, -h.x)
        };
        let centre = from.pos + normal * self.radius;
        let d = from.pos - centre;
        let rate = self.speed / self.radius * if left { 1.0 } else { -1.0 };
        Ok(Box::new(ArcMotion {
            t0,
            centre,
            radius: self.radius,
            phase: d.y.atan2(d.x),
            rate,
            duration: self.angle.abs().to_radians() / rate.abs(),
            heading0: from.angle,
        }))
    }
}

impl MotionPattern for ArcMotion {
    fn start_time(&self) -> f64 {
        self.t0
    }
    fn end_time(&self) -> f64 {
        self.t0 + self.duration
    }
    fn state_at(&self, t: f64) -> Kinematics {
        let dt = (t.min(self.end_time()) - self.t0).max(0.0);
        let phi = self.phase + self.rate * dt;
        let pos = self.centre + Vector::new(phi.cos(), phi.sin()) * self.radius;
        let moving = t < self.end_time();
        Kinematics {
            pos,
            angle: normalize_deg(self.heading0 + (self.rate * dt).to_degrees()),
            vel: if moving {
                Vector::new(-phi.sin(), phi.cos()) * self.radius * self.rate
            } else {
                Vector::zeros()
            },
            omega: if moving { self.rate.to_degrees() } else { 0.0 },
        }
    }
    fn events(&self) -> Vec<MotionStep> {
        vec![
            MotionStep {
                t: self.t0,
                kind: StepKind::Custom("start_arc".into()),
            },
            MotionStep {
                t: self.end_time(),
                kind: StepKind::Custom("finish_arc".into()),
            },
        ]
    }
    fn pieces(&self) -> Vec<Piece> {
        vec![Piece {
            t0: self.t0,
            t1: self.end_time(),
            shape: Shape::Curve {
                max_speed: self.radius * self.rate.abs(),
            },
        }]
    }
}

/// Drives one arc and reports how it ended.
#[derive(Debug)]
struct ArcDriver(f64);

impl Algorithm for ArcDriver {
    fn name(&self) -> &str {
        "arc driver"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let angle = self.0;
        Box::pin(async move {
            let end: MotionEnd = robot
                .motion(Motion::Custom(Arc::new(ArcSpec {
                    radius: 50.0,
                    angle,
                    speed: 5.0,
                })))
                .await;
            println!(
                "t={:.6} arc ended: {:?} at {:?}",
                robot.now(),
                end.outcome,
                end.state.pos
            );
        })
    }
}

/// Robot 0 starts at (0, 0) facing +x and drives a left arc around (0, 50); robot 1 stands on
/// that circle at polar angle `obstacle_deg` around the centre.
fn run(obstacle_deg: f64) -> nekosim::scheduler::RunOutput {
    let centre = Point::new(0.0, 50.0);
    let q = centre
        + Vector::new(
            obstacle_deg.to_radians().cos(),
            obstacle_deg.to_radians().sin(),
        ) * 50.0;
    nekosim::run(SimConfig {
        sensors: Default::default(),
        seed: 1,
        until: 100.0,
        world: WorldConfig {
            size: WorldSize::Infinite,
            ghost_mode: false,
            walls: true,
            turn: Default::default(),
            cell_size: None,
            obstacles: Default::default(),
        },
        robots: vec![
            (
                RobotSpec {
                    radius: 3.0,
                    pose: Pose {
                        pos: Point::new(0.0, 0.0),
                        angle: 0.0,
                    },
                },
                Box::new(ArcDriver(180.0)),
            ),
            (
                RobotSpec {
                    radius: 2.0,
                    pose: Pose { pos: q, angle: 0.0 },
                },
                Box::new(Idle),
            ),
        ],
        arbiters: 1,
        record: true,
        observers: Default::default(),
        comms: Default::default(),
    })
    .expect("run")
}

#[cfg_attr(test, allow(dead_code))]
fn main() {
    let out = run(45.0);
    for r in &out.records {
        println!("{:>10.6} {:?}", r.t, r.obs);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn collision_on_the_arc_happens_at_the_closed_form_instant() {
        // The robot starts at polar angle -90° around the centre and moves at 0.1 rad/s.
        // Contact when the chord to the obstacle equals 3 + 2: 2·50·sin(Δ/2) = 5.
        let obstacle = 45.0f64;
        let out = run(obstacle);
        let collision = out
            .records
            .iter()
            .find(|r| matches!(r.obs, Observation::Collision { .. }))
            .expect("a collision");
        let delta = (obstacle + 90.0).to_radians() - 2.0 * (5.0f64 / 100.0).asin();
        let expected = delta / 0.1;
        assert!(
            (collision.t - expected).abs() < 1e-6,
            "collision at {} expected {expected}",
            collision.t
        );
    }

    /// The arc of `collision_on_the_arc...` towards a wall `x = 30` (an obstacle segment): the
    /// centre is at `(50 sin(0.1 t), 50 - 50 cos(0.1 t))`, so the disc of radius 3 touches
    /// the wall when `50 sin(0.1 t) = 27`, at `(30, y)`: found by conservative advancement.
    #[test]
    fn an_arc_stops_at_an_obstacle_at_the_closed_form_instant() {
        let out = nekosim::run(SimConfig {
            sensors: Default::default(),
            seed: 1,
            until: 100.0,
            world: WorldConfig {
                size: WorldSize::Infinite,
                ghost_mode: false,
                walls: true,
                turn: Default::default(),
                cell_size: None,
                obstacles: vec![nekosim::world::obstacle::Shape::Segment {
                    from: (30.0, -100.0),
                    to: (30.0, 200.0),
                }]
                .into(),
            },
            robots: vec![(
                RobotSpec {
                    radius: 3.0,
                    pose: Pose {
                        pos: Point::new(0.0, 0.0),
                        angle: 0.0,
                    },
                },
                Box::new(ArcDriver(180.0)),
            )],
            arbiters: 1,
            record: true,
            observers: Default::default(),
            comms: Default::default(),
        })
        .expect("run");
        let (t, other, other_pos) = out
            .records
            .iter()
            .find_map(|r| match r.obs {
                Observation::Collision {
                    other, other_pos, ..
                } => Some((r.t, other, other_pos)),
                _ => None,
            })
            .expect("a collision");
        let expected = (27.0f64 / 50.0).asin() / 0.1;
        assert!(
            (t - expected).abs() < 1e-6,
            "collision at {t} expected {expected}"
        );
        assert_eq!(other, nekosim::world::Obstacle::Object(0));
        let y = 50.0 - 50.0 * (0.1 * expected).cos();
        assert!(
            (other_pos - Point::new(30.0, y)).norm() < 1e-6,
            "{other_pos}"
        );
    }

    #[test]
    fn an_arc_that_stops_short_of_the_obstacle_does_not_collide() {
        // The half circle ends at polar angle 90°; an obstacle at 120° is never reached.
        let out = run(120.0);
        assert!(!out
            .records
            .iter()
            .any(|r| matches!(r.obs, Observation::Collision { .. })));
        let end = out.records.iter().rev().find_map(|r| match &r.obs {
            Observation::MotionFinish { state, .. } => Some(state.pos),
            _ => None,
        });
        assert!((end.unwrap() - Point::new(0.0, 100.0)).norm() < 1e-9);
    }
}
