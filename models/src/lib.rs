//! Stateright models that explore every interleaving of the protocols in `nekosim-protocols`:
//! the very code the simulator runs, not a re-implementation.
//!
//! - [`adapter`]: one process's stack as one stateright actor.
//! - [`config`]: what one check is made of: its options, network semantics and what its
//!   properties read.
//! - [`family`]: the services the checker knows, which decide the properties.
//! - [`model`]: building a model from a stack (crashes, bounds) and running the checker.
//! - [`liveness`]: liveness under fairness on any explicit-state transition system, with
//!   lasso counterexamples (the Look-Compute-Move checks use it).
//! - [`compact`]: the breadth-first search over compact states (collapse compression);
//!   [`spill`]: its visited set and frontier moved to disk when memory runs short.
//! - [`property`]: the properties of each protocol family.
//! - [`reason`]: why a counterexample violates its property, in the property's terms.
//! - [`registry`]: the shipped models as Rust targets, for this crate's tests and benches
//!   (`nekosim check NAME` reads the same stacks from `examples/check/*.ron`; a test keeps
//!   the two equal).
//! - [`symmetry`]: symmetry reduction for stacks whose processes are alike.
//! - [`reduction`]: partial-order reduction, exploring the steps of a few processes only
//!   where that provably keeps every verdict.
//! - [`temporal`]: each family's liveness as temporal properties, decided by [`liveness`] on
//!   the model's whole graph under fair delivery, fair timers, fair loss and eventual
//!   accuracy.
//! - [`explain`]: a path of the checker as a sequence of messages, deliveries and decisions.
//!
//! See docs/model-checking.md for what is checked and under which assumptions.

pub mod adapter;
pub mod budget;
pub mod compact;
pub mod config;
pub mod explain;
pub mod family;
pub mod liveness;
pub mod model;
pub mod property;
pub mod reason;
pub mod reduction;
pub mod registry;
pub mod rest;
pub mod spill;
pub mod symmetry;
pub mod temporal;

pub use adapter::State;
pub use budget::{available_memory, resident_memory, Budget, Stopped};
pub use config::{CheckModel, NetworkKind, Options};
pub use family::Family;
pub use model::{
    build, build_in, run, run_watched, Discovery, Exploration, ModelError, Outcome, Progress,
    Strategy, Target, Verdict, Watch, SIMULATION_STATES,
};
pub use registry::{find, ModelDef, MODELS};
