//! Convergence to the centre of gravity (Cohen and Peleg, "Convergence properties of the
//! gravitational algorithm in asynchronous robot systems", SIAM J. Comput. 34(6), 2005): each
//! robot moves to the centre of gravity of the robots it sees, itself included. Under FSYNC
//! with rigid moves every robot reaches the same point in one round; with moves cut short at
//! the same fraction f, the centre stays put and every robot's distance to it shrinks by the
//! factor 1 - f each round; under SSYNC and ASYNC the robots converge.

use super::NoConfig;
use crate::config::Setting;
use crate::lcm::{Decision, LcmConfigured, LookComputeMove, View};
use nekosim_protocols::FieldError;

/// `CentreOfGravity()`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CentreOfGravity;

impl LookComputeMove for CentreOfGravity {
    fn compute(&self, view: &View) -> Decision {
        Decision::to(view.centre_of_gravity())
    }
}

impl LcmConfigured for CentreOfGravity {
    type Config = NoConfig;

    fn configure(_: NoConfig, _: &Setting) -> Result<Self, FieldError> {
        Ok(Self)
    }
}
