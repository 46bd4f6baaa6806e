//! Gathering with multiplicity detection, the rule at the core of Cieliebak, Flocchini,
//! Prencipe and Santoro ("Distributed computing by mobile robots: gathering", SIAM J. Comput.
//! 41(4), 2012): when one point holds more robots than any other, every robot goes there, and
//! it stays the unique point of most robots; otherwise a robot heads for the centre of the
//! smallest circle enclosing all robots. This is the rule alone, without the paper's
//! treatment of symmetric configurations (equiangular and bivalent ones): it gathers n >= 3
//! robots from every configuration with a unique point of greatest multiplicity, and under
//! FSYNC with rigid moves from any configuration in one round.

use super::NoConfig;
use crate::config::Setting;
use crate::lcm::circle::smallest_enclosing;
use crate::lcm::settings::Detection;
use crate::lcm::{Decision, LcmConfigured, LookComputeMove, Multiplicity, View};
use crate::world::geometry::Point;
use nekosim_protocols::FieldError;

/// `MaxMultiplicity()`: needs the scenario's `lcm.multiplicity` (Weak or Strong).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MaxMultiplicity;

impl LookComputeMove for MaxMultiplicity {
    fn compute(&self, view: &View) -> Decision {
        // Robots at each point, the robot's own point first.
        let mut counts: Vec<(Point, u32)> = vec![(Point::origin(), 1)];
        for s in &view.others {
            let k = match s.multiplicity {
                Multiplicity::Exactly(k) => k,
                Multiplicity::Many => 2,
                Multiplicity::One | Multiplicity::Unknown => 1,
            };
            match counts.iter_mut().find(|(p, _)| *p == s.at) {
                Some(c) => c.1 += k,
                None => counts.push((s.at, k)),
            }
        }
        let most = counts.iter().map(|c| c.1).max().unwrap_or(1);
        let mut tops = counts.iter().filter(|c| c.1 == most);
        if let (Some(&(p, k)), None) = (tops.next(), tops.next()) {
            if k >= 2 {
                return Decision::to(p);
            }
        }
        let points: Vec<Point> = counts.iter().map(|c| c.0).collect();
        match smallest_enclosing(&points) {
            Some(c) => Decision::to(c.centre),
            None => Decision::stay(),
        }
    }
}

impl LcmConfigured for MaxMultiplicity {
    type Config = NoConfig;

    fn configure(_: NoConfig, setting: &Setting) -> Result<Self, FieldError> {
        if setting.lcm.multiplicity == Detection::None {
            return Err(FieldError::new(
                "",
                "MaxMultiplicity without multiplicity detection",
                "the scenario's lcm.multiplicity: Weak or Strong",
            ));
        }
        Ok(Self)
    }
}
