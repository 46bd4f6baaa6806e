//! Sans-IO microprotocols (seed 3.5): Neko's protocol library as deterministic state
//! machines whose effects are data. The simulator's actors host them (every hop an event of
//! the virtual-time scheduler) and the stateright models explore the very same code.
//!
//! - [`wire`]: process ids, contents, the layered wire format; [`service`]: requests,
//!   indications, inputs and effects; [`protocol`]: the [`Microprotocol`] trait.
//! - Protocols: [`fifo`], [`retransmit`], [`rbroadcast`], [`lamport`], [`sequencer`],
//!   [`heartbeat`], [`omega`], [`consensus`] (Chandra-Toueg), [`consensus_abcast`].
//! - [`stack`]: composition by name, wiring checks and effect routing; [`custom`]: user
//!   protocols registered by name.

pub mod consensus;
pub mod consensus_abcast;
pub mod custom;
pub mod fifo;
pub mod heartbeat;
pub mod lamport;
pub mod omega;
pub mod protocol;
pub mod rbroadcast;
pub mod retransmit;
pub mod sequencer;
pub mod service;
pub mod stack;
pub mod wire;

pub use custom::{CustomLayer, Protocols, Shape};
pub use protocol::Microprotocol;
pub use service::{Ctx, Effect, Indication, Input, LayerIx, Out, Request, APP, NET};
pub use stack::{Layer, LayerSpec, ProtocolSpec, Routed, Stack, StackError, Wiring};
pub use wire::{Content, MsgId, Pid, Real, Wire};
