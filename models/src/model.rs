//! Building a stateright model from a stack (the adapter's processes, the network semantics,
//! the bounds and the family's properties) and running the checker on it.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

#[cfg(doc)]
use nekosim_protocols::Microprotocol;
use nekosim_protocols::{
    AppMsg, Content, Ctx, Layer, LayerSpec, Payload, Pid, Protocols, Rename, Request, Round,
    Rounds, Service, Stack, StackProperty, Wiring,
};
use stateright::actor::{ActorModel, LossyNetwork, Network};
use stateright::{Checker, Expectation, HasDiscoveries, Model, Path, UniformChooser};

use crate::adapter::{ClientRequest, NetMsg, ProcessActor, ProcessState, Shared, State};
use crate::budget::{resident_memory, Budget, Stopped, MEMORY_HEADROOM};
use crate::compact::{self, CompactBfs};
use crate::config::{
    Action, CheckModel, Condition, ModelCfg, NetworkKind, Options, UNLIMITED_TIMERS,
};
use crate::family::Family;
use crate::property::properties;
use crate::reduction::{self, Invisible};
use crate::spill::{Spill, Spilled, Store};
use crate::symmetry::Symmetry;

/// A check that cannot be built from its parameters.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ModelError {
    #[error("{0} processes; expected 2 to 8")]
    Processes(u32),
    #[error("{0} requests; expected at least 1")]
    NoRequests(u32),
    #[error("{requests} proposals for {processes} processes; consensus expects proposals from a majority and at most one per process ({min} to {processes})")]
    Proposals {
        requests: u32,
        processes: u32,
        min: u32,
    },
    #[error("{crashes} crashes with {processes} processes; expected fewer crashes than processes")]
    Crashes { crashes: u32, processes: u32 },
    #[error("invalid stack: {0}")]
    Stack(String),
    #[error("{0} properties stated by the stack's protocols; at most 8 are checked")]
    TooManyProperties(usize),
    #[error("no layer {name:?} in the stack; expected one of {known}")]
    NoLayer { name: String, known: String },
    #[error("symmetry reduction: {0}")]
    Symmetry(String),
    #[error("the stack has several top layers ({0}); choose the one to check with --layer")]
    TopLayers(String),
    #[error("layer {layer:?} provides {service} ({what}), which has no properties to check; checkable services: total-order broadcast, broadcast, consensus, point-to-point messages, a failure detector, leader election")]
    Unchecked {
        layer: String,
        service: &'static str,
        what: &'static str,
    },
}

/// What to check: a stack, the layer the application talks to and what it promises.
#[derive(Clone, Debug)]
pub struct Target {
    pub stack: Vec<LayerSpec>,
    /// Layer id that receives the client requests.
    pub entry: String,
    pub family: Family,
    /// Layers whose messages only ever matter to their own timers (a heartbeat detector's
    /// beats only feed its next check): with a timer budget of zero they are not sent.
    pub timer_fed: Vec<String>,
}

impl Target {
    /// The target a scenario's stack defines: the entry layer is `layer`, or else the stack's
    /// one top layer (the one the application talks to); the family is the service that
    /// layer provides ([`Family::of`]); layers providing a failure detector are timer-fed.
    pub fn of_stack(
        stack: Vec<LayerSpec>,
        layer: Option<&str>,
        protocols: &Protocols,
    ) -> Result<Self, ModelError> {
        let (wiring, _) =
            Wiring::check(&stack, protocols).map_err(|e| ModelError::Stack(e.to_string()))?;
        let entry = match layer {
            Some(name) => wiring.index(name).ok_or_else(|| ModelError::NoLayer {
                name: name.to_string(),
                known: wiring.ids.join(", "),
            })?,
            None => {
                let tops: Vec<usize> = (0..wiring.ids.len())
                    .filter(|&i| wiring.app_hears[i])
                    .collect();
                match tops[..] {
                    [one] => one as u16,
                    [] => return Err(ModelError::Stack("the stack is empty".into())),
                    _ => {
                        let names: Vec<&str> =
                            tops.iter().map(|&i| wiring.ids[i].as_str()).collect();
                        return Err(ModelError::TopLayers(names.join(", ")));
                    }
                }
            }
        };
        let provided = wiring.provides[entry as usize];
        let family = Family::of(provided).ok_or_else(|| ModelError::Unchecked {
            layer: wiring.ids[entry as usize].clone(),
            service: provided.name,
            what: provided.what,
        })?;
        let timer_fed = (0..wiring.ids.len())
            .filter(|&i| wiring.provides[i].serves(Service::FAILURE_DETECTOR))
            .map(|i| wiring.ids[i].clone())
            .collect();
        Ok(Self {
            entry: wiring.ids[entry as usize].clone(),
            stack,
            family,
            timer_fed,
        })
    }
}

