//! nekosim: a deterministic, event-driven simulator for prototyping distributed algorithms on
//! cooperative mobile robots. This crate is the facade over the engine crates, plus scenario
//! files and the run's outputs (Neko log, JSONL trace).
//!
//! A user's crate depends on this one alone (docs/extending.md, "Your own crate"): the engine
//! is re-exported at the root, the protocol API as [`protocols`], the model checker as
//! [`models`].

pub use nekosim_actors::*;

/// The microprotocol API a user's protocols are written against (`Microprotocol`, services,
/// payloads, stacks).
pub use nekosim_protocols as protocols;

/// The stateright model checker over protocol stacks (`nekosim check`).
pub use nekosim_models as models;

/// The random number generators a user's network models and sensors draw from.
pub use {rand, rand_chacha};

/// serde, for a crate that derives through it (`#[serde(crate = "nekosim::serde")]`) instead
/// of naming it as a dependency.
pub use serde;

/// The engine crate by name (its modules are also at this crate's root).
pub use nekosim_actors as actors;

pub mod allocator;
pub mod apps;
pub mod check;
pub mod cli;
pub mod cluster;
pub mod log;
pub mod node;
pub mod output;
pub mod recording;
pub mod runner;
pub mod scenario;
pub mod sweep;
pub mod trace;

/// Extending nekosim with your own protocols: docs/extending.md, whose snippets run as
/// doc tests.
#[doc = include_str!("../docs/extending.md")]
pub mod extending {}

/// Look-Compute-Move robots: docs/lcm.md, whose Rust snippet runs as a doc test.
#[doc = include_str!("../docs/lcm.md")]
pub mod look_compute_move {}

/// Model checking protocol stacks: docs/model-checking.md, whose snippets run as doc tests.
#[doc = include_str!("../docs/model-checking.md")]
pub mod model_checking {}
