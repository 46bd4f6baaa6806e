//! The one wire encoding (seed 3.4: Neko's messages carry their content across layers and
//! networks). Below the typed edge of a protocol, every message is a [`Payload`]: the
//! compact postcard encoding of one layer's own message type, tagged with the index of the
//! layer that encoded it. A message travelling down the stack nests: a layer's message holds
//! the payload of the layer above as an opaque field. The same bytes are what the simulator
//! carries, what the model checker stores in its states and what a real network sends.
//!
//! The tag makes a payload self-describing within a stack (every process runs the same
//! layers at the same indices), so hosts can render any payload readably ([`Codec`],
//! [`render`]) without knowing the protocols' types.

use std::cell::RefCell;
use std::fmt;
use std::marker::PhantomData;
use std::sync::Arc;

use serde::de::{DeserializeOwned, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::service::{LayerIx, APP};
use crate::symmetry::Rename;

/// An encoded message of the layer (or the application, [`APP`]) with index `layer`.
///
/// Equality, order and hashing are those of the tag and bytes; cloning shares the bytes.
#[derive(Clone, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Payload {
    layer: LayerIx,
    bytes: Arc<[u8]>,
}

/// A value that cannot be encoded or decoded (a type whose serde form postcard does not
/// support, or bytes that are not an encoding of the expected type).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("wire encoding: {0}")]
pub struct WireError(pub String);

impl Payload {
    /// Encodes `msg` as a message of the layer `layer`.
    ///
    /// # Panics
    /// If `msg`'s serde form cannot be encoded by postcard (`serialize_any`-only types such
    /// as untagged enums); message types deriving `Serialize` always can.
    pub fn encode<M: Serialize>(layer: LayerIx, msg: &M) -> Self {
        Self::try_encode(layer, msg).unwrap_or_else(|e| panic!("{e}"))
    }

    /// Encodes `msg` as a message of the layer `layer`, or says why it cannot.
    pub fn try_encode<M: Serialize>(layer: LayerIx, msg: &M) -> Result<Self, WireError> {
        let bytes = postcard::to_allocvec(msg).map_err(|e| WireError(e.to_string()))?;
        Ok(Self {
            layer,
            bytes: bytes.into(),
        })
    }

    /// Raw parts: a payload received from elsewhere (a socket).
    pub fn from_parts(layer: LayerIx, bytes: &[u8]) -> Self {
        Self {
            layer,
            bytes: bytes.into(),
        }
    }

    /// The index of the layer that encoded it ([`APP`] for the application).
    pub fn layer(&self) -> LayerIx {
        self.layer
    }

    /// The encoded message.
    pub fn bytes(&self) -> &[u8] {
        &self.bytes
    }

    /// Decodes the message as an `M` (the whole encoding must be used).
    pub fn decode<M: DeserializeOwned>(&self) -> Result<M, WireError> {
        decode_bytes(&self.bytes)
    }
}

impl Payload {
    /// This payload with its process ids renamed by its layer's codec in `codecs` (a timer
    /// when `timer`), or `None` if that layer does not declare symmetry.
    pub fn renamed_with(&self, codecs: &Codecs, r: &Rename, timer: bool) -> Option<Self> {
        let codec = codecs.get(self.layer)?;
        let rename = if timer {
            codec.rename_timer
        } else {
            codec.rename
        };
        Some(Self::from_parts(self.layer, &rename(&self.bytes, r)?))
    }
}

/// Decodes `bytes` as an `M`, using every byte.
pub fn decode_bytes<M: DeserializeOwned>(bytes: &[u8]) -> Result<M, WireError> {
    let (m, rest) = postcard::take_from_bytes(bytes).map_err(|e| WireError(e.to_string()))?;
    if rest.is_empty() {
        Ok(m)
    } else {
        Err(WireError(format!("{} bytes left over", rest.len())))
    }
}

struct Bytes<'a>(&'a [u8]);

impl Serialize for Bytes<'_> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bytes(self.0)
    }
}

impl Serialize for Payload {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        (self.layer, Bytes(&self.bytes)).serialize(s)
    }
}

struct BytesVisitor;

impl<'de> Visitor<'de> for BytesVisitor {
    type Value = Arc<[u8]>;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("bytes")
    }

    fn visit_bytes<E: serde::de::Error>(self, v: &[u8]) -> Result<Self::Value, E> {
        Ok(v.into())
    }

    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let mut v = Vec::new();
        while let Some(b) = seq.next_element::<u8>()? {
            v.push(b);
        }
        Ok(v.into())
    }
}

struct OwnedBytes(Arc<[u8]>);

impl<'de> Deserialize<'de> for OwnedBytes {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_bytes(BytesVisitor).map(OwnedBytes)
    }
}

impl<'de> Deserialize<'de> for Payload {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let (layer, OwnedBytes(bytes)) = <(LayerIx, OwnedBytes)>::deserialize(d)?;
        Ok(Self { layer, bytes })
    }
}

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
        if let Some(codec) = codecs.as_ref().and_then(|c| c.get(self.layer)) {
            match (codec.render)(&self.bytes, f) {
                Ok(r) => return r,
                Err(e) => return write!(f, "<{}: {e}>", codec.protocol),
            }
        }
        write!(f, "<{} bytes of layer {}>", self.bytes.len(), self.layer)
    }
}

impl fmt::Debug for Payload {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Clone, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
    enum Msg {
        Data { seq: u64, payload: Payload },
        Ack(u64),
    }

    #[test]
    fn nested_payloads_round_trip_and_stay_compact() {
        let inner = Payload::encode(APP, &("GOTO".to_string(), 3u8));
        let outer = Payload::encode(
            0,
            &Msg::Data {
                seq: 5,
                payload: inner.clone(),
            },
        );
        // variant 1 byte + seq 1 byte + tag 3 bytes (65534 as varint) + length 1 byte + 6.
        assert_eq!(outer.bytes().len(), 1 + 1 + 3 + 1 + inner.bytes().len());
        let back: Msg = outer.decode().unwrap();
        assert_eq!(
            back,
            Msg::Data {
                seq: 5,
                payload: inner
            }
        );
        assert!(
            outer.decode::<u64>().is_err(),
            "bytes left over are refused"
        );
        assert!(Payload::from_parts(0, &[9]).decode::<Msg>().is_err());
    }
}