/// The client request `g` (issued by process `g mod n`): a proposal to instance `g / n`, a
/// broadcast, or a message to every other process, each carrying `g`.
fn request(family: Family, n: u32, g: u32) -> Request {
    let msg = |tag| AppMsg::new(tag, Content::Int(i64::from(g))).payload();
    match family {
        Family::Consensus => Request::Propose {
            k: u64::from(g / n),
            value: msg("V"),
        },
        Family::Abcast | Family::Broadcast => Request::Broadcast { msg: msg("M") },
        Family::P2p { .. } => Request::Send {
            to: (0..n).filter(|&q| q != g % n).collect(),
            msg: msg("M"),
        },
        Family::FailureDetector | Family::Leader => {
            unreachable!("a failure detector or leader election takes no requests")
        }
    }
}

/// Builds the model of `target` with `opts`; `tweak` may replace layers of each process's
/// initial stack (for the deliberately broken variants).
pub fn build(
    target: &Target,
    opts: &Options,
    tweak: impl Fn(Pid, &mut Stack),
) -> Result<CheckModel, ModelError> {
    build_in(&Protocols::with_builtins(), target, opts, tweak)
}

/// [`build`] with the protocols of `protocols` (a user's registry: built-ins and their own).
pub fn build_in(
    protocols: &Protocols,
    target: &Target,
    opts: &Options,
    tweak: impl Fn(Pid, &mut Stack),
) -> Result<CheckModel, ModelError> {
    let n = opts.processes;
    if !(2..=8).contains(&n) {
        return Err(ModelError::Processes(n));
    }
    let requests = if target.family.takes_requests() {
        opts.requests
    } else {
        0
    };
    if target.family.takes_requests() && requests == 0 {
        return Err(ModelError::NoRequests(opts.requests));
    }
    if target.family == Family::Consensus && !(n / 2 + 1..=n).contains(&opts.requests) {
        return Err(ModelError::Proposals {
            requests: opts.requests,
            processes: n,
            min: n / 2 + 1,
        });
    }
    if opts.crashes >= n {
        return Err(ModelError::Crashes {
            crashes: opts.crashes,
            processes: n,
        });
    }
    let (mut wiring, stack) =
        Wiring::check(&target.stack, protocols).map_err(|e| ModelError::Stack(e.to_string()))?;
    let entry = wiring
        .index(&target.entry)
        .ok_or_else(|| ModelError::Stack(format!("no layer {:?}", target.entry)))?;
    // The checked layer is the application's, whatever sits above it.
    wiring.app_hears[entry as usize] = true;
    // The round bound reads the messages of layers that number rounds and looks through the
    // headers that carry them; a stack without numbered rounds is not bounded.
    let round_layers: Vec<Option<Layer>> = stack
        .layers
        .iter()
        .map(|l| (l.rounds() != Rounds::None).then(|| l.clone()))
        .collect();
    let numbered = stack.layers.iter().any(|l| l.rounds() == Rounds::Numbered);
    let stated: Vec<StackProperty> = protocols
        .properties()
        .iter()
        .filter(|p| p.applies_to(&stack))
        .cloned()
        .collect();
    if stated.len() > STATED.len() {
        return Err(ModelError::TooManyProperties(stated.len()));
    }
    let requests: Vec<(Pid, Request)> = (0..requests)
        .map(|g| (g % n, request(target.family, n, g)))
        .collect();
    let muted = if opts.timer_budget == 0 {
        target
            .timer_fed
            .iter()
            .filter_map(|id| wiring.index(id))
            .collect()
    } else {
        Vec::new()
    };
    let shared = Arc::new(Shared {
        n,
        muted,
        wiring,
        timer_budget: opts.timer_budget,
        staged_sends: opts.crashes > 0 && opts.partial_multicasts,
        entry,
    });
    let actors: Vec<ProcessActor> = (0..n)
        .map(|p| {
            let mut init = stack.clone();
            tweak(p, &mut init);
            ProcessActor {
                shared: Arc::clone(&shared),
                init,
                requests: requests
                    .iter()
                    .filter(|(q, _)| *q == p)
                    .map(|(_, req)| ClientRequest {
                        layer: entry,
                        req: req.clone(),
                    })
                    .collect(),
            }
        })
        .collect();
    let in_send_order = opts.reduction
        && opts.defer_early
        && opts.network == NetworkKind::Unordered
        && actors
            .iter()
            .all(|a| reduction::early_arrivals_held(&shared.wiring, &a.init));
    let symmetry = if opts.symmetry {
        Some(Arc::new(symmetry_of(&shared, &actors, &requests)?))
    } else {
        None
    };
    let mut cfg = ModelCfg {
        family: target.family,
        n,
        requests,
        timer_budget: opts.timer_budget,
        max_round: numbered.then_some(opts.max_round),
        round_layers,
        stop: Arc::new(AtomicBool::new(false)),
        stated,
        conditions: Vec::new(),
        undo: Vec::new(),
        reduction: opts.reduction,
        in_send_order,
        found: Arc::new(Vec::new()),
        symmetry,
    };
    let proposers = (cfg.requests.len() as u32).min(n);
    let mut props = properties(target.family, n, opts, proposers);
    for (i, p) in cfg.stated.iter().enumerate() {
        let expectation = if p.always {
            Expectation::Always
        } else {
            Expectation::Sometimes
        };
        props.push((expectation, p.name, STATED[i], stack_changed));
    }
    assert!(
        props.len() <= FIRST.len(),
        "at most {} properties",
        FIRST.len()
    );
    cfg.conditions = props.iter().map(|(e, _, c, _)| (e.clone(), *c)).collect();
    cfg.undo = props.iter().map(|(.., u)| *u).collect();
    cfg.found = Arc::new(props.iter().map(|_| AtomicBool::new(false)).collect());
    let network = match opts.network {
        NetworkKind::Ordered => Network::new_ordered([]),
        NetworkKind::Unordered if in_send_order => Network::new_ordered([]),
        NetworkKind::Unordered | NetworkKind::Lossy => Network::new_unordered_nonduplicating([]),
    };
    let lossy = if opts.network == NetworkKind::Lossy {
        LossyNetwork::Yes
    } else {
        LossyNetwork::No
    };
    let mut model = ActorModel::new(cfg, ())
        .actors(actors)
        .init_network(network)
        .lossy_network(lossy)
        .max_crashes(opts.crashes as usize)
        .within_boundary(within_boundary);
    for (i, (expectation, name, ..)) in props.into_iter().enumerate() {
        model = model.property(expectation, name, FIRST[i]);
    }
    Ok(model)
}

