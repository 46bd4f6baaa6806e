//! Look-Compute-Move algorithms for n robots, each written against the public API a user has
//! ([`super::LookComputeMove`], [`super::LcmConfigured`]) and registered like a user's.

pub mod ando;
pub mod centre_of_gravity;
pub mod circle_formation;
pub mod max_multiplicity;

pub use ando::Ando;
pub use centre_of_gravity::CentreOfGravity;
pub use circle_formation::CircleFormation;
pub use max_multiplicity::MaxMultiplicity;

use serde::Deserialize;

/// The configuration of an algorithm without settings: `Name()`.
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoConfig {}
