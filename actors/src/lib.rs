//! The nekosim engine.
pub mod world;