/// Processes a symmetry reduction can rename: `n!` renamings are tried on every state.
pub const SYMMETRY_PROCESSES: u32 = 5;

/// The renamings of a model whose processes are alike, or why they are not.
fn symmetry_of(
    shared: &Shared,
    actors: &[ProcessActor],
    requests: &[(Pid, Request)],
) -> Result<Symmetry, ModelError> {
    let refuse = |why: String| Err(ModelError::Symmetry(why));
    if shared.n > SYMMETRY_PROCESSES {
        return refuse(format!(
            "{} processes; at most {SYMMETRY_PROCESSES} (every renaming is tried on every state)",
            shared.n
        ));
    }
    if shared.staged_sends {
        return refuse(
            "with crashes, a multicast leaves one destination at a time in the order of process ids, which a renaming does not keep"
                .into(),
        );
    }
    if actors.iter().any(|a| a.init != actors[0].init) {
        return refuse("the processes do not start with the same stack".into());
    }
    let identity: Vec<Pid> = (0..shared.n).collect();
    let payload = |p: &Payload, _: &Rename| Some(p.clone());
    let r = Rename::new(&identity, &payload);
    if let Some(layer) = actors[0]
        .init
        .layers
        .iter()
        .position(|l| l.renamed(&r).is_none())
    {
        return refuse(format!(
            "layer {:?} ({}) does not declare symmetry (Microprotocol::renamed)",
            shared.wiring.ids[layer],
            actors[0].init.layers[layer].name()
        ));
    }
    Ok(Symmetry::new(
        shared.n,
        requests,
        Arc::clone(&shared.wiring.codecs),
    ))
}

