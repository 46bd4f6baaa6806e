//! Building a stateright model from a stack (the adapter's processes, the network semantics,
//! the bounds and the family's properties) and running the checker on it.

use std::sync::Arc;

use nekosim_protocols::consensus::{ChandraToueg, CtMsg};
use nekosim_protocols::fifo::{Fifo, FifoMsg};
use nekosim_protocols::retransmit::{Retransmit, RtMsg};
use nekosim_protocols::{
    AppMsg, Content, LayerSpec, Payload, Pid, Protocols, Request, Stack, Wiring,
};
use stateright::actor::{ActorModel, ActorModelAction, LossyNetwork, Network};
use stateright::{Checker, Expectation, HasDiscoveries, Model, Path};

use crate::adapter::{ClientRequest, ModelTimer, NetMsg, ProcessActor, Shared};
use crate::property::{properties, Family, State};

/// A model as stateright checks it.
pub type CheckModel = ActorModel<ProcessActor, ModelCfg, ()>;
/// One step of a model.
pub type Action = ActorModelAction<NetMsg, ModelTimer, ()>;

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
    /// Protocol timer firings allowed per process.
    pub timer_budget: u32,
    /// Last Chandra-Toueg round explored in each instance: states with a message of a later
    /// round are outside the model. Round 1 is the least that lets round 0 decide, as a
    /// process that acks round 0 moves on to round 1 in the same step.
    pub max_round: u64,
    /// With crashes, a multicast leaves one message at a time, so a crash can cut it short
    /// (what reliable broadcast must survive). Off, a multicast leaves at once, which keeps
    /// heartbeat-driven stacks with crashes small enough to explore.
    pub partial_multicasts: bool,
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
        }
    }
}

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
}

/// What the properties and the boundary need to know about a model.
#[derive(Clone, Debug)]
pub struct ModelCfg {
    pub family: Family,
    pub n: u32,
    /// Every client request in global order: request `g` is issued by process `g mod n`.
    pub requests: Vec<(Pid, Request)>,
    pub timer_budget: u32,
    /// Round bound, when a layer runs Chandra-Toueg.
    pub max_round: Option<u64>,
    /// What each layer's messages are, for looking through headers.
    pub headers: Vec<Header>,
}

/// The layers whose messages the round bound looks into.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Header {
    ChandraToueg,
    Fifo,
    Retransmit,
    Other,
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

/// The client request `g` of process `p`.
fn request(family: Family, n: u32, g: u32) -> Request {
    match family {
        Family::Consensus => Request::Propose {
            k: u64::from(g / n),
            value: AppMsg::new("V", Content::Int(i64::from(g))).payload(),
        },
        Family::Abcast | Family::Broadcast => Request::Broadcast {
            msg: AppMsg::new("M", Content::Int(i64::from(g))).payload(),
        },
    }
}

/// Builds the model of `target` with `opts`; `tweak` may replace layers of each process's
/// initial stack (for the deliberately broken variants).
pub fn build(
    target: &Target,
    opts: &Options,
    tweak: impl Fn(Pid, &mut Stack),
) -> Result<CheckModel, ModelError> {
    let n = opts.processes;
    if !(2..=8).contains(&n) {
        return Err(ModelError::Processes(n));
    }
    if opts.requests == 0 {
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
    let (wiring, stack) = Wiring::check(&target.stack, &Protocols::with_builtins())
        .map_err(|e| ModelError::Stack(e.to_string()))?;
    let entry = wiring
        .index(&target.entry)
        .ok_or_else(|| ModelError::Stack(format!("no layer {:?}", target.entry)))?;
    let headers: Vec<Header> = stack
        .layers
        .iter()
        .map(|l| {
            if l.downcast_ref::<ChandraToueg>().is_some() {
                Header::ChandraToueg
            } else if l.downcast_ref::<Fifo>().is_some() {
                Header::Fifo
            } else if l.downcast_ref::<Retransmit>().is_some() {
                Header::Retransmit
            } else {
                Header::Other
            }
        })
        .collect();
    let uses_ct = headers.contains(&Header::ChandraToueg);
    let requests: Vec<(Pid, Request)> = (0..opts.requests)
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
    let cfg = ModelCfg {
        family: target.family,
        n,
        requests,
        timer_budget: opts.timer_budget,
        max_round: uses_ct.then_some(opts.max_round),
        headers,
    };
    let network = match opts.network {
        NetworkKind::Ordered => Network::new_ordered([]),
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
    for (expectation, name, condition) in
        properties(target.family, n, opts.crashes, opts.requests.min(n))
    {
        model = model.property(expectation, name, condition);
    }
    Ok(model)
}

/// The Chandra-Toueg round a message belongs to, looking through point-to-point headers.
fn round_of(headers: &[Header], p: &Payload) -> Option<u64> {
    match headers.get(p.layer() as usize)? {
        Header::ChandraToueg => p.decode::<CtMsg>().ok()?.round(),
        Header::Fifo => round_of(headers, &p.decode::<FifoMsg>().ok()?.payload),
        Header::Retransmit => match p.decode::<RtMsg>().ok()? {
            RtMsg::Data { payload, .. } => round_of(headers, &payload),
            RtMsg::Ack { .. } => None,
        },
        Header::Other => None,
    }
}

/// States inside the model: no recovered process (protocols are crash-stop) and, with
/// Chandra-Toueg, no message of a round past the bound (in flight or staged).
fn within_boundary(cfg: &ModelCfg, s: &State) -> bool {
    if s.actor_states.iter().any(|a| a.zombie) {
        return false;
    }
    let Some(max) = cfg.max_round else {
        return true;
    };
    let early = |p: &Payload| round_of(&cfg.headers, p).is_none_or(|r| r <= max);
    s.network.iter_all().all(|e| early(&e.msg.msg))
        && s.actor_states
            .iter()
            .all(|a| a.outbox.iter().all(|(_, m)| early(&m.msg)))
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
}

impl Outcome {
    /// Whether every property holds.
    pub fn all_hold(&self) -> bool {
        self.verdicts.iter().all(|v| v.holds)
    }

    /// The verdict of a property.
    pub fn verdict(&self, name: &str) -> Option<&Verdict> {
        self.verdicts.iter().find(|v| v.name == name)
    }
}

/// How to explore.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Exploration {
    pub threads: usize,
    /// Explore paths of at most this many steps.
    pub depth: Option<usize>,
    /// Stop at the first counterexample instead of settling every property.
    pub first_counterexample: bool,
}

impl Default for Exploration {
    fn default() -> Self {
        Self {
            threads: 1,
            depth: None,
            first_counterexample: false,
        }
    }
}

/// Explores `model` breadth-first (so each counterexample is a shortest one when single
/// threaded).
pub fn run(model: CheckModel, how: Exploration) -> Outcome {
    let props = model.properties();
    let mut builder = model.checker().threads(how.threads.max(1));
    if let Some(d) = how.depth {
        builder = builder.target_max_depth(d);
    }
    if how.first_counterexample {
        builder = builder.finish_when(HasDiscoveries::AnyFailures);
    }
    let checker = builder.spawn_bfs().join();
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
    }
}
