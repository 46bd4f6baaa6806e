//! The Move of a Look-Compute-Move robot: a straight line at constant velocity, without
//! turning, from where the robot is to where the move stops, in a given time. It ends exactly
//! at that point, so robots sent to one point stand on equal coordinates.

use super::super::world::geometry::{Point, Vector};
use super::super::world::motion::{
    Kinematics, MotionError, MotionPattern, MotionSpec, MotionStep, Piece, Pose, Progress, Shape,
    StepKind,
};

/// The request: glide to `to` in `duration` seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Glide {
    pub to: Point,
    pub duration: f64,
}

/// A started glide.
#[derive(Debug)]
struct Gliding {
    t0: f64,
    from: Point,
    to: Point,
    v: Vector,
    t1: f64,
    angle: f64,
}

impl MotionSpec for Glide {
    fn name(&self) -> &str {
        "glide"
    }
    fn params(&self) -> Vec<(String, f64)> {
        vec![
            ("to_x".into(), self.to.x),
            ("to_y".into(), self.to.y),
            ("duration".into(), self.duration),
        ]
    }
    fn begin(&self, t0: f64, from: Pose) -> Result<Box<dyn MotionPattern>, MotionError> {
        if !(self.duration.is_finite() && self.duration > 0.0) {
            return Err(MotionError::BadValue {
                what: "glide duration",
                expected: "a finite number > 0",
                value: self.duration,
            });
        }
        if !(self.to.x.is_finite() && self.to.y.is_finite()) {
            return Err(MotionError::BadValue {
                what: "glide destination",
                expected: "finite coordinates",
                value: if self.to.x.is_finite() {
                    self.to.y
                } else {
                    self.to.x
                },
            });
        }
        Ok(Box::new(Gliding {
            t0,
            from: from.pos,
            to: self.to,
            v: (self.to - from.pos) / self.duration,
            t1: t0 + self.duration,
            angle: from.angle,
        }))
    }
}

impl Gliding {
    /// The glide's one piece of path.
    fn piece(&self) -> Piece {
        Piece {
            t0: self.t0,
            t1: self.t1,
            shape: Shape::Linear {
                p0: self.from,
                v: self.v,
            },
        }
    }
}

impl MotionPattern for Gliding {
    fn start_time(&self) -> f64 {
        self.t0
    }
    fn end_time(&self) -> f64 {
        self.t1
    }
    fn state_at(&self, t: f64) -> Kinematics {
        let moving = t < self.t1;
        let pos = if moving {
            self.from + self.v * (t.max(self.t0) - self.t0)
        } else {
            self.to
        };
        Kinematics {
            pos,
            angle: self.angle,
            vel: if moving { self.v } else { Vector::zeros() },
            omega: 0.0,
        }
    }
    fn events(&self) -> Vec<MotionStep> {
        (0..2).filter_map(|k| self.step(k)).map(|s| s.0).collect()
    }
    fn step(&self, k: usize) -> Option<(MotionStep, bool)> {
        let (t, name) = match k {
            0 => (self.t0, "start_glide"),
            1 => (self.t1, "finish_glide"),
            _ => return None,
        };
        let kind = StepKind::Custom(name.into());
        Some((MotionStep { t, kind }, k == 1))
    }
    fn pieces(&self) -> Vec<Piece> {
        vec![self.piece()]
    }
    fn for_each_piece(&self, f: &mut dyn FnMut(Piece)) {
        f(self.piece());
    }
    fn progress_at(&self, t: f64) -> Progress {
        let speed = self.v.norm();
        Progress {
            dest: self.to,
            distance_left: speed * (self.t1 - t.clamp(self.t0, self.t1)),
            move_speed: speed,
            ..Progress::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A glide ends on its destination's very coordinates, and passes through the path's
    /// points in proportion to time.
    #[test]
    fn a_glide_ends_exactly_at_its_destination() {
        let to = Point::new(0.1 + 0.2, 1.0 / 3.0);
        let g = Glide { to, duration: 0.7 }
            .begin(
                2.0,
                Pose {
                    pos: Point::new(-5.0, 7.0),
                    angle: 30.0,
                },
            )
            .expect("starts");
        assert_eq!(g.state_at(2.7).pos, to);
        assert_eq!(g.state_at(9.0).pos, to);
        let mid = g.state_at(2.35).pos;
        let exact = Point::new((-5.0 + to.x) / 2.0, (7.0 + to.y) / 2.0);
        assert!((mid - exact).norm() < 1e-12);
        assert_eq!(g.state_at(2.35).angle, 30.0);
    }
}