/// Property `I` of the model, reporting only its first discovery: stateright 0.31 keeps the
/// last path it finds to a counterexample (or witness), so this condition answers "no
/// discovery" once one was made. Breadth-first on one thread, the path kept is then a
/// shortest one.
fn first<const I: usize>(m: &CheckModel, s: &State) -> bool {
    let (expectation, condition) = &m.cfg.conditions[I];
    let value = condition(m, s);
    let discovery = match expectation {
        Expectation::Always | Expectation::Eventually => !value,
        Expectation::Sometimes => value,
    };
    if discovery && m.cfg.found[I].swap(true, Ordering::Relaxed) {
        return !value;
    }
    value
}

/// The model's property conditions, by index.
const FIRST: [Condition; 24] = [
    first::<0>,
    first::<1>,
    first::<2>,
    first::<3>,
    first::<4>,
    first::<5>,
    first::<6>,
    first::<7>,
    first::<8>,
    first::<9>,
    first::<10>,
    first::<11>,
    first::<12>,
    first::<13>,
    first::<14>,
    first::<15>,
    first::<16>,
    first::<17>,
    first::<18>,
    first::<19>,
    first::<20>,
    first::<21>,
    first::<22>,
    first::<23>,
];

/// A stated property reads the protocol's state, which any change of a stack may undo.
fn stack_changed(_: &ModelCfg, before: &ProcessState, after: &ProcessState) -> bool {
    before.stack != after.stack
}

/// Property `I` a protocol states ([`ModelCfg::stated`]), of every process's stack.
fn stated<const I: usize>(m: &CheckModel, s: &State) -> bool {
    let stacks: Vec<&Stack> = s.actor_states.iter().map(|a| &a.stack).collect();
    m.cfg.stated[I].holds(&stacks)
}

/// Stateright takes a property's condition as a function pointer: one per stated property.
const STATED: [Condition; 8] = [
    stated::<0>,
    stated::<1>,
    stated::<2>,
    stated::<3>,
    stated::<4>,
    stated::<5>,
    stated::<6>,
    stated::<7>,
];

/// The round a message belongs to ([`Microprotocol::round`]), looking through the headers
/// that carry other layers' payloads.
fn round_of(layers: &[Option<Layer>], p: &Payload) -> Option<u64> {
    match layers.get(p.layer() as usize)?.as_ref()?.round(p)? {
        Round::None => None,
        Round::At(r) => Some(r),
        Round::Carries(inner) => round_of(layers, &inner),
    }
}

/// States inside the model: no recovered process (protocols are crash-stop) and, with
/// numbered rounds, no message of a round past the bound (in flight or staged).
fn within_boundary(cfg: &ModelCfg, s: &State) -> bool {
    if cfg.stop.load(Ordering::Relaxed) || s.actor_states.iter().any(|a| a.zombie) {
        return false;
    }
    if cfg.timer_budget == UNLIMITED_TIMERS
        && !(single_copies(&s.network) && s.actor_states.iter().all(|a| single_staged(&a.outbox)))
    {
        return false;
    }
    let Some(max) = cfg.max_round else {
        return true;
    };
    let early = |p: &Payload| round_of(&cfg.round_layers, p).is_none_or(|r| r <= max);
    all_in_flight(&s.network, |m| early(&m.msg))
        && s.actor_states
            .iter()
            .all(|a| a.outbox.iter().all(|(_, m)| early(&m.msg)))
}

/// Whether no message is in flight twice on one link (the bound of unlimited timers,
/// [`UNLIMITED_TIMERS`]).
fn single_copies(network: &Network<NetMsg>) -> bool {
    match network {
        Network::UnorderedDuplicating(..) => true,
        Network::UnorderedNonDuplicating(multiset) => multiset.values().all(|&c| c <= 1),
        Network::Ordered(channels) => channels.values().all(|c| {
            c.iter()
                .enumerate()
                .all(|(i, m)| !c.iter().skip(i + 1).any(|o| o == m))
        }),
    }
}

/// Whether no message is staged twice for one destination in an outbox (the same bound, on
/// the sends a crash may still cut short).
fn single_staged(outbox: &std::collections::VecDeque<(Pid, NetMsg)>) -> bool {
    outbox
        .iter()
        .enumerate()
        .all(|(i, m)| !outbox.iter().skip(i + 1).any(|o| o == m))
}

