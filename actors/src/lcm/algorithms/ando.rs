//! Point convergence under limited visibility (Ando, Oasa, Suzuki and Yamashita, "Distributed
//! memoryless point convergence algorithm for mobile robots with limited visibility", IEEE
//! Trans. Robotics and Automation 15(5), 1999). A robot sees the robots within its visibility
//! V. It heads for the centre of the smallest circle enclosing what it sees, but goes no
//! further than keeps each robot it sees within V/2 of their midpoint, so that no robot it
//! sees now leaves its view; the visibility graph then stays connected and the robots converge
//! to a point (the paper proves it under SSYNC).

use super::NoConfig;
use crate::config::Setting;
use crate::lcm::circle::smallest_enclosing;
use crate::lcm::{Decision, LcmConfigured, LookComputeMove, View};
use crate::world::geometry::Point;
use nekosim_protocols::FieldError;

/// `Ando()`: needs the scenario's `lcm.visibility`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Ando;

impl LookComputeMove for Ando {
    fn compute(&self, view: &View) -> Decision {
        let Some(v) = view.visibility else {
            return Decision::stay();
        };
        let points = view.points();
        if points.len() < 2 {
            return Decision::stay();
        }
        let Some(sec) = smallest_enclosing(&points) else {
            return Decision::stay();
        };
        let goal = sec.centre.coords;
        let distance = goal.norm();
        if distance == 0.0 {
            return Decision::stay();
        }
        let unit = goal / distance;
        let mut limit = distance;
        for s in view.others.iter().filter(|s| !s.is_here()) {
            let d = s.at.coords.norm();
            // Angle between the goal's direction and this robot's.
            let cos = (unit.dot(&s.at.coords) / d).clamp(-1.0, 1.0);
            let sin = (1.0 - cos * cos).max(0.0).sqrt();
            let half = d / 2.0;
            let reach = half * cos + ((v / 2.0).powi(2) - (half * sin).powi(2)).max(0.0).sqrt();
            limit = limit.min(reach);
        }
        Decision::to(Point::from(unit * limit.max(0.0)))
    }
}

impl LcmConfigured for Ando {
    type Config = NoConfig;

    fn configure(_: NoConfig, setting: &Setting) -> Result<Self, FieldError> {
        if setting.lcm.visibility.is_none() {
            return Err(FieldError::new(
                "",
                "Ando without a visibility range",
                "the scenario's lcm.visibility",
            ));
        }
        Ok(Self)
    }
}
