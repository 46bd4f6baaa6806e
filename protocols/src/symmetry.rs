//! Process symmetry: renaming every process id in a protocol's state and messages by a
//! permutation. A protocol that treats all processes alike (no fixed sequencer, no rotating
//! coordinator, no tie-break by id) says so by implementing
//! [`crate::Microprotocol::renamed`] and [`crate::Microprotocol::renamed_msg`]; a model
//! checker may then explore one state of each class of states equal up to a renaming
//! (symmetry reduction; docs/model-checking.md).
//!
//! Payloads nest (a layer's message carries the payload of the layer above), so a protocol
//! renames the payloads inside its messages with [`Rename::payload`], which the host answers
//! with the codec of the payload's own layer.

use std::fmt;

use crate::payload::Payload;
use crate::wire::{MsgId, Pid};

/// A renaming of process ids: process `p` becomes `to[p]`.
pub struct Rename<'a> {
    to: &'a [Pid],
    payload: &'a dyn Fn(&Payload, &Rename) -> Option<Payload>,
}

impl fmt::Debug for Rename<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Rename").field("to", &self.to).finish()
    }
}

impl<'a> Rename<'a> {
    /// Process `p` becomes `to[p]` (a permutation of `0..to.len()`); `payload` renames a
    /// payload of any layer (the host's dispatch by the payload's layer).
    pub fn new(to: &'a [Pid], payload: &'a dyn Fn(&Payload, &Rename) -> Option<Payload>) -> Self {
        Self { to, payload }
    }

    /// The new id of process `p`.
    pub fn pid(&self, p: Pid) -> Pid {
        self.to[p as usize]
    }

    /// A message id with its origin renamed.
    pub fn msg_id(&self, id: MsgId) -> MsgId {
        MsgId {
            origin: self.pid(id.origin),
            n: id.n,
        }
    }

    /// A payload of any layer renamed, or `None` if its layer is not symmetric.
    pub fn payload(&self, p: &Payload) -> Option<Payload> {
        (self.payload)(p, self)
    }

    /// The permutation, `to[p]` for each process `p`.
    pub fn permutation(&self) -> &[Pid] {
        self.to
    }
}

/// A codec entry for what cannot be renamed (the application's messages, which only the
/// host knows how to rename).
pub fn not_renamed(_: &[u8], _: &Rename) -> Option<Vec<u8>> {
    None
}
