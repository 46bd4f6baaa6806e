//! The nekosim engine: a deterministic, event-driven simulator of cooperative mobile robots,
//! rebuilt from the Neko robot simulation engine (Sangsubhan, 2009; "the seed").
//!
//! - [`world`]: the pure kernel (geometry, motion patterns, exact collision prediction, the
//!   spatial index, the virtual world), free of actix.
//! - [`scheduler`]: the virtual-time scheduler actor and its ordering contract; [`kernel`]: the
//!   same handling code driven without actors (the reference the engine bench compares with).
//! - [`motion_manager`], [`sensor_manager`], [`robot`], [`sensor`]: the other actors.
//! - [`algorithm`]: built-in robot algorithms; [`behaviour`]: composable behaviours (seed 7.2);
//!   [`simulation`]: building and running a run.

pub mod algorithm;
pub mod behaviour;
pub mod kernel;
pub mod layer;
pub mod motion_manager;
pub mod network;
pub mod registry;
pub mod robot;
pub mod scheduler;
pub mod sensor;
pub mod sensor_manager;
pub mod simulation;
pub mod world;

pub use robot::{Algorithm, AlgorithmFuture, MotionEnd, Received, Robot};
pub use simulation::{run, run_then_exit, Comms, Fault, SimConfig, SimError};
