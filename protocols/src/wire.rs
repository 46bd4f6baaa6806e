//! The names and values that travel between processes (seed 3.4-3.5): process ids, layer
//! indices, broadcast message ids and message contents. Everything is `Eq + Hash + Ord` so
//! protocol states and messages can be explored by a model checker; the layered wire format
//! is [`crate::payload`], the application's messages [`crate::app`].

use std::fmt;

use serde::{Deserialize, Serialize};

/// A process (robot) id; processes of a run are `0..n`.
pub type Pid = u32;

/// A layer's index in its process's stack (the same in every process).
pub type LayerIx = u16;
/// The network, below every stack.
pub const NET: LayerIx = LayerIx::MAX;
/// The robot's algorithm, on top of every stack.
pub const APP: LayerIx = LayerIx::MAX - 1;

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
