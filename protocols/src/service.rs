//! The interfaces between microprotocols (seed 3.5): the services a layer provides and needs
//! ([`Service`]), what a layer can ask of the layer below or of a layer it uses
//! ([`Request`]), what it tells the layers above ([`Indication`]), and the effects a handler
//! produces, as data ([`Effect`]), in the spirit of stateright's `Out`. Messages cross these
//! interfaces as [`Payload`]s; a protocol's handlers see its own types
//! ([`crate::Microprotocol`]).

use serde::{Deserialize, Serialize};

use crate::payload::Payload;
use crate::wire::{MsgId, Pid, Real};
// Where a request or an indication comes from and goes: named with the services.
pub use crate::wire::{LayerIx, APP, NET};

/// What a handler knows of its setting. Protocols are time-free: they react to messages,
/// requests and timers only, so a model checker can explore them without clocks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Ctx {
    /// This process.
    pub me: Pid,
    /// Number of processes, `0..n`.
    pub n: u32,
}

impl Ctx {
    /// Every process but this one.
    pub fn others(&self) -> Vec<Pid> {
        (0..self.n).filter(|&p| p != self.me).collect()
    }

    /// Every process.
    pub fn all(&self) -> Vec<Pid> {
        (0..self.n).collect()
    }

    /// A majority: ⌊n/2⌋ + 1.
    pub fn majority(&self) -> usize {
        self.n as usize / 2 + 1
    }
}

/// A service request to a lower layer.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Request {
    /// Send to a set of processes (multicast is native).
    Send { to: Vec<Pid>, msg: Payload },
    /// Broadcast to every process, this one included.
    Broadcast { msg: Payload },
    /// Propose a value to consensus instance `k`.
    Propose { k: u64, value: Payload },
    /// A request of a service a user defines: its own message, encoded (see
    /// [`Payload::decode`]).
    Custom(Payload),
}

/// A service indication to the layers above.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Indication {
    /// A message from `from` arrived (point-to-point service).
    Deliver { from: Pid, msg: Payload },
    /// A broadcast message is delivered (broadcast services).
    BDeliver { id: MsgId, msg: Payload },
    /// Consensus instance `k` decided.
    Decide { k: u64, value: Payload },
    /// A failure detector suspects a process.
    Suspect(Pid),
    /// A failure detector trusts a process again.
    Trust(Pid),
    /// Omega's leader changed.
    Leader(Pid),
    /// An indication of a service a user defines: its own message, encoded.
    Custom(Payload),
}

/// What reaches a layer.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Input {
    /// The process starts.
    Start,
    /// A request from the layer (or application) `from` above.
    Request { from: LayerIx, req: Request },
    /// An indication from the layer `from` below, or from a layer this one uses.
    Indication { from: LayerIx, ind: Indication },
    /// A timer of this layer fired (the layer's own timer value, encoded).
    Timer(Payload),
}

/// An effect of a handler.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Effect {
    /// A request to the layer below (the network at the bottom).
    Down(Request),
    /// A request to the `slot`-th layer this layer uses.
    Use {
        slot: u8,
        req: Request,
    },
    /// An indication to the layer `to` above, or to every layer above and using this one.
    Up {
        to: Option<LayerIx>,
        ind: Indication,
    },
    /// Fire `timer` (the layer's own timer value, encoded) after `after` seconds (the
    /// simulator's time; a model checker fires timers whenever it likes). Setting a timer
    /// that is already set moves it.
    SetTimer {
        timer: Payload,
        after: Real,
    },
    CancelTimer(Payload),
}

/// A service a layer provides to the layers above or needs from the layer below and the
/// layers it uses (seed 3.5: Neko's layers are typed by their interfaces). Services are
/// values, so a user defines one as a constant:
///
/// ```
/// use nekosim_protocols::Service;
/// const GOSSIP: Service = Service::new("Gossip", "gossip dissemination", &[Service::BROADCAST]);
/// assert!(GOSSIP.serves(Service::BROADCAST));
/// assert!(!Service::BROADCAST.serves(GOSSIP));
/// ```
#[derive(Clone, Copy, Debug)]
pub struct Service {
    /// Its name (services are equal when their names are).
    pub name: &'static str,
    /// What it is, in words (for wiring errors).
    pub what: &'static str,
    /// Services a layer providing this one also provides (FIFO links are links).
    pub implies: &'static [Service],
}

impl Service {
    /// Point-to-point send/deliver.
    pub const P2P: Service = Service::new("P2p", "point-to-point messages", &[]);
    /// Point-to-point with per-link FIFO order.
    pub const FIFO_P2P: Service =
        Service::new("FifoP2p", "FIFO point-to-point messages", &[Service::P2P]);
    /// Broadcast/deliver.
    pub const BROADCAST: Service = Service::new("Broadcast", "broadcast", &[]);
    /// Broadcast with total order.
    pub const TOTAL_ORDER: Service =
        Service::new("TotalOrder", "total-order broadcast", &[Service::BROADCAST]);
    /// Consensus on a sequence of instances.
    pub const CONSENSUS: Service = Service::new("Consensus", "consensus", &[]);
    /// Suspicions and trust of processes.
    pub const FAILURE_DETECTOR: Service =
        Service::new("FailureDetector", "a failure detector", &[]);
    /// Leader election (Omega).
    pub const LEADER: Service = Service::new("Leader", "leader election", &[]);

    /// A service `name`, described as `what`, that also provides `implies`.
    pub const fn new(name: &'static str, what: &'static str, implies: &'static [Service]) -> Self {
        Self {
            name,
            what,
            implies,
        }
    }

    /// Whether a layer providing `self` can serve a need for `need`.
    pub fn serves(self, need: Service) -> bool {
        self == need || self.implies.iter().any(|s| s.serves(need))
    }
}

impl PartialEq for Service {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

impl Eq for Service {}

impl std::hash::Hash for Service {
    fn hash<H: std::hash::Hasher>(&self, state: &mut H) {
        self.name.hash(state)
    }
}

/// What a protocol provides and needs, as checked by [`crate::Wiring`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Shape {
    /// Service to the layers above.
    pub provides: Service,
    /// Service needed from the layer below.
    pub needs_below: Service,
    /// Services needed from used layers, in `uses` order.
    pub needs_uses: Vec<Service>,
}

impl Shape {
    /// Provides `provides` on top of point-to-point links, using no other layer.
    pub fn on_links(provides: Service) -> Self {
        Self {
            provides,
            needs_below: Service::P2P,
            needs_uses: Vec::new(),
        }
    }
}
