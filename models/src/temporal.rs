//! Temporal properties of protocol stacks: each family's liveness stated as `eventually`,
//! `eventually always` or `always eventually` of a state predicate, decided on the model's
//! whole reachable graph under the fairness the family needs, with a lasso for a property
//! that fails (a livelock: a stem, then a cycle repeated for ever).
//!
//! The graph is the very stateright model `nekosim check` searches ([`crate::model::build`]),
//! explored step by step through its own `actions` and `next_state`, without partial-order
//! or symmetry reduction: both keep what safety and at-rest properties need, not every cycle.
//! It does forget spent messages, as the breadth-first search does (on networks that reorder
//! messages, while the reductions are on): a spent message's delivery is no step, now or
//! later, so it is never an enabled task, and a state and the same state without it have the
//! same steps to the same futures, the same propositions, and the same enabled tasks; merging
//! them changes no fair cycle, so no verdict. By the same argument it forgets, with unlimited
//! timers, every message to a crashed process (`forget_undeliverable`), and keeps of a
//! detector's indications only the suspicions in force (`keep_suspicions_in_force`).
//!
//! A state is stored packed ([`Packed`]): a few words of interned parts
//! ([`crate::compact::Packer`]), its propositions read once when it is made, and a step as its
//! action's position among the model's `actions` (the few steps of a lasso are found again
//! when it is printed).
//!
//! - **Fairness is owed to tasks** ([`crate::liveness::Task`]): every message in flight (by
//!   sender, receiver and content) and every timer of every process. A delivery that would
//!   change nothing is no step in the model (the message stays in flight), so such a message
//!   is not enabled and owes nothing. Crashes and losses are the adversary's and owe nothing.
//!   - **fair delivery** (weak, reliable networks): a message enabled without interruption
//!     is eventually delivered;
//!   - **fair timers** (weak): a timer that can fire without interruption eventually fires;
//!   - **fair loss** (strong, lossy networks): a message enabled infinitely often (sent
//!     again and again) is delivered infinitely often.
//! - **Eventual accuracy** of the failure detectors a stack uses is an assumption `<>[] A`:
//!   from some point on no live process's detector suspects a live process. A run that keeps
//!   a false suspicion is not judged. The detectors read are the layers that say whom they
//!   suspect ([`nekosim_protocols::Microprotocol::suspicions`]: `Heartbeat`, and a user's
//!   detector that implements it; of one that does not nothing is assumed). A time-free model cannot
//!   check it of a detector (a check may always come before the heartbeat it waits for); a
//!   failure detector states its time-free core instead, that no false suspicion lasts for
//!   ever (`eventual trust`, a property of each pair of processes, [`Holds::Pairs`]).
//! - **Bounds** (the timer budget after a crash, the round bound, the copy bound of unlimited
//!   timers) never make a counterexample: a state a bound cut short is never where a run ends,
//!   and the steps it leaves out count as enabled there ([`crate::liveness`]). A run ends only
//!   in a state at rest ([`crate::rest::at_rest`]), where the at-rest properties are read.

use std::cell::{Cell, RefCell};
use std::collections::HashMap;
use std::sync::Arc;

use nekosim_protocols::{Pid, Request};
use stateright::actor::{ActorModelAction, Id, Network};
use stateright::{Model, Path};

#[cfg(doc)]
use crate::adapter::ProcessState;
use crate::adapter::{live, ModelTimer, NetMsg, ProcessActor, State};
use crate::compact::{Packer, Unpacked};
use crate::config::{Action, CheckModel, NetworkKind, UNLIMITED_TIMERS};
use crate::family::Family;
use crate::liveness::{
    explore, Actors, Exceeded, Graph, Lasso, Limits, Liveness, Strength, Task, TransitionSystem,
    Verdict,
};
use crate::property::{all_received, decided_all, suspects};

mod reason;
pub use reason::reason;

/// The fairness a liveness check assumes of the tasks of a stack.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StackFairness {
    /// Every run counts: a message may stay in flight and a timer unfired for ever.
    None,
    /// Every task weakly fair: fair delivery and fair timers; on a lossy network a message
    /// may be lost every time it is sent.
    Weak,
    /// Every task strongly fair: on a lossy network, fair loss.
    Strong,
}

