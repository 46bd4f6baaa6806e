//! The shipped models, by name: each is a scenario-style stack, the layer the application
//! talks to and the family of properties it promises. `nekosim check NAME` reads the same
//! stacks from `examples/check/*.ron` (a test in the main crate keeps the two equal); this
//! crate's tests and benches use these.

use nekosim_protocols::LayerSpec;

use crate::family::Family;
use crate::model::Target;

/// A named model.
#[derive(Clone, Copy, Debug)]
pub struct ModelDef {
    pub name: &'static str,
    /// One line saying what is checked.
    pub about: &'static str,
    target: fn() -> Target,
}

impl ModelDef {
    /// The stack, entry layer and family.
    pub fn target(&self) -> Target {
        (self.target)()
    }
}

fn layer(id: &str, protocol: &str, below: &str, uses: &[&str]) -> LayerSpec {
    LayerSpec::new(id, protocol, below, uses)
}

/// The failure detector of the consensus stacks. Its periods do not matter to the checker,
/// which fires timers whenever it likes.
fn heartbeat() -> LayerSpec {
    layer("fd", "Heartbeat(period: 1.0, timeout: 2.0)", "net", &[])
}

/// Lamport total-order broadcast over FIFO links.
pub fn lamport_abcast() -> Target {
    Target {
        stack: vec![
            layer("fifo", "Fifo", "net", &[]),
            layer("abcast", "LamportAbcast", "fifo", &[]),
        ],
        entry: "abcast".into(),
        family: Family::Abcast,
        timer_fed: Vec::new(),
    }
}

/// Fixed-sequencer total-order broadcast (process 0 orders).
pub fn sequencer_abcast() -> Target {
    Target {
        stack: vec![layer("abcast", "FixedSequencer", "net", &[])],
        entry: "abcast".into(),
        family: Family::Abcast,
        timer_fed: Vec::new(),
    }
}

/// Consensus-based total-order broadcast: reliable broadcast plus Chandra-Toueg instances.
pub fn consensus_abcast() -> Target {
    Target {
        stack: vec![
            heartbeat(),
            layer("rb", "ReliableBroadcast", "net", &[]),
            layer("consensus", "ChandraToueg", "net", &["fd"]),
            layer("abcast", "ConsensusAbcast", "rb", &["consensus"]),
        ],
        entry: "abcast".into(),
        family: Family::Abcast,
        timer_fed: vec!["fd".into()],
    }
}

/// Chandra-Toueg consensus with a heartbeat failure detector.
pub fn ct_consensus() -> Target {
    Target {
        stack: vec![
            heartbeat(),
            layer("consensus", "ChandraToueg", "net", &["fd"]),
        ],
        entry: "consensus".into(),
        family: Family::Consensus,
        timer_fed: vec!["fd".into()],
    }
}

/// Reliable broadcast by eager relay.
pub fn reliable_broadcast() -> Target {
    Target {
        stack: vec![layer("rb", "ReliableBroadcast", "net", &[])],
        entry: "rb".into(),
        family: Family::Broadcast,
        timer_fed: Vec::new(),
    }
}

/// Every model, in the order `nekosim check --list` prints them.
pub const MODELS: [ModelDef; 5] = [
    ModelDef {
        name: "lamport-abcast",
        about: "Lamport total-order broadcast over Fifo",
        target: lamport_abcast,
    },
    ModelDef {
        name: "sequencer-abcast",
        about: "fixed-sequencer total-order broadcast",
        target: sequencer_abcast,
    },
    ModelDef {
        name: "consensus-abcast",
        about: "consensus-based total-order broadcast (RBroadcast + Chandra-Toueg + Heartbeat)",
        target: consensus_abcast,
    },
    ModelDef {
        name: "ct-consensus",
        about: "Chandra-Toueg consensus with a Heartbeat failure detector",
        target: ct_consensus,
    },
    ModelDef {
        name: "reliable-broadcast",
        about: "reliable broadcast by eager relay",
        target: reliable_broadcast,
    },
];

/// The model called `name`.
pub fn find(name: &str) -> Option<&'static ModelDef> {
    MODELS.iter().find(|m| m.name == name)
}
