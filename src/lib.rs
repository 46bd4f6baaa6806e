//! nekosim: a deterministic, event-driven simulator for prototyping distributed algorithms on
//! cooperative mobile robots. This crate is the facade over the engine crates.

pub use nekosim_actors::*;