/// Whether `f` holds for every message in flight. (Stateright 0.31's `Network::iter_all`
/// never ends on a non-empty ordered network: its cursor over a channel does not advance.)
pub fn all_in_flight(network: &Network<NetMsg>, f: impl Fn(&NetMsg) -> bool) -> bool {
    match network {
        Network::UnorderedDuplicating(set, _) => set.iter().all(|e| f(&e.msg)),
        Network::UnorderedNonDuplicating(multiset) => multiset.keys().all(|e| f(&e.msg)),
        Network::Ordered(channels) => channels.values().flatten().all(f),
    }
}

/// How one property fared.
#[derive(Clone, Debug)]
pub struct Verdict {
    pub name: &'static str,
    pub expectation: Expectation,
    pub holds: bool,
    /// The counterexample (`always`) or witness (`sometimes`), if one was found.
    pub path: Option<Path<State, Action>>,
}

/// The checker's figures and verdicts.
#[derive(Clone, Debug)]
pub struct Outcome {
    pub states: usize,
    pub unique_states: usize,
    pub max_depth: usize,
    /// In the model's property order.
    pub verdicts: Vec<Verdict>,
    /// What ended the search before it was exhaustive, if anything did.
    pub stopped: Option<Stopped>,
}

impl Outcome {
    /// Whether every property holds.
    pub fn all_hold(&self) -> bool {
        self.verdicts.iter().all(|v| v.holds)
    }

    /// Whether some `always` property has a counterexample.
    pub fn any_fails(&self) -> bool {
        self.verdicts
            .iter()
            .any(|v| v.expectation != Expectation::Sometimes && !v.holds)
    }

    /// The verdict of a property.
    pub fn verdict(&self, name: &str) -> Option<&Verdict> {
        self.verdicts.iter().find(|v| v.name == name)
    }
}

/// The order in which states are explored (stateright's three checkers).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Strategy {
    /// Breadth-first: exhaustive, and each counterexample is a shortest one (one thread).
    #[default]
    Bfs,
    /// Depth-first: exhaustive, holding only the current path's frontier.
    Dfs,
    /// Random walks from the initial states, each seeded from `seed`: never exhaustive, but
    /// reaches deep configurations (more processes) whose whole space does not fit.
    Simulation { seed: u64 },
}

/// Where a search stands, as a watcher sees it while it runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    /// States generated.
    pub states: usize,
    pub unique_states: usize,
    /// The deepest level reached (breadth-first: the level being explored).
    pub max_depth: usize,
    /// This process's resident memory in bytes, where readable.
    pub memory: Option<u64>,
}

/// A property's first discovery, told as soon as the search makes it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Discovery {
    pub name: &'static str,
    pub expectation: Expectation,
    /// The unique states explored when it was seen.
    pub unique_states: usize,
}

impl Discovery {
    /// Whether it is a counterexample (of an `always` or `eventually` property), not a
    /// witness.
    pub fn fails(&self) -> bool {
        self.expectation != Expectation::Sometimes
    }
}

/// Who watches a running search: it is told the progress (about every [`PROGRESS_TICKS`]
/// looks) and each property's first discovery, and may stop the search. The models crate
/// never reads the wall clock; a watcher times the search itself.
pub trait Watch {
    fn progress(&mut self, _at: &Progress) {}
    fn discovered(&mut self, _d: &Discovery) {}
    /// Whether the search should stop now, as a budget stops it: no new state enters, and
    /// what it holds is settled ([`Stopped::Interrupted`]).
    fn interrupted(&self) -> bool {
        false
    }
    /// The time budget, once it has run out: the search then stops as a budget stops it
    /// ([`Stopped::Time`]). The watcher keeps the time, as it times the search.
    fn out_of_time(&self) -> Option<Duration> {
        None
    }
    /// The search spilled to disk ([`crate::spill`]): told after each spill, and once more
    /// at the end with the files' peak.
    fn spilled(&mut self, _so_far: &Spilled) {}
}

/// The watcher of [`run`]: nobody.
impl Watch for () {}

/// Looks at a running search (2 ms apart) between two progress reports: about 0.1 s.
pub const PROGRESS_TICKS: u32 = 50;

/// How to explore.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Exploration {
    pub threads: usize,
    /// Explore paths of at most this many steps.
    pub depth: Option<usize>,
    /// Stop at the first counterexample instead of settling every property.
    pub first_counterexample: bool,
    pub strategy: Strategy,
    pub budget: Budget,
    /// Spill the visited set and the frontier to disk instead of stopping at the memory
    /// budget (breadth-first search by [`CompactBfs`] only); `None`: stop there.
    pub spill: Option<Spill>,
}

