//! The interfaces between microprotocols (seed 3.5): what a layer can ask of the layer below
//! or of a layer it uses ([`Request`]), what it tells the layers above ([`Indication`]), and the
//! effects a handler produces, as data ([`Out`]), in the spirit of stateright's `Out`.

use serde::{Deserialize, Serialize};

use crate::wire::{MsgId, Pid, Real, Wire};

/// A layer's index in its process's stack (the same in every process).
pub type LayerIx = u16;
/// The network, below every stack.
pub const NET: LayerIx = LayerIx::MAX;
/// The robot's algorithm, on top of every stack.
pub const APP: LayerIx = LayerIx::MAX - 1;

/// A protocol-defined timer.
pub type TimerId = u32;

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
    Send { to: Vec<Pid>, msg: Wire },
    /// Broadcast to every process, this one included.
    Broadcast { msg: Wire },
    /// Propose a value to consensus instance `k`.
    Propose { k: u64, value: Wire },
}

/// A service indication to the layers above.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Indication {
    /// A message from `from` arrived (point-to-point service).
    Deliver { from: Pid, msg: Wire },
    /// A broadcast message is delivered (broadcast services).
    BDeliver { id: MsgId, msg: Wire },
    /// Consensus instance `k` decided.
    Decide { k: u64, value: Wire },
    /// A failure detector suspects a process.
    Suspect(Pid),
    /// A failure detector trusts a process again.
    Trust(Pid),
    /// Omega's leader changed.
    Leader(Pid),
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
    /// A timer of this layer fired.
    Timer(TimerId),
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
    /// Fire `timer` after `after` seconds (the simulator's time; a model checker fires timers
    /// whenever it likes).
    SetTimer {
        timer: TimerId,
        after: Real,
    },
    CancelTimer(TimerId),
}

/// Collects a handler's effects.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Out {
    pub effects: Vec<Effect>,
}

impl Out {
    /// An empty collection.
    pub fn new() -> Self {
        Self::default()
    }

    /// Sends `msg` to `to` through the layer below.
    pub fn send(&mut self, to: Vec<Pid>, msg: Wire) {
        if !to.is_empty() {
            self.effects.push(Effect::Down(Request::Send { to, msg }));
        }
    }

    /// A request to the layer below.
    pub fn down(&mut self, req: Request) {
        self.effects.push(Effect::Down(req));
    }

    /// A request to a used layer.
    pub fn use_layer(&mut self, slot: u8, req: Request) {
        self.effects.push(Effect::Use { slot, req });
    }

    /// An indication to one layer above.
    pub fn up_to(&mut self, to: LayerIx, ind: Indication) {
        self.effects.push(Effect::Up { to: Some(to), ind });
    }

    /// An indication to every layer above and using this one.
    pub fn up(&mut self, ind: Indication) {
        self.effects.push(Effect::Up { to: None, ind });
    }

    /// Sets a timer.
    pub fn set_timer(&mut self, timer: TimerId, after: f64) {
        self.effects.push(Effect::SetTimer {
            timer,
            after: Real::new(after),
        });
    }
}
