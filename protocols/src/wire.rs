//! What travels between processes and between layers (seed 3.4-3.5): process ids, message
//! contents and the layered wire format. Everything is `Eq + Hash + Ord` so protocol states
//! and messages can be explored by a model checker.

use std::fmt;

use serde::{Deserialize, Serialize};

/// A process (robot) id; processes of a run are `0..n`.
pub type Pid = u32;

/// An `f64` that is `Eq`, `Ord` and `Hash` (by its bits), for message contents.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Real(u64);

impl Real {
    /// Wraps a number (NaN and -0.0 are kept as they are).
    pub fn new(v: f64) -> Self {
        Real(v.to_bits())
    }

    /// The number.
    pub fn get(self) -> f64 {
        f64::from_bits(self.0)
    }
}

impl fmt::Debug for Real {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.get())
    }
}

/// Application-level content of a message.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Content {
    None,
    Int(i64),
    Real(Real),
    Point(Real, Real),
    Text(String),
    List(Vec<Content>),
}

impl fmt::Display for Content {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Content::None => write!(f, "-"),
            Content::Int(i) => write!(f, "{i}"),
            Content::Real(r) => write!(f, "{}", r.get()),
            Content::Point(x, y) => write!(f, "[{}, {}]", x.get(), y.get()),
            Content::Text(s) => write!(f, "{s:?}"),
            Content::List(v) => {
                write!(f, "[")?;
                for (i, c) in v.iter().enumerate() {
                    write!(f, "{}{c}", if i > 0 { ", " } else { "" })?;
                }
                write!(f, "]")
            }
        }
    }
}

/// The globally unique id of a broadcast message: its origin and the origin's count.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub struct MsgId {
    pub origin: Pid,
    pub n: u64,
}

impl fmt::Display for MsgId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}", self.origin, self.n)
    }
}

/// A message as a layer hands it to the layer below: the layer's own header around the
/// payload of the layer above, down to the application's message.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Wire {
    /// An application message: Neko's message type name and content.
    App {
        kind: String,
        content: Content,
    },
    /// Fifo: per-link sequence number.
    Fifo {
        seq: u64,
        up: u16,
        inner: Box<Wire>,
    },
    /// Retransmit: data with a per-link sequence number, or its acknowledgement.
    RtData {
        seq: u64,
        up: u16,
        inner: Box<Wire>,
    },
    RtAck {
        seq: u64,
    },
    /// Reliable broadcast: a message and its id, relayed by every receiver.
    Rb {
        id: MsgId,
        inner: Box<Wire>,
    },
    /// Lamport total order: a timestamped message, or an acknowledgement carrying a clock.
    LamportMsg {
        ts: u64,
        id: MsgId,
        inner: Box<Wire>,
    },
    LamportAck {
        ts: u64,
    },
    /// Fixed sequencer: a message sent to the sequencer, and its ordering.
    SeqRequest {
        id: MsgId,
        inner: Box<Wire>,
    },
    SeqOrder {
        gseq: u64,
        id: MsgId,
        inner: Box<Wire>,
    },
    /// Heartbeat failure detector.
    Heartbeat,
    /// Chandra-Toueg consensus, instance `k`, round `r`.
    CtEstimate {
        k: u64,
        r: u64,
        est: Box<Wire>,
        ts: u64,
    },
    CtPropose {
        k: u64,
        r: u64,
        value: Box<Wire>,
    },
    CtAck {
        k: u64,
        r: u64,
    },
    CtNack {
        k: u64,
        r: u64,
    },
    CtDecide {
        k: u64,
        value: Box<Wire>,
    },
    /// A batch of broadcast messages (consensus-based atomic broadcast's proposals).
    Batch(Vec<(MsgId, Wire)>),
    /// A user-defined protocol's message.
    Custom {
        protocol: String,
        tag: String,
        data: Content,
        inner: Option<Box<Wire>>,
    },
}

impl Wire {
    /// An application message.
    pub fn app(kind: &str, content: Content) -> Self {
        Wire::App {
            kind: kind.to_string(),
            content,
        }
    }

    /// The application message inside all the headers, if any.
    pub fn app_part(&self) -> Option<(&str, &Content)> {
        match self {
            Wire::App { kind, content } => Some((kind, content)),
            Wire::Fifo { inner, .. }
            | Wire::RtData { inner, .. }
            | Wire::Rb { inner, .. }
            | Wire::LamportMsg { inner, .. }
            | Wire::SeqRequest { inner, .. }
            | Wire::SeqOrder { inner, .. } => inner.app_part(),
            Wire::Custom {
                inner: Some(inner), ..
            } => inner.app_part(),
            _ => None,
        }
    }

    /// The outermost header's name (Neko's message type in logs).
    pub fn type_name(&self) -> &str {
        match self {
            Wire::App { kind, .. } => kind,
            Wire::Fifo { .. } => "FIFO",
            Wire::RtData { .. } => "RT_DATA",
            Wire::RtAck { .. } => "RT_ACK",
            Wire::Rb { .. } => "RB",
            Wire::LamportMsg { .. } => "LAMPORT",
            Wire::LamportAck { .. } => "LAMPORT_ACK",
            Wire::SeqRequest { .. } => "SEQ_REQUEST",
            Wire::SeqOrder { .. } => "SEQ_ORDER",
            Wire::Heartbeat => "HEARTBEAT",
            Wire::CtEstimate { .. } => "CT_ESTIMATE",
            Wire::CtPropose { .. } => "CT_PROPOSE",
            Wire::CtAck { .. } => "CT_ACK",
            Wire::CtNack { .. } => "CT_NACK",
            Wire::CtDecide { .. } => "CT_DECIDE",
            Wire::Batch(_) => "BATCH",
            Wire::Custom { tag, .. } => tag,
        }
    }
}
