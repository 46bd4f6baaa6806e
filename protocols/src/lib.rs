//! Sans-IO microprotocols (seed 3.5): Neko's protocol library as deterministic state
//! machines whose effects are data. The simulator's actors host them (every hop an event of
//! the virtual-time scheduler) and the stateright models explore the very same code.
//!
//! - [`protocol`]: the [`Microprotocol`] trait: a protocol's own message, timer and
//!   configuration types, typed handlers and [`Out`]; [`Layer`] holds any protocol.
//! - [`wire`]: process ids, layer indices, message ids and contents; [`payload`]: the one
//!   wire encoding below the typed edge ([`Payload`]); [`codec`]: how hosts render and rename
//!   payloads without the protocols' types; [`app`]: the application's messages.
//! - [`service`]: services, requests, indications, inputs and effects.
//! - [`registry`]: protocols by name ([`Protocols::with_builtins`]); [`builtins`] lists the
//!   built-in protocols, registered exactly as a user's are.
//! - Protocols: [`fifo`], [`retransmit`], [`rbroadcast`], [`lamport`], [`sequencer`],
//!   [`heartbeat`], [`omega`], [`consensus`] (Chandra-Toueg), [`consensus_abcast`].
//! - [`stack`]: a process's stack of instances, its wiring and the routing of their effects;
//!   [`compose`]: a scenario's stack by name, checked into a wiring and a fresh stack.
//! - [`symmetry`]: renaming process ids, for a model checker's symmetry reduction.

pub mod app;
pub mod builtins;
pub mod codec;
pub mod compose;
pub mod consensus;
pub mod consensus_abcast;
pub mod fifo;
pub mod heartbeat;
pub mod lamport;
pub mod omega;
pub mod payload;
pub mod protocol;
pub mod rbroadcast;
pub mod registry;
pub mod retransmit;
pub mod sequencer;
pub mod service;
pub mod stack;
pub mod symmetry;
pub mod wire;

pub use app::{app_decode, app_payload, AppMsg};
pub use compose::{LayerSpec, StackError};
pub use payload::{Payload, WireError};
pub use protocol::{
    FieldError, Layer, Message, Microprotocol, NoConfig, NoMsg, Out, Round, Rounds,
};
pub use registry::{ProtocolSpec, Protocols, Spec, SpecError, StackProperty};
pub use service::{Ctx, Effect, Indication, Input, LayerIx, Request, Service, Shape, APP, NET};
pub use stack::{Routed, Stack, Wiring};
pub use symmetry::Rename;
pub use wire::{Content, MsgId, Pid, Real};
