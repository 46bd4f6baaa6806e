//! Look-Compute-Move robots: the model of distributed robotics theory (Suzuki and Yamashita,
//! "Distributed anonymous mobile robots: formation of geometric patterns", SIAM J. Comput.
//! 28(4), 1999; Flocchini, Prencipe and Santoro, "Distributed Computing by Mobile Entities",
//! Springer, 2019, ch. 1), with the lights of Das, Flocchini, Prencipe, Santoro and Yamashita
//! ("Autonomous mobile robots with lights", TCS 609, 2016).
//!
//! A robot is an anonymous point with no memory between cycles. Each cycle it **Looks** (an
//! instantaneous snapshot of the others in its own local frame, [`view`]), **Computes** (a pure
//! function of the snapshot, [`LookComputeMove::compute`]) and **Moves** towards the
//! destination it computed. An adversary activates robots under a synchrony model
//! ([`settings::Synchrony`]), chooses their local frames ([`frame`]), how long each phase
//! lasts and where a non-rigid move stops ([`adversary`]). A luminous robot carries a light
//! that the others see ([`LightState`]); a Look during another robot's Compute reads its light
//! through the register the scenario names.
//!
//! A Look-Compute-Move robot is a robot like the others: an algorithm hosted by the same robot
//! actor ([`runtime::Lcm`]), in the same world, moving by the exact motion formulas
//! ([`glide`]); its Look is a sensor ([`look`]) and its light is world state the sensor manager
//! keeps. The user's code is the pure `compute`; the cycle, the adversary and the frames are
//! the runtime's.

pub mod adversary;
pub mod algorithms;
pub mod circle;
pub mod frame;
pub mod glide;
pub mod look;
pub mod predicate;
pub mod record;
pub mod rule_table;
pub mod runtime;
pub mod search;
pub mod settings;
pub mod view;

pub use frame::Frame;
pub use look::Register;
pub use runtime::{Lcm, LcmConfigured};
pub use settings::{LcmSettings, Movement, Synchrony};
pub use view::{Decision, Light, LightState, LookComputeMove, Multiplicity, Seen, View};
