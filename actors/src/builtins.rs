//! The built-in algorithms under the names scenarios use for them (seed ch. 5, 7.2): those of
//! [`crate::algorithm`] and [`crate::behaviour::Behaviour`], registered through the same
//! [`Algorithms::algorithm`] a user's algorithm is registered with.

use crate::algorithm::*;
use crate::behaviour::Behaviour;
use crate::lcm::algorithms::{Ando, CentreOfGravity, CircleFormation, MaxMultiplicity};
use crate::lcm::rule_table::RuleTable;
use crate::lcm::Lcm;
use crate::registry::Algorithms;

impl Default for Algorithms {
    /// [`Algorithms::with_builtins`].
    fn default() -> Self {
        Self::with_builtins()
    }
}

impl Algorithms {
    /// The built-in algorithms of [`crate::algorithm`], under their names.
    pub fn with_builtins() -> Self {
        let mut r = Self::empty();
        r.algorithm::<Idle>("Idle")
            .algorithm::<Script>("Script")
            .algorithm::<RandomMovement>("RandomMovement")
            .algorithm::<Gathering>("Gathering")
            .algorithm::<AskForHelp>("AskForHelp")
            .algorithm::<BroadcastLoad>("BroadcastLoad")
            .algorithm::<MeetingPoint>("MeetingPoint")
            .algorithm::<PathReservation>("PathReservation")
            .algorithm::<Behaviour>("Behaviour")
            .algorithm::<Lcm<RuleTable>>("RuleTable")
            .algorithm::<Lcm<CentreOfGravity>>("CentreOfGravity")
            .algorithm::<Lcm<Ando>>("Ando")
            .algorithm::<Lcm<MaxMultiplicity>>("MaxMultiplicity")
            .algorithm::<Lcm<CircleFormation>>("CircleFormation");
        r
    }
}