impl StackFairness {
    /// The names the command accepts.
    pub const NAMES: [&'static str; 3] = ["none", "weak", "strong"];

    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "none" => Some(Self::None),
            "weak" => Some(Self::Weak),
            "strong" => Some(Self::Strong),
            _ => None,
        }
    }

    /// What the links promise: fair delivery on reliable networks (weak), fair loss on a lossy
    /// one (strong on messages). Timers are weakly fair either way.
    pub fn of(network: NetworkKind) -> Self {
        match network {
            NetworkKind::Lossy => Self::Strong,
            NetworkKind::Ordered | NetworkKind::Unordered => Self::Weak,
        }
    }

    /// In a report's words.
    pub fn text(self, network: NetworkKind) -> &'static str {
        match (self, network) {
            (Self::None, _) => "none (any message may stay in flight, any timer unfired, for ever)",
            (Self::Weak, NetworkKind::Lossy) => {
                "weak (fair timers; a message may be lost every time it is sent)"
            }
            (Self::Weak, _) => "fair delivery and fair timers (weak)",
            (Self::Strong, NetworkKind::Lossy) => {
                "fair loss (strong: a message sent infinitely often is delivered infinitely often) and fair timers"
            }
            (Self::Strong, _) => "strong on every message and timer",
        }
    }

    /// How it holds a task.
    fn strength(self) -> Option<Strength> {
        match self {
            Self::None => None,
            Self::Weak => Some(Strength::Weak),
            Self::Strong => Some(Strength::Strong),
        }
    }
}

/// A family's liveness property: `kind` over `holds`.
#[derive(Clone, Copy, Debug)]
pub struct Temporal {
    pub name: &'static str,
    pub kind: Liveness,
    /// The state predicate, in words.
    pub predicate: &'static str,
    pub holds: Holds,
}

/// The predicate of a temporal property.
#[derive(Clone, Copy, Debug)]
pub enum Holds {
    /// A predicate of a state.
    State(fn(&CheckModel, &State) -> bool),
    /// A predicate of a state and an ordered pair of distinct processes `(a, b)`; the
    /// property holds when it holds of each pair (`[]<> P(a, b)` for every pair says more
    /// than `[]<>` of their conjunction: each pair may be true at its own times).
    Pairs(fn(&CheckModel, &State, Pid, Pid) -> bool),
}

impl Temporal {
    /// Whether the predicate holds in `s` (of `pair`, for a property of pairs).
    pub fn holds_in(&self, m: &CheckModel, s: &State, pair: Option<(Pid, Pid)>) -> bool {
        match (self.holds, pair) {
            (Holds::State(f), _) => f(m, s),
            (Holds::Pairs(f), Some((a, b))) => f(m, s, a, b),
            (Holds::Pairs(f), None) => pairs(m.cfg.n).all(|(a, b)| f(m, s, a, b)),
        }
    }

    /// How many propositions it reads in a state of `n` processes.
    fn width(&self, n: u32) -> u32 {
        match self.holds {
            Holds::State(_) => 1,
            Holds::Pairs(_) => n * (n - 1),
        }
    }
}

/// The ordered pairs of distinct processes among `n`, in the order of their propositions.
fn pairs(n: u32) -> impl Iterator<Item = (Pid, Pid)> {
    (0..n).flat_map(move |a| (0..n).filter(move |&b| b != a).map(move |b| (a, b)))
}