impl Default for Exploration {
    fn default() -> Self {
        Self {
            threads: 1,
            depth: None,
            first_counterexample: false,
            strategy: Strategy::Bfs,
            budget: Budget::default(),
            spill: None,
        }
    }
}

/// States a simulation visits when no state budget is given: random walks never finish on
/// their own while an `always` property holds.
pub const SIMULATION_STATES: usize = 1_000_000;

/// Explores `model` with the strategy, threads, depth and budget of `how`. Breadth-first on
/// one thread, each counterexample is a shortest one.
pub fn run(model: CheckModel, how: Exploration) -> Outcome {
    run_watched(model, how, &mut ())
}

/// [`run`], telling `watch` how the search goes and letting it stop the search.
pub fn run_watched(model: CheckModel, how: Exploration, watch: &mut dyn Watch) -> Outcome {
    let props = model.properties();
    for f in model.cfg.found.iter() {
        f.store(false, Ordering::Relaxed);
    }
    let stop = Arc::clone(&model.cfg.stop);
    if how.strategy == Strategy::Bfs && compact::supports(&model) {
        let images = model.cfg.symmetry.clone().map(|sym| {
            Arc::new(move |s: &State| sym.images(s)) as compact::Images<ProcessActor, ()>
        });
        let reductions = compact::Reductions {
            images,
            invisible: model.cfg.reduction.then(|| invisible(&model)),
            spent: model.cfg.reduction.then(|| spent(&model)),
        };
        let checker = CompactBfs::spawn_spilling(
            model,
            (how.threads, how.depth, how.first_counterexample),
            reductions,
            Some(Arc::clone(&stop)),
            how.spill,
        );
        let store = checker.spill();
        let watched = supervise(checker, &stop, how.budget, watch, store.as_deref());
        return outcome(watched, &props);
    }
    let mut builder = model.checker().threads(how.threads.max(1));
    if let Some(d) = how.depth {
        builder = builder.target_max_depth(d);
    }
    if how.first_counterexample {
        builder = builder.finish_when(HasDiscoveries::AnyFailures);
    }
    match how.strategy {
        Strategy::Bfs => outcome(
            supervise(builder.spawn_bfs(), &stop, how.budget, watch, None),
            &props,
        ),
        Strategy::Dfs => outcome(
            supervise(builder.spawn_dfs(), &stop, how.budget, watch, None),
            &props,
        ),
        Strategy::Simulation { seed } => {
            // A walk ends on its own; the search ends at the state budget, which stateright
            // counts itself (states visited, the same on every run of a seed on one thread).
            let limit = how.budget.max_states.unwrap_or(SIMULATION_STATES);
            let budget = Budget {
                max_states: None,
                ..how.budget
            };
            let checker = builder
                .target_state_count(limit)
                .spawn_simulation(seed, UniformChooser);
            let (checker, spent) = supervise(checker, &stop, budget, watch, None);
            let spent =
                spent.or((checker.state_count() >= limit).then_some(Stopped::States { limit }));
            outcome((checker, spent), &props)
        }
    }
}

/// The partial-order reduction's test of a step of `model` ([`crate::reduction`]): no
/// property's [`crate::config::Undo`] says it may undo a discovery.
pub fn invisible(model: &CheckModel) -> Invisible<ProcessActor, ()> {
    let cfg = model.cfg.clone();
    Arc::new(move |before: &State, p: usize, after: &State| {
        let (b, a) = (&*before.actor_states[p], &*after.actor_states[p]);
        !cfg.undo.iter().any(|undo| undo(&cfg, b, a))
    })
}

/// Which messages in flight the search of `model` may forget ([`compact::Spent`]): one to a
/// crashed process, which the protocols here never deliver (they are crash-stop), and one
/// its receiver's layer declares spent ([`Microprotocol::spent`]).
pub fn spent(model: &CheckModel) -> compact::Spent<ProcessActor> {
    let n = model.cfg.n;
    Arc::new(move |states, crashed, env| {
        let to = usize::from(env.dst);
        let receiver: &ProcessState = &states[to];
        crashed[to]
            || receiver.zombie
            || receiver.stack.spent(
                &Ctx { me: to as Pid, n },
                env.msg.layer,
                usize::from(env.src) as Pid,
                &env.msg.msg,
            )
    })
}

