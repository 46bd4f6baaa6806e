//! Predicates a Look-Compute-Move scenario can name (`lcm: (predicates: [...])`), and the
//! monitor that tells when each first held and whether it kept holding.
//!
//! The monitor reads a run's records only: a robot is where it was born until a Move record
//! sends it along a straight line to its stop, at constant speed until the Move's end, and a
//! crashed robot stays where it crashed. Between two instants with records every robot
//! therefore moves on a straight line at constant speed, so the predicates are evaluated at
//! those instants, and collision-freedom between them too, by each pair's closest approach
//! (exact, not sampled). Every predicate compares points with [`SAME_POINT`].

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::circle::smallest_enclosing;
use super::record::LcmRecord;
use super::view::SAME_POINT;
use crate::world::geometry::Point;
use crate::world::observation::{Observation, Record};
use crate::world::RobotId;

/// A property of the Look-Compute-Move robots' positions.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Predicate {
    /// Every robot on one point.
    Gathered,
    /// Two robots on one point (gathering of two).
    Rendezvous,
    /// The robots within `epsilon` of each other (the diameter of their positions).
    Converged { epsilon: f64 },
    /// No two robots on one point, unless all are gathered.
    CollisionFree,
    /// The robots evenly spaced on a circle, each within `epsilon` of its place.
    UniformCircle { epsilon: f64 },
}

impl Predicate {
    /// Its name in reports.
    pub fn name(&self) -> String {
        match self {
            Self::Gathered => "gathered".into(),
            Self::Rendezvous => "rendezvous".into(),
            Self::Converged { epsilon } => format!("converged(epsilon {epsilon})"),
            Self::CollisionFree => "collision-free".into(),
            Self::UniformCircle { epsilon } => format!("uniform circle(epsilon {epsilon})"),
        }
    }

    /// Why it is refused, if it is.
    pub fn check(&self) -> Result<(), String> {
        match self {
            Self::Converged { epsilon } | Self::UniformCircle { epsilon }
                if !(epsilon.is_finite() && *epsilon > 0.0) =>
            {
                Err(format!("epsilon is {epsilon}; expected a number > 0"))
            }
            _ => Ok(()),
        }
    }
}

/// When a predicate first held, and since when it has held without a break (if it holds at
/// the end).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Report {
    pub predicate: String,
    pub first: Option<f64>,
    pub holds_since: Option<f64>,
}

impl Report {
    /// One line: `gathered: first at 3.2 s, holds since 3.2 s`.
    pub fn text(&self) -> String {
        match (self.first, self.holds_since) {
            (None, _) => format!("{}: never held", self.predicate),
            (Some(f), Some(s)) => format!(
                "{}: first held at {f:.6} s, holds since {s:.6} s to the end",
                self.predicate
            ),
            (Some(f), None) => format!(
                "{}: first held at {f:.6} s, does not hold at the end",
                self.predicate
            ),
        }
    }
}

/// A robot's straight-line motion from `t0` to `t1`, at rest outside.
#[derive(Clone, Copy, Debug)]
struct Leg {
    t0: f64,
    from: Point,
    t1: f64,
    to: Point,
}

impl Leg {
    fn at(&self, t: f64) -> Point {
        if t >= self.t1 {
            self.to
        } else if t <= self.t0 {
            self.from
        } else {
            self.from + (self.to - self.from) * ((t - self.t0) / (self.t1 - self.t0))
        }
    }

    fn rest(p: Point) -> Self {
        Self {
            t0: 0.0,
            from: p,
            t1: 0.0,
            to: p,
        }
    }
}

/// Watches a run's records and reports on the predicates.
#[derive(Debug)]
pub struct Monitor {
    predicates: Vec<Predicate>,
    first: Vec<Option<f64>>,
    since: Vec<Option<f64>>,
    born: BTreeMap<RobotId, Point>,
    legs: BTreeMap<RobotId, Leg>,
    /// The instant whose records are coming in.
    pending: Option<f64>,
    /// Whether no two robots met since the last instant judged.
    meanwhile: bool,
}

impl Monitor {
    /// A monitor of `predicates`.
    pub fn new(predicates: Vec<Predicate>) -> Self {
        let n = predicates.len();
        Self {
            predicates,
            first: vec![None; n],
            since: vec![None; n],
            born: BTreeMap::new(),
            legs: BTreeMap::new(),
            pending: None,
            meanwhile: true,
        }
    }

    /// Takes one record into account.
    pub fn observe(&mut self, r: &Record) {
        if self.predicates.is_empty() {
            return;
        }
        if let Observation::Spawn { robot, pos, .. } = &r.obs {
            self.born.insert(*robot, *pos);
            return;
        }
        if !matches!(r.obs, Observation::Crash { .. } | Observation::Lcm(_)) {
            return;
        }
        // An instant is judged once all its records are in: when a later one comes.
        if let Some(t) = self.pending.filter(|&t| r.t > t) {
            self.evaluate(t, self.meanwhile);
            // Until this record, every robot keeps the motion it has now.
            self.meanwhile =
                !self.predicates.contains(&Predicate::CollisionFree) || self.apart_between(t, r.t);
        }
        self.pending = Some(r.t);
        match &r.obs {
            Observation::Crash { robot, state } => {
                if let Some(l) = self.legs.get_mut(robot) {
                    *l = Leg::rest(state.pos);
                }
            }
            Observation::Lcm(rec) => {
                let robot = rec.robot();
                if !self.legs.contains_key(&robot) {
                    let p = self.born.get(&robot).copied().unwrap_or(Point::origin());
                    self.legs.insert(robot, Leg::rest(p));
                }
                if let LcmRecord::Move {
                    from, stop, end, ..
                } = rec
                {
                    self.legs.insert(
                        robot,
                        Leg {
                            t0: r.t,
                            from: *from,
                            t1: *end,
                            to: *stop,
                        },
                    );
                }
            }
            _ => {}
        }
    }