/// What a family states as its liveness (docs/model-checking.md, "Temporal properties").
pub fn temporal_properties(model: &CheckModel) -> Vec<Temporal> {
    use Liveness::{AlwaysEventually, Eventually, EventuallyAlways};
    let t = |name, kind, predicate, holds| Temporal {
        name,
        kind,
        predicate,
        holds: Holds::State(holds),
    };
    // No false suspicion lasts for ever: what a time-free model can check of eventual
    // accuracy. With a timer budget a run ends when the budget is spent, possibly just after
    // a check that came before the last heartbeat, so it is stated with unlimited timers only.
    let trust = Temporal {
        name: "eventual trust",
        kind: AlwaysEventually,
        predicate: "for each two live processes p and q, p does not suspect q",
        holds: Holds::Pairs(trusts),
    };
    let unlimited = model.cfg.timer_budget == UNLIMITED_TIMERS;
    match model.cfg.family {
        Family::Abcast => vec![
            t("validity", EventuallyAlways, "every live process delivered every message it broadcast", own_delivered),
            t("uniform agreement", EventuallyAlways, "every live process delivered whatever any process delivered", uniformly_agreed),
        ],
        Family::Broadcast => vec![
            t("validity", EventuallyAlways, "every live process delivered every message it broadcast", own_delivered),
            t("agreement", EventuallyAlways, "every live process delivered whatever a live process delivered", agreed),
        ],
        Family::Consensus => vec![t(
            "termination",
            Eventually,
            "every live process decided every instance (or fewer than a majority of the proposers are live)",
            terminated,
        )],
        Family::P2p { .. } => vec![t(
            "reliable delivery",
            EventuallyAlways,
            "every message a live process sent to a live process was delivered",
            all_delivered,
        )],
        Family::FailureDetector => {
            let mut v = Vec::new();
            if model.max_crashes > 0 {
                v.push(t(
                    "strong completeness",
                    EventuallyAlways,
                    "every live process suspects every crashed process",
                    complete,
                ));
            }
            if unlimited {
                v.push(trust);
            }
            v
        }
        Family::Leader => vec![t(
            "stable leader",
            EventuallyAlways,
            "every live process's leader is the same live process",
            common_leader,
        )],
    }
}

/// Every live process delivered each message it broadcast.
fn own_delivered(_: &CheckModel, s: &State) -> bool {
    live(s).all(|i| {
        let a = &s.actor_states[i];
        (0..a.issued as u64).all(|n| {
            a.delivered
                .iter()
                .any(|(d, _)| d.origin as usize == i && d.n == n)
        })
    })
}

fn delivered_by_all_live(s: &State, from: impl Iterator<Item = usize>) -> bool {
    let ids: Vec<_> = from
        .flat_map(|i| s.actor_states[i].delivered.iter().map(|(id, _)| *id))
        .collect();
    live(s).all(|i| {
        ids.iter()
            .all(|id| s.actor_states[i].delivered.iter().any(|(d, _)| d == id))
    })
}

fn uniformly_agreed(_: &CheckModel, s: &State) -> bool {
    delivered_by_all_live(s, 0..s.actor_states.len())
}

fn agreed(_: &CheckModel, s: &State) -> bool {
    delivered_by_all_live(s, live(s))
}

/// Every live process decided every instance, unless too few proposers are live for any
/// decision (the model's proposers, not the protocol, are then short).
fn terminated(m: &CheckModel, s: &State) -> bool {
    let majority = m.cfg.n as usize / 2 + 1;
    let live_proposers = live(s)
        .filter(|&i| {
            m.cfg
                .requests
                .iter()
                .any(|(p, r)| *p as usize == i && matches!(r, Request::Propose { .. }))
        })
        .count();
    live_proposers < majority || live(s).all(|i| decided_all(m, s, i))
}

fn all_delivered(m: &CheckModel, s: &State) -> bool {
    all_received(m, s, |p| !s.crashed[p as usize])
}

fn complete(_: &CheckModel, s: &State) -> bool {
    let crashed: Vec<Pid> = (0..s.crashed.len())
        .filter(|&i| s.crashed[i])
        .map(|i| i as Pid)
        .collect();
    live(s).all(|a| crashed.iter().all(|&t| suspects(s, a, t)))
}

/// `a` does not suspect `b`, or one of them crashed.
fn trusts(_: &CheckModel, s: &State, a: Pid, b: Pid) -> bool {
    s.crashed[a as usize] || s.crashed[b as usize] || !suspects(s, a as usize, b)
}

fn common_leader(_: &CheckModel, s: &State) -> bool {
    let mut leaders = live(s).map(|i| s.actor_states[i].leader);
    let Some(Some(first)) = leaders.next() else {
        return false;
    };
    leaders.all(|l| l == Some(first)) && !s.crashed[first as usize]
}

/// Eventual accuracy, the assumption `<>[] accurate`: no live process's failure detector
/// suspects a live process. True where the stack has none.
pub fn accurate(_: &CheckModel, s: &State) -> bool {
    live(s).all(|i| {
        s.actor_states[i].stack.layers.iter().all(|l| {
            l.suspicions()
                .is_none_or(|suspected| suspected.iter().all(|&p| s.crashed[p as usize]))
        })
    })
}