/// The figures and verdicts of a finished checker.
fn outcome<C: Checker<CheckModel>>(
    (checker, stopped): (C, Option<Stopped>),
    props: &[stateright::Property<CheckModel>],
) -> Outcome {
    let mut discoveries = checker.discoveries();
    let verdicts = props
        .iter()
        .map(|p| {
            let path = discoveries.remove(p.name);
            let holds = match p.expectation {
                Expectation::Always | Expectation::Eventually => path.is_none(),
                Expectation::Sometimes => path.is_some(),
            };
            Verdict {
                name: p.name,
                expectation: p.expectation.clone(),
                holds,
                path,
            }
        })
        .collect();
    Outcome {
        states: checker.state_count(),
        unique_states: checker.unique_state_count(),
        max_depth: checker.max_depth(),
        verdicts,
        stopped,
    }
}

/// Waits for `checker`, watching its budget and telling `watch`: when the unique states or
/// this process's resident memory reach theirs, the watcher's time runs out or it
/// interrupts, `stop` closes the model's boundary, so the checker settles the states it holds
/// without making new ones and ends. With `spill`, memory nearing its budget asks the
/// checker to spill first, and a spill that fails has closed the boundary itself.
fn supervise<C: Checker<CheckModel>>(
    checker: C,
    stop: &AtomicBool,
    budget: Budget,
    watch: &mut dyn Watch,
    spill: Option<&Store>,
) -> (C, Option<Stopped>) {
    let found = Arc::clone(&checker.model().cfg.found);
    let expectations: Vec<Expectation> = checker
        .model()
        .properties()
        .iter()
        .map(|p| p.expectation.clone())
        .collect();
    let names: Vec<&'static str> = checker
        .model()
        .properties()
        .iter()
        .map(|p| p.name)
        .collect();
    let mut told = vec![false; found.len()];
    let mut tell = |watch: &mut dyn Watch, unique_states: usize| {
        for (i, f) in found.iter().enumerate() {
            if !told[i] && f.load(Ordering::Relaxed) {
                told[i] = true;
                watch.discovered(&Discovery {
                    name: names[i],
                    expectation: expectations[i].clone(),
                    unique_states,
                });
            }
        }
    };
    let mut spent = None;
    let mut ticks = 0u32;
    let mut spills = 0;
    while !checker.is_done() {
        if let Some(so_far) = spill.map(Store::report).filter(|r| r.spills != spills) {
            spills = so_far.spills;
            watch.spilled(&so_far);
        }
        let unique = checker.unique_state_count();
        tell(watch, unique);
        let memory = (budget.max_memory.is_some() || ticks % PROGRESS_TICKS == 0)
            .then(resident_memory)
            .flatten();
        if ticks % PROGRESS_TICKS == 0 {
            watch.progress(&Progress {
                states: checker.state_count(),
                unique_states: unique,
                max_depth: checker.max_depth(),
                memory,
            });
        }
        if spent.is_none() {
            // A spill that failed has closed the boundary already.
            spent = spill.and_then(Store::failure);
            if let Some(limit) = budget.max_states {
                if unique >= limit {
                    spent = Some(Stopped::States { limit });
                }
            }
            if let (Some(limit), Some(seen)) = (budget.max_memory, memory) {
                if let Some(store) = spill {
                    store.look(seen, limit);
                }
                // Stop a little early: memory still grows between two looks and while the
                // states in hand are settled, and the peak must stay under the limit.
                if seen >= limit - limit / MEMORY_HEADROOM {
                    spent = Some(Stopped::Memory { limit, seen });
                }
            }
            if let Some(limit) = watch.out_of_time().filter(|_| spent.is_none()) {
                spent = Some(Stopped::Time { limit });
            }
            if spent.is_none() && watch.interrupted() {
                spent = Some(Stopped::Interrupted);
            }
            if spent.is_some() {
                stop.store(true, Ordering::Relaxed);
            }
        }
        ticks = ticks.wrapping_add(1);
        std::thread::sleep(Duration::from_millis(2));
    }
    tell(watch, checker.unique_state_count());
    let checker = checker.join();
    if let Some(store) = spill {
        spent = spent.or(store.failure());
        let so_far = store.report();
        if so_far.spills > 0 {
            watch.spilled(&so_far);
        }
    }
    (checker, spent)
}