    fn positions(&self, t: f64) -> Vec<Point> {
        self.legs.values().map(|l| l.at(t)).collect()
    }

    fn evaluate(&mut self, t: f64, meanwhile: bool) {
        let points = self.positions(t);
        for (i, p) in self.predicates.iter().enumerate() {
            let holds = match p {
                Predicate::Gathered | Predicate::Rendezvous => gathered(&points),
                Predicate::Converged { epsilon } => diameter(&points) <= *epsilon,
                Predicate::CollisionFree => meanwhile && (gathered(&points) || apart(&points)),
                Predicate::UniformCircle { epsilon } => uniform_circle(&points, *epsilon),
            };
            if holds {
                self.first[i].get_or_insert(t);
                self.since[i].get_or_insert(t);
            } else {
                self.since[i] = None;
            }
        }
    }

    /// Whether no two robots meet strictly between `t0` and `t1` (every robot moves on a
    /// straight line at constant speed then).
    fn apart_between(&self, t0: f64, t1: f64) -> bool {
        if t1 <= t0 {
            return true;
        }
        let legs: Vec<&Leg> = self.legs.values().collect();
        let mid = (t0 + t1) / 2.0;
        for (i, a) in legs.iter().enumerate() {
            for b in &legs[i + 1..] {
                // Relative position p(t) = p0 + v (t - t0) on [t0, t1].
                let p0 = a.at(t0) - b.at(t0);
                let v = ((a.at(mid) - b.at(mid)) - p0) / (mid - t0);
                let vv = v.norm_squared();
                let s = if vv > 0.0 {
                    (-p0.dot(&v) / vv).clamp(0.0, t1 - t0)
                } else {
                    0.0
                };
                if s > 0.0 && s < t1 - t0 {
                    let closest = p0 + v * s;
                    let scale = a.at(t0).coords.norm().max(1.0);
                    if closest.norm() <= SAME_POINT * scale {
                        return false;
                    }
                }
            }
        }
        true
    }

    /// The reports, once the run is over (the last instant judged with them).
    pub fn reports(&mut self) -> Vec<Report> {
        if let Some(t) = self.pending.take() {
            self.evaluate(t, self.meanwhile);
        }
        (self.predicates.iter().enumerate())
            .map(|(i, p)| Report {
                predicate: p.name(),
                first: self.first[i],
                holds_since: self.since[i],
            })
            .collect()
    }
}

/// Whether two points are one under [`SAME_POINT`], relative to their coordinates' size.
fn same(a: Point, b: Point) -> bool {
    let scale = a.coords.amax().max(b.coords.amax()).max(1.0);
    (a - b).norm() <= SAME_POINT * scale
}

/// Whether every point is one, under [`SAME_POINT`].
pub fn gathered(points: &[Point]) -> bool {
    points
        .first()
        .is_none_or(|&p| points.iter().all(|&q| same(p, q)))
}

fn apart(points: &[Point]) -> bool {
    let mut sorted = points.to_vec();
    sorted.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    for (i, a) in sorted.iter().enumerate() {
        for b in &sorted[i + 1..] {
            let scale = a.coords.amax().max(1.0);
            if b.x - a.x > SAME_POINT * scale * 2.0 {
                break;
            }
            if same(*a, *b) {
                return false;
            }
        }
    }
    true
}

/// The largest distance between two of the points.
pub fn diameter(points: &[Point]) -> f64 {
    let mut d: f64 = 0.0;
    for (i, a) in points.iter().enumerate() {
        for b in &points[i + 1..] {
            d = d.max((a - b).norm());
        }
    }
    d
}

/// Whether the points stand evenly spaced on their smallest enclosing circle, each within
/// `epsilon` of the circle and the arcs between neighbours within `epsilon` of equal.
pub fn uniform_circle(points: &[Point], epsilon: f64) -> bool {
    let n = points.len();
    if n < 3 {
        return false;
    }
    let Some(c) = smallest_enclosing(points) else {
        return false;
    };
    if points
        .iter()
        .any(|p| ((p - c.centre).norm() - c.radius).abs() > epsilon)
    {
        return false;
    }
    let mut angles: Vec<f64> = points
        .iter()
        .map(|p| (p.y - c.centre.y).atan2(p.x - c.centre.x))
        .collect();
    angles.sort_by(f64::total_cmp);
    let arc = std::f64::consts::TAU / n as f64;
    (0..n).all(|i| {
        let gap = if i + 1 < n {
            angles[i + 1] - angles[i]
        } else {
            angles[0] + std::f64::consts::TAU - angles[n - 1]
        };
        ((gap - arc) * c.radius).abs() <= epsilon
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The diameter is the brute-force largest distance, and a square of side 1 is uniform
    /// on its circle while a kite is not.
    #[test]
    fn shapes_are_recognised() {
        let square = [
            Point::new(0.0, 0.0),
            Point::new(1.0, 0.0),
            Point::new(1.0, 1.0),
            Point::new(0.0, 1.0),
        ];
        assert!((diameter(&square) - 2f64.sqrt()).abs() < 1e-15);
        assert!(uniform_circle(&square, 1e-9));
        let kite = [
            Point::new(1.0, 0.0),
            Point::new(0.0, 1.0),
            Point::new(-1.0, 0.0),
            Point::new(0.6, -0.8),
        ];
        assert!(!uniform_circle(&kite, 1e-3));
        assert!(gathered(&[Point::new(3.0, 4.0); 3]));
        assert!(!gathered(&[Point::new(3.0, 4.0), Point::new(3.0, 4.001)]));
    }
}