/// Whether the stack's liveness rests on eventual accuracy: a layer other than the one
/// checked is a failure detector ([`nekosim_protocols::Microprotocol::suspicions`]; a
/// failure detector checked itself assumes nothing of itself).
pub fn assumes_accuracy(model: &CheckModel) -> bool {
    model.cfg.family != Family::FailureDetector
        && model
            .actors
            .first()
            .is_some_and(|a| a.init.layers.iter().any(|l| l.suspicions().is_some()))
}

/// What fairness owes a task to: a message in flight or a process's timer.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum TaskKey {
    Deliver { src: Pid, dst: Pid, msg: NetMsg },
    Timer { process: Pid, timer: ModelTimer },
}

/// A state of a stack's liveness graph: a few words of bits, the propositions read in it
/// (those of each temporal property in [`temporal_properties`]' order, one or one per pair
/// of processes, then eventual accuracy's, [`accurate`]), then its record of interned parts
/// ([`crate::compact::Packer`]), with its spent messages forgotten.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Packed(Box<[u32]>);

impl Packed {
    fn bit(&self, i: u32) -> bool {
        self.0[i as usize / 32] & (1 << (i % 32)) != 0
    }
}

/// A step of a stack's liveness graph: where its action is among the model's `actions` of
/// the state it leaves, and the task it takes (`NO_TASK` for a crash or a loss).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Step {
    action: u32,
    task: Task,
}

/// The task of a step that owes nothing to fairness.
const NO_TASK: Task = Task::MAX;

/// A stack's model as a [`TransitionSystem`] whose tasks are its messages and timers, and
/// whose states are packed ([`Packed`]): a state's processes, histories and messages are
/// stored once each, in the tables of a [`crate::compact::Packer`].
pub struct StackSystem<'a> {
    pub model: &'a CheckModel,
    properties: Vec<Temporal>,
    packer: Packer<ProcessActor, ()>,
    /// The first bit of each property's propositions in a [`Packed`] state, the bit of
    /// eventual accuracy, and how many words the bits take.
    first: Vec<u32>,
    accurate_bit: u32,
    head: usize,
    /// Whether every message to a crashed process is forgotten, whatever the network and the
    /// reductions ([`forget_undeliverable`]).
    undeliverable: bool,
    tasks: RefCell<HashMap<TaskKey, Task>>,
    keys: RefCell<Vec<TaskKey>>,
    /// The tasks of the last state's steps that left the model, for [`Self::beyond`].
    left: RefCell<Vec<Task>>,
    /// Whether the last state expanded has no step and is not at rest.
    stuck: Cell<bool>,
    /// Asked at the first state expanded and every [`POLL_EVERY`] after whether to stop;
    /// once it says so, no state has a step and the (incomplete) graph is discarded.
    halt: Option<&'a dyn Fn() -> bool>,
    expanded: Cell<u64>,
    halted: Cell<bool>,
}

/// States expanded between two polls of a [`StackSystem`]'s halt (reading the resident
/// memory costs a file read).
pub const POLL_EVERY: u64 = 1024;

/// A stack's whole liveness graph and the system that made it (whose tables its states'
/// records refer to).
#[derive(Debug)]
pub struct StackGraph<'a> {
    pub graph: Graph<StackSystem<'a>>,
    pub system: StackSystem<'a>,
}

impl<'a> std::ops::Deref for StackGraph<'a> {
    type Target = Graph<StackSystem<'a>>;

    fn deref(&self) -> &Self::Target {
        &self.graph
    }
}

/// `s` as the liveness graph of `model` stores it: with its spent messages forgotten (where
/// the model's reductions are on and its network reorders messages).
pub fn stored(model: &CheckModel, s: &State) -> State {
    let system = StackSystem::new(model);
    system.unpack(&system.pack(s.clone(), None))
}

