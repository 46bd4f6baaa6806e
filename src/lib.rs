//! nekosim: a deterministic, event-driven simulator for prototyping distributed algorithms on
//! cooperative mobile robots. This crate is the facade over the engine crates, plus scenario
//! files and the run's outputs.

pub use nekosim_actors::*;

pub mod scenario;
