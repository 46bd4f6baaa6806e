//! Uniform circle formation (after Défago and Konagaya, "Circle formation for oblivious
//! anonymous mobile robots with no common sense of orientation", POMC 2002): robots inside the
//! smallest circle enclosing all robots move out to it; robots on it move halfway towards the
//! angular midpoint of their two neighbours on it. The halfway step makes the spacing converge
//! to uniform under FSYNC (the lazy averaging of the gaps has no oscillating mode, where going
//! all the way would oscillate for an even number of robots). Robots move along chords, not
//! arcs, so a move cut short leaves its robot inside the circle, and it moves out again.

use super::NoConfig;
use crate::config::Setting;
use crate::lcm::circle::smallest_enclosing;
use crate::lcm::{Decision, LcmConfigured, LookComputeMove, View};
use crate::world::geometry::{Point, Vector};
use nekosim_protocols::FieldError;

/// `CircleFormation()`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CircleFormation;

/// How close to the circle counts as on it, relative to its radius.
const ON_CIRCLE: f64 = 1e-9;

impl LookComputeMove for CircleFormation {
    fn compute(&self, view: &View) -> Decision {
        let points = view.points();
        if points.len() < 3 {
            return Decision::stay();
        }
        let Some(sec) = smallest_enclosing(&points) else {
            return Decision::stay();
        };
        let (c, r) = (sec.centre, sec.radius);
        let mine = Point::origin() - c;
        if mine.norm() < r * (1.0 - ON_CIRCLE) {
            if mine.norm() == 0.0 {
                return Decision::to(c + Vector::new(r, 0.0));
            }
            return Decision::to(c + mine * (r / mine.norm()));
        }
        let angle = |p: Point| {
            let d = p - c;
            d.y.atan2(d.x)
        };
        let me = angle(Point::origin());
        let tau = std::f64::consts::TAU;
        // Angular offsets of the others on the circle, anticlockwise from me, in (0, 2 pi).
        let mut offsets: Vec<f64> = points[1..]
            .iter()
            .filter(|p| ((*p - c).norm() - r).abs() <= r * ON_CIRCLE)
            .map(|&p| (angle(p) - me).rem_euclid(tau))
            .filter(|&o| o > 0.0)
            .collect();
        if offsets.is_empty() {
            return Decision::stay();
        }
        offsets.sort_by(f64::total_cmp);
        let next = offsets[0];
        let prev = offsets[offsets.len() - 1] - tau;
        let target = me + (next + prev) / 4.0;
        Decision::to(c + Vector::new(target.cos(), target.sin()) * r)
    }
}

impl LcmConfigured for CircleFormation {
    type Config = NoConfig;

    fn configure(_: NoConfig, _: &Setting) -> Result<Self, FieldError> {
        Ok(Self)
    }
}
