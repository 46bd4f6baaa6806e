//! How hosts read payloads without knowing the protocols' types: each layer's [`Codec`]
//! (monomorphised functions of its protocol that render and rename its encoded messages and
//! timers), a stack's [`Codecs`], and the codecs in force on a thread ([`install`],
//! [`render`]), with which a [`Payload`] displays as the message it encodes.

use std::cell::RefCell;
use std::fmt;
use std::marker::PhantomData;
use std::sync::Arc;

use crate::payload::{Payload, WireError};
use crate::symmetry::Rename;
use crate::wire::{LayerIx, APP};

/// How a host renders the messages of one layer: monomorphised functions of the layer's
/// protocol (see [`crate::Microprotocol::render`]).
#[derive(Clone, Copy)]
pub struct Codec {
    /// The protocol's registered name (or `"app"`).
    pub protocol: &'static str,
    /// Writes the readable form of an encoded message, or fails to decode it.
    pub render: fn(&[u8], &mut fmt::Formatter<'_>) -> Result<fmt::Result, WireError>,
    /// Writes an encoded timer (its `Debug`), or fails to decode it.
    pub render_timer: fn(&[u8], &mut fmt::Formatter<'_>) -> Result<fmt::Result, WireError>,
    /// Renames the process ids in an encoded message ([`crate::symmetry`]), or `None` if the
    /// protocol does not declare symmetry.
    pub rename: fn(&[u8], &Rename) -> Option<Vec<u8>>,
    /// Renames the process ids in an encoded timer.
    pub rename_timer: fn(&[u8], &Rename) -> Option<Vec<u8>>,
}

impl fmt::Debug for Codec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Codec({})", self.protocol)
    }
}

impl PartialEq for Codec {
    fn eq(&self, other: &Self) -> bool {
        self.protocol == other.protocol
    }
}

impl Eq for Codec {}

impl std::hash::Hash for Codec {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.protocol.hash(state)
    }
}

/// The codecs of a stack's layers by index, plus the application's.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Codecs {
    pub layers: Vec<Codec>,
    pub app: Codec,
}

impl Codecs {
    /// The codec of the layer `layer` ([`APP`] for the application's).
    pub fn get(&self, layer: LayerIx) -> Option<&Codec> {
        if layer == APP {
            Some(&self.app)
        } else {
            self.layers.get(layer as usize)
        }
    }
}

thread_local! {
    static CODECS: RefCell<Vec<Arc<Codecs>>> = const { RefCell::new(Vec::new()) };
}

/// Renders `value` (a payload, a message holding payloads, ...) with `codecs` in force, so
/// every [`Payload`] inside prints as the readable form of the message it encodes.
pub fn render<T: fmt::Display + ?Sized>(codecs: &Arc<Codecs>, value: &T) -> String {
    with_codecs(codecs, || value.to_string())
}

/// Runs `f` with `codecs` in force for the `Display` and `Debug` of payloads.
pub fn with_codecs<R>(codecs: &Arc<Codecs>, f: impl FnOnce() -> R) -> R {
    let _in_force = install(codecs);
    f()
}

/// Puts `codecs` in force on this thread until the guard is dropped.
pub fn install(codecs: &Arc<Codecs>) -> CodecsGuard {
    CODECS.with(|c| c.borrow_mut().push(Arc::clone(codecs)));
    CodecsGuard(PhantomData)
}

/// Keeps codecs in force on its thread ([`install`]); not `Send`.
#[derive(Debug)]
pub struct CodecsGuard(PhantomData<*const ()>);

impl Drop for CodecsGuard {
    fn drop(&mut self) {
        CODECS.with(|c| c.borrow_mut().pop());
    }
}

/// The first word of a rendering: Neko's message type (`FIFO`, `LAMPORT_ACK`, `GOTO`).
pub fn type_word(rendered: &str) -> &str {
    let end = rendered
        .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == '.'))
        .unwrap_or(rendered.len());
    &rendered[..end]
}

/// Readable: the message it encodes when codecs are in force ([`render`]), otherwise its
/// layer and size.
impl fmt::Display for Payload {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let codecs = CODECS.with(|c| c.borrow().last().cloned());
        if let Some(codec) = codecs.as_ref().and_then(|c| c.get(self.layer())) {
            match (codec.render)(self.bytes(), f) {
                Ok(r) => return r,
                Err(e) => return write!(f, "<{}: {e}>", codec.protocol),
            }
        }
        write!(
            f,
            "<{} bytes of layer {}>",
            self.bytes().len(),
            self.layer()
        )
    }
}

impl fmt::Debug for Payload {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

impl Payload {
    /// This payload with its process ids renamed by its layer's codec in `codecs` (a timer
    /// when `timer`), or `None` if that layer does not declare symmetry.
    pub fn renamed_with(&self, codecs: &Codecs, r: &Rename, timer: bool) -> Option<Self> {
        let codec = codecs.get(self.layer())?;
        let rename = if timer {
            codec.rename_timer
        } else {
            codec.rename
        };
        Some(Self::from_parts(self.layer(), &rename(self.bytes(), r)?))
    }
}
