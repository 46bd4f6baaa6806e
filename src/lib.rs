//! nekosim: a deterministic, event-driven simulator for prototyping distributed algorithms on
//! cooperative mobile robots. This crate is the facade over the engine crates, plus scenario
//! files and the run's outputs (Neko log, JSONL trace).

pub use nekosim_actors::*;

pub mod check;
pub mod cli;
pub mod log;
pub mod output;
pub mod recording;
pub mod runner;
pub mod scenario;
pub mod trace;