/// Explores the whole graph of `model`, within `max_states` unique states, asking `halt`
/// now and then whether to stop (the memory budget, Ctrl-C). `Ok(None)`: `halt` stopped it,
/// after the returned number of states. Build `model` with [`crate::Options::defer_early`]
/// off, as `nekosim check` does: a graph with each link in send order has only real fair
/// runs, but the states it adds between two upcalls could hide the lasso of a property that
/// is not monotone in what was delivered.
#[allow(clippy::type_complexity)]
pub fn explore_stack<'a>(
    model: &'a CheckModel,
    max_states: Option<usize>,
    halt: &'a dyn Fn() -> bool,
) -> (Result<StackGraph<'a>, Exceeded>, Option<u64>, usize) {
    let mut system = StackSystem::new(model);
    system.halt = Some(halt);
    let limits = Limits {
        max_states,
        max_memory: None,
    };
    let graph = explore(&system, limits);
    let halted = system.halted.get().then(|| system.expanded.get());
    let tasks = system.task_count();
    (
        graph.map(|graph| StackGraph { graph, system }),
        halted,
        tasks,
    )
}

impl std::fmt::Debug for StackSystem<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StackSystem")
            .field("tasks", &self.task_count())
            .finish_non_exhaustive()
    }
}

impl<'a> StackSystem<'a> {
    /// The system of `model`, which forgets spent messages where the model's reductions are
    /// on ([`crate::model::spent`]; the packer forgets them only on networks that reorder
    /// messages, as the breadth-first search does).
    pub fn new(model: &'a CheckModel) -> Self {
        let ordered = model
            .init_states()
            .first()
            .is_some_and(|s| matches!(s.network, Network::Ordered(_)));
        let spent = model.cfg.reduction.then(|| crate::model::spent(model));
        let properties = temporal_properties(model);
        let mut first = Vec::new();
        let mut bits = 0;
        for p in &properties {
            first.push(bits);
            bits += p.width(model.cfg.n);
        }
        Self {
            model,
            properties,
            first,
            accurate_bit: bits,
            head: bits as usize / 32 + 1,
            packer: Packer::new(model.actors.len(), ordered, spent),
            undeliverable: model.cfg.timer_budget == UNLIMITED_TIMERS,
            tasks: RefCell::new(HashMap::new()),
            keys: RefCell::new(Vec::new()),
            left: RefCell::new(Vec::new()),
            stuck: Cell::new(false),
            halt: None,
            expanded: Cell::new(0),
            halted: Cell::new(false),
        }
    }

    /// How many tasks the exploration named.
    pub fn task_count(&self) -> usize {
        self.keys.borrow().len()
    }

    /// Which task `t` is.
    pub fn key(&self, t: Task) -> Option<TaskKey> {
        self.keys.borrow().get(t as usize).cloned()
    }

    fn task(&self, action: &Action) -> Option<Task> {
        let key = match action {
            ActorModelAction::Deliver { src, dst, msg } => TaskKey::Deliver {
                src: usize::from(*src) as Pid,
                dst: usize::from(*dst) as Pid,
                msg: msg.clone(),
            },
            ActorModelAction::Timeout(id, timer) => TaskKey::Timer {
                process: usize::from(*id) as Pid,
                timer: timer.clone(),
            },
            _ => return None,
        };
        let mut tasks = self.tasks.borrow_mut();
        let next = tasks.len() as Task;
        Some(*tasks.entry(key.clone()).or_insert_with(|| {
            self.keys.borrow_mut().push(key);
            next
        }))
    }

    /// `s`, the successor of `parent` (if any), packed with its spent messages forgotten and
    /// its propositions read.
    fn pack(&self, mut s: State, parent: Option<(&[u32], &Unpacked<ProcessActor, ()>)>) -> Packed {
        self.packer.forget(&mut s, parent);
        if self.undeliverable {
            forget_undeliverable(&mut s);
        }
        keep_suspicions_in_force(&mut s);
        let mut words = vec![0u32; self.head];
        let mut set = |i: u32| words[i as usize / 32] |= 1 << (i % 32);
        for (p, &first) in self.properties.iter().zip(&self.first) {
            match p.holds {
                Holds::State(f) => {
                    if f(self.model, &s) {
                        set(first);
                    }
                }
                Holds::Pairs(f) => {
                    for (j, (a, b)) in (0..).zip(pairs(self.model.cfg.n)) {
                        if f(self.model, &s, a, b) {
                            set(first + j);
                        }
                    }
                }
            }
        }
        if accurate(self.model, &s) {
            set(self.accurate_bit);
        }
        let mut record = Vec::new();
        self.packer.pack_forgotten(s, parent, &mut record);
        words.extend_from_slice(&record);
        Packed(words.into_boxed_slice())
    }

