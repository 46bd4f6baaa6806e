//! nekosim: a deterministic, event-driven simulator for prototyping distributed algorithms on
//! cooperative mobile robots. This crate is the facade over the engine crates, plus scenario
//! files and the run's outputs (Neko log, JSONL trace).

pub use nekosim_actors::*;

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
