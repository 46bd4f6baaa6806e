//! What one check is made of: its parameters ([`Options`], [`NetworkKind`]), what its
//! properties and boundary read ([`ModelCfg`]), and the stateright types of the model.

use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use nekosim_protocols::{Layer, Pid, Request, StackProperty};
#[cfg(doc)]
use nekosim_protocols::{Protocols, Rounds};
use stateright::actor::{ActorModel, ActorModelAction};
use stateright::Expectation;

use crate::adapter::{ModelTimer, NetMsg, ProcessActor, ProcessState, State};
use crate::family::Family;
use crate::symmetry::Symmetry;

/// A model as stateright checks it.
pub type CheckModel = ActorModel<ProcessActor, ModelCfg, ()>;
/// One step of a model.
pub type Action = ActorModelAction<NetMsg, ModelTimer, ()>;

pub use crate::adapter::UNLIMITED_TIMERS;

/// How the network treats messages between processes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum NetworkKind {
    /// Every message is delivered exactly once, in any order.
    #[default]
    Unordered,
    /// Every message is delivered exactly once, in order per (sender, receiver) pair.
    Ordered,
    /// Any message may also be lost (unordered otherwise).
    Lossy,
}

impl NetworkKind {
    /// The names the command accepts.
    pub const NAMES: [&'static str; 3] = ["unordered", "ordered", "lossy"];

    /// Parses a name of [`NetworkKind::NAMES`].
    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "unordered" => Some(Self::Unordered),
            "ordered" => Some(Self::Ordered),
            "lossy" => Some(Self::Lossy),
            _ => None,
        }
    }
}

/// The parameters of one check.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Number of processes.
    pub processes: u32,
    /// Client requests (broadcasts or proposals), handed out to the processes round-robin.
    pub requests: u32,
    /// Processes that may crash (crash-stop).
    pub crashes: u32,
    pub network: NetworkKind,
    /// Protocol timer firings allowed per process ([`UNLIMITED_TIMERS`]: no limit).
    pub timer_budget: u32,
    /// Last Chandra-Toueg round explored in each instance: states with a message of a later
    /// round are outside the model. Round 1 is the least that lets round 0 decide, as a
    /// process that acks round 0 moves on to round 1 in the same step.
    pub max_round: u64,
    /// With crashes, a multicast leaves one message at a time, so a crash can cut it short
    /// (what reliable broadcast must survive). Off, a multicast leaves at once, which keeps
    /// heartbeat-driven stacks with crashes small enough to explore.
    pub partial_multicasts: bool,
    /// Symmetry reduction: explore one state of each class of states equal up to a renaming
    /// of the processes ([`crate::symmetry`]). Needs every layer to declare symmetry, the
    /// same stack at every process and multicasts that leave at once; breadth-first only.
    pub symmetry: bool,
    /// The breadth-first search's reductions. Partial-order reduction ([`crate::reduction`]):
    /// where a set of processes' steps is provably enough, explore only those; without a
    /// depth bound, on an ordered network. Spent messages ([`crate::model::spent`]): on a
    /// network that reorders messages, forget those that can no longer change their
    /// receiver.
    pub reduction: bool,
    /// With `reduction`, on a network that reorders but never loses: when every layer on the
    /// network holds early arrivals back ([`nekosim_protocols::Microprotocol::HOLDS_EARLY`]),
    /// deliver each link's messages in send order only ([`crate::reduction`], "Early
    /// arrivals"), so that partial-order reduction applies. The liveness graph turns it off.
    pub defer_early: bool,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            processes: 3,
            requests: 2,
            crashes: 0,
            network: NetworkKind::Unordered,
            timer_budget: 1,
            max_round: 1,
            partial_multicasts: true,
            symmetry: false,
            reduction: true,
            defer_early: true,
        }
    }
}

/// What the properties and the boundary need to know about a model.
#[derive(Clone, Debug)]
pub struct ModelCfg {
    pub family: Family,
    pub n: u32,
    /// Every client request in global order: request `g` is issued by process `g mod n`.
    pub requests: Vec<(Pid, Request)>,
    pub timer_budget: u32,
    /// Round bound, when a layer runs numbered rounds ([`Rounds::Numbered`]).
    pub max_round: Option<u64>,
    /// By index, each layer whose messages the round bound reads: numbered rounds, or headers
    /// it looks through ([`Rounds::Carried`]).
    pub round_layers: Vec<Option<Layer>>,
    /// Set when a budget ran out: from then on no new state is inside the model, so the
    /// search drains what it holds and ends (see [`crate::budget::Budget`]).
    pub stop: Arc<AtomicBool>,
    /// The properties the stack's protocols state themselves ([`Protocols::invariant`],
    /// [`Protocols::reachable`]).
    pub stated: Vec<StackProperty>,
    /// Every property's expectation and condition, in the model's order; the model's own
    /// conditions report only the first discovery of each.
    pub conditions: Vec<(Expectation, Condition)>,
    /// Every property's [`Undo`], in the model's order: which steps the partial-order
    /// reduction must not leave to later.
    pub undo: Vec<Undo>,
    /// The reductions are on ([`Options::reduction`]).
    pub reduction: bool,
    /// Each link's messages are delivered in send order, the network reordering none
    /// ([`Options::defer_early`] took effect).
    pub in_send_order: bool,
    /// Whether property `i` has had its discovery (reset by [`crate::model::run`]).
    pub found: Arc<Vec<AtomicBool>>,
    /// The renamings that map the model onto itself, when symmetry reduction is on
    /// ([`Options::symmetry`]; breadth-first search only).
    pub symmetry: Option<Arc<Symmetry>>,
}

/// A property's condition.
pub type Condition = fn(&CheckModel, &State) -> bool;

/// Whether one step of a process, from its state `before` to `after`, may undo a discovery
/// of a property wherever the other processes stand: make an `always` property hold again
/// after it failed, or a `sometimes` property fail again after it held
/// ([`crate::reduction`]). A crash is never judged: states where one can happen are fully
/// expanded.
pub type Undo = fn(&ModelCfg, before: &ProcessState, after: &ProcessState) -> bool;