    /// The record of interned parts of a packed state.
    fn record<'p>(&self, p: &'p Packed) -> &'p [u32] {
        &p.0[self.head..]
    }

    /// The state a packed state stands for.
    pub fn unpack(&self, p: &Packed) -> State {
        self.packer.unpack(self.record(p)).into_state()
    }

    /// A lasso of the graph as a lasso of the model: each step's action found again among
    /// the `actions` of the state it leaves, each state unpacked. Its states are the
    /// graph's, without spent messages.
    pub fn expand(&self, lasso: &Lasso<Packed, Step>) -> Lasso<State, Action> {
        // The actions are listed from unpacked states, as the graph listed them; the start
        // is the model's own initial state, so that the lasso replays as a path.
        let mut from = self.unpack(&lasso.start);
        let start = self
            .model
            .init_states()
            .into_iter()
            .find(|s| self.pack(s.clone(), None) == lasso.start)
            .unwrap_or_else(|| from.clone());
        let mut step = |(step, to): &(Step, Packed)| {
            let mut actions = Vec::new();
            self.model.actions(&from, &mut actions);
            let action = actions.swap_remove(step.action as usize);
            from = self.unpack(to);
            (action, from.clone())
        };
        let stem = lasso.stem.iter().map(&mut step).collect();
        let cycle = lasso.cycle.iter().map(&mut step).collect();
        Lasso { start, stem, cycle }
    }
}

impl TransitionSystem for StackSystem<'_> {
    type State = Packed;
    type Label = Step;

    fn initial_states(&self) -> Vec<Packed> {
        self.model
            .init_states()
            .into_iter()
            .filter(|s| self.model.within_boundary(s))
            .map(|s| self.pack(s, None))
            .collect()
    }

    fn successors(&self, packed: &Packed, out: &mut Vec<(Step, Packed)>) {
        self.left.borrow_mut().clear();
        self.stuck.set(false);
        if self.halted.get() {
            return;
        }
        let n = self.expanded.get();
        self.expanded.set(n + 1);
        if let Some(halt) = self.halt.filter(|_| n % POLL_EVERY == 0) {
            if halt() {
                self.halted.set(true);
                return;
            }
        }
        let parent = self.packer.unpack(self.record(packed));
        let state = parent.state();
        let mut actions = Vec::new();
        self.model.actions(state, &mut actions);
        let mut left = self.left.borrow_mut();
        left.clear();
        let before = out.len();
        for (i, action) in actions.into_iter().enumerate() {
            // A recovered process is outside every model (crash-stop protocols), whatever
            // the bounds: it is no step left out.
            if matches!(
                action,
                ActorModelAction::Recover(_) | ActorModelAction::SelectRandom { .. }
            ) {
                continue;
            }
            let Some(next) = self.model.next_state(state, action.clone()) else {
                continue;
            };
            let task = self.task(&action);
            if self.model.within_boundary(&next) {
                let step = Step {
                    action: u32::try_from(i).expect("fewer than 2^32 actions"),
                    task: task.unwrap_or(NO_TASK),
                };
                out.push((step, self.pack(next, Some((self.record(packed), &parent)))));
            } else {
                // A crash or a loss into a bounded state cuts the run there.
                left.push(task.unwrap_or(NO_TASK));
            }
        }
        let none = out.len() == before && left.is_empty();
        self.stuck
            .set(none && !crate::rest::at_rest(self.model, state));
    }

    fn moved(&self, _: &Step) -> Actors {
        0
    }

    fn actors(&self) -> usize {
        self.model.actors.len()
    }

    fn tasks(&self, step: &Step, out: &mut Vec<Task>) {
        if step.task != NO_TASK {
            out.push(step.task);
        }
    }

    fn beyond(&self, _: &Packed, out: &mut Vec<Task>) -> bool {
        let left = self.left.borrow();
        out.extend(left.iter().copied().filter(|&t| t != NO_TASK));
        !left.is_empty() || self.stuck.get()
    }
}

