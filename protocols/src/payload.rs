//! The one wire encoding (seed 3.4: Neko's messages carry their content across layers and
//! networks). Below the typed edge of a protocol, every message is a [`Payload`]: the
//! compact postcard encoding of one layer's own message type, tagged with the index of the
//! layer that encoded it. A message travelling down the stack nests: a layer's message holds
//! the payload of the layer above as an opaque field. The same bytes are what the simulator
//! carries, what the model checker stores in its states and what a real network sends.
//!
//! The tag makes a payload self-describing within a stack (every process runs the same
//! layers at the same indices), so hosts can render and rename any payload
//! ([`crate::codec`], where a payload's `Display` is) without knowing the protocols' types.

use std::fmt;
use std::sync::Arc;

use serde::de::{DeserializeOwned, Visitor};
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::wire::LayerIx;

/// An encoded message of the layer (or the application, [`crate::APP`]) with index `layer`.
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

    /// The index of the layer that encoded it ([`crate::APP`] for the application).
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::APP;

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