/// Keeps, of what each process's detector told it ([`ProcessState::detections`]), only the
/// suspicions in force. No step reads it (a process only records it) and every proposition
/// of the graph reads only whether a process suspects another now, so a state and its
/// summary have the same steps to the same futures, up to the same summary, and the same
/// propositions; merging them keeps every fair cycle and makes the graph smaller.
fn keep_suspicions_in_force(s: &mut State) {
    for p in &mut s.actor_states {
        let in_force = p.detections.in_force();
        if in_force != p.detections {
            Arc::make_mut(p).detections = in_force;
        }
    }
}

/// Forgets every message in flight to a crashed process. Such a message is never delivered
/// (the protocols are crash-stop, and a recovery is outside every model), so, as a spent
/// message, it is never an enabled task and a state and the same state without it have the
/// same steps, propositions and fair cycles. The graph forgets them wherever timers are
/// unlimited: there a second copy of a message on one link is outside the model, so a
/// process that keeps sending to every process (a heartbeat) would otherwise be stopped,
/// after its first message to a crashed one, and every run after a crash cut short, with no
/// verdict resting on it. (Where the reductions are on and the network reorders messages,
/// the spent messages the search forgets include these.)
fn forget_undeliverable(s: &mut State) {
    let crashed = &s.crashed;
    match &mut s.network {
        Network::UnorderedNonDuplicating(multiset) => {
            multiset.retain(|env, _| !crashed[usize::from(env.dst)]);
        }
        Network::Ordered(channels) => channels.retain(|(_, dst), _| !crashed[usize::from(*dst)]),
        Network::UnorderedDuplicating(set, _) => set.retain(|env| !crashed[usize::from(env.dst)]),
    }
}

/// The pid of an actor id.
pub fn pid(id: Id) -> Pid {
    usize::from(id) as Pid
}

/// A temporal property's verdict on a graph.
#[derive(Clone, Debug)]
pub struct Decision {
    pub property: Temporal,
    /// For a property of pairs that fails, the pair its lasso is about.
    pub pair: Option<(Pid, Pid)>,
    pub verdict: Verdict<State, Action>,
}

/// Decides every temporal property of `model` on its `graph` ([`explore_stack`]) under
/// `fairness`, assuming eventual accuracy where the stack rests on it
/// ([`assumes_accuracy`]). The propositions are the bits read when each state was packed.
pub fn decide(
    model: &CheckModel,
    graph: &StackGraph<'_>,
    fairness: StackFairness,
) -> Vec<Decision> {
    let assume = assumes_accuracy(model);
    let system = &graph.system;
    let check = |bit: u32, kind| match graph.check_under(
        kind,
        &|_| fairness.strength(),
        &|s| !assume || s.bit(system.accurate_bit),
        |s| s.bit(bit),
    ) {
        Verdict::Holds => Verdict::Holds,
        Verdict::Fails(lasso) => Verdict::Fails(system.expand(&lasso)),
    };
    system
        .properties
        .iter()
        .zip(&system.first)
        .map(|(&property, &first)| {
            let (pair, verdict) = match property.holds {
                Holds::State(_) => (None, check(first, property.kind)),
                // The first pair that fails, if any.
                Holds::Pairs(_) => (0..)
                    .zip(pairs(model.cfg.n))
                    .map(|(j, pair)| (Some(pair), check(first + j, property.kind)))
                    .find(|(_, v)| matches!(v, Verdict::Fails(_)))
                    .unwrap_or((None, Verdict::Holds)),
            };
            Decision {
                property,
                pair,
                verdict,
            }
        })
        .collect()
}

/// A lasso as one path of the model: the stem, then the cycle once. Its states hold the
/// spent messages the graph forgets, so its last state is the cycle's entry again up to
/// those ([`stored`]). `None` if it is not a path of the model (never, for a
/// lasso of its graph: [`Path::from_actions`] replays every step).
pub fn lasso_path(model: &CheckModel, lasso: &Lasso<State, Action>) -> Option<Path<State, Action>> {
    let actions: Vec<&Action> = lasso
        .stem
        .iter()
        .chain(&lasso.cycle)
        .map(|(a, _)| a)
        .collect();
    Path::from_actions(model, lasso.start.clone(), actions)
}
