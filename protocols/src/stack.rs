//! Composition (seed 3.5, 6.2): a process's stack of microprotocol instances, wired by
//! name as in a scenario's `stack: [Layer(id, protocol, below, uses)]`, checked before use and
//! run by routing each handler's effects.
//!
//! The stack itself never delivers anything on its own: [`Stack::step`] runs one layer's
//! handler and says where each effect goes ([`Routed`]). The simulator turns every hop into
//! an event of its scheduler; a model checker applies the hops inside one step
//! ([`Stack::step_local`]).

use std::collections::BTreeMap;
use std::fmt;

use serde::{Deserialize, Serialize};

use crate::consensus::ChandraToueg;
use crate::consensus_abcast::ConsensusAbcast;
use crate::custom::{CustomLayer, Params, Protocols, Shape};
use crate::fifo::Fifo;
use crate::heartbeat::Heartbeat;
use crate::lamport::LamportAbcast;
use crate::omega::Omega;
use crate::protocol::Microprotocol;
use crate::rbroadcast::ReliableBroadcast;
use crate::retransmit::Retransmit;
use crate::sequencer::FixedSequencer;
use crate::service::{Ctx, Effect, Indication, Input, LayerIx, Out, Request, TimerId, APP, NET};
use crate::wire::{Pid, Real};

/// A protocol and its parameters, as a scenario names it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ProtocolSpec {
    Fifo,
    Retransmit {
        period: f64,
    },
    ReliableBroadcast,
    LamportAbcast,
    /// Process 0 is the sequencer.
    FixedSequencer,
    Heartbeat {
        period: f64,
        timeout: f64,
    },
    Omega,
    ChandraToueg,
    ConsensusAbcast,
    /// A protocol registered in Rust under `name` (see [`Protocols`]), with its parameters.
    Custom {
        name: String,
        #[serde(default)]
        params: Params,
    },
}

/// A service a layer provides or needs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Service {
    /// Point-to-point send/deliver.
    P2p,
    /// Point-to-point with per-link FIFO order.
    FifoP2p,
    /// Broadcast/deliver.
    Broadcast,
    /// Broadcast with total order.
    TotalOrder,
    Consensus,
    FailureDetector,
    Leader,
}

impl Service {
    /// Whether a layer providing `self` can serve a need for `need`.
    pub fn serves(self, need: Service) -> bool {
        self == need
            || (self == Service::FifoP2p && need == Service::P2p)
            || (self == Service::TotalOrder && need == Service::Broadcast)
    }

    /// What the service is, in words.
    pub fn name(self) -> &'static str {
        match self {
            Service::P2p => "point-to-point messages",
            Service::FifoP2p => "FIFO point-to-point messages",
            Service::Broadcast => "broadcast",
            Service::TotalOrder => "total-order broadcast",
            Service::Consensus => "consensus",
            Service::FailureDetector => "a failure detector",
            Service::Leader => "leader election",
        }
    }
}

impl ProtocolSpec {
    /// What the protocol provides and needs; custom protocols are looked up in `protocols`.
    pub fn shape(&self, protocols: &Protocols) -> Result<Shape, String> {
        let provides = match self {
            ProtocolSpec::Custom { name, .. } => return protocols.shape(name).cloned(),
            ProtocolSpec::Fifo => Service::FifoP2p,
            ProtocolSpec::Retransmit { .. } => Service::P2p,
            ProtocolSpec::ReliableBroadcast => Service::Broadcast,
            ProtocolSpec::LamportAbcast
            | ProtocolSpec::FixedSequencer
            | ProtocolSpec::ConsensusAbcast => Service::TotalOrder,
            ProtocolSpec::Heartbeat { .. } => Service::FailureDetector,
            ProtocolSpec::Omega => Service::Leader,
            ProtocolSpec::ChandraToueg => Service::Consensus,
        };
        let needs_below = match self {
            ProtocolSpec::LamportAbcast => Service::FifoP2p,
            ProtocolSpec::ConsensusAbcast => Service::Broadcast,
            _ => Service::P2p,
        };
        let needs_uses = match self {
            ProtocolSpec::Omega | ProtocolSpec::ChandraToueg => vec![Service::FailureDetector],
            ProtocolSpec::ConsensusAbcast => vec![Service::Consensus],
            _ => vec![],
        };
        Ok(Shape {
            provides,
            needs_below,
            needs_uses,
        })
    }

    /// Checks parameters: `Err` names the field and what is expected.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        let positive = |what: &'static str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err((
                    what,
                    format!("{what} is {v}; expected a finite number > 0 (seconds)"),
                ))
            }
        };
        match *self {
            ProtocolSpec::Retransmit { period } => positive("period", period),
            ProtocolSpec::Heartbeat { period, timeout } => {
                positive("period", period)?;
                positive("timeout", timeout)?;
                if timeout < period {
                    return Err(("timeout", format!("timeout {timeout} is shorter than the period {period}; expected timeout >= period")));
                }
                Ok(())
            }
            _ => Ok(()),
        }
    }

    /// A fresh instance; custom protocols are built by their factory in `protocols`.
    pub fn instantiate(&self, protocols: &Protocols) -> Result<Layer, String> {
        Ok(match self {
            ProtocolSpec::Custom { name, params } => Layer::Custom(protocols.build(name, params)?),
            ProtocolSpec::Fifo => Layer::Fifo(Fifo::default()),
            ProtocolSpec::Retransmit { period } => Layer::Retransmit(Retransmit::new(*period)),
            ProtocolSpec::ReliableBroadcast => {
                Layer::ReliableBroadcast(ReliableBroadcast::default())
            }
            ProtocolSpec::LamportAbcast => Layer::LamportAbcast(LamportAbcast::default()),
            ProtocolSpec::FixedSequencer => Layer::FixedSequencer(FixedSequencer::new(0)),
            ProtocolSpec::Heartbeat { period, timeout } => {
                Layer::Heartbeat(Heartbeat::new(*period, *timeout))
            }
            ProtocolSpec::Omega => Layer::Omega(Omega::default()),
            ProtocolSpec::ChandraToueg => Layer::ChandraToueg(ChandraToueg::default()),
            ProtocolSpec::ConsensusAbcast => Layer::ConsensusAbcast(ConsensusAbcast::default()),
        })
    }
}

/// One layer of a scenario's stack: `Layer(id: "abcast", protocol: LamportAbcast, below: "fifo")`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, rename = "Layer")]
pub struct LayerSpec {
    pub id: String,
    pub protocol: ProtocolSpec,
    /// `"net"` or the id of another layer.
    pub below: String,
    #[serde(default)]
    pub uses: Vec<String>,
}

impl LayerSpec {
    /// A layer `id` running `protocol` on `below`, using `uses`.
    pub fn new(id: &str, protocol: ProtocolSpec, below: &str, uses: &[&str]) -> Self {
        Self {
            id: id.to_string(),
            protocol,
            below: below.to_string(),
            uses: uses.iter().map(|u| u.to_string()).collect(),
        }
    }
}

/// A wiring mistake; `layer` is the index in the stack list, `field` the offending field.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct StackError {
    pub layer: usize,
    pub field: &'static str,
    pub message: String,
}

/// A protocol instance of a built-in kind (the closed set keeps states `Eq + Hash` for model
/// checking).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Layer {
    Fifo(Fifo),
    Retransmit(Retransmit),
    ReliableBroadcast(ReliableBroadcast),
    LamportAbcast(LamportAbcast),
    FixedSequencer(FixedSequencer),
    Heartbeat(Heartbeat),
    Omega(Omega),
    ChandraToueg(ChandraToueg),
    ConsensusAbcast(ConsensusAbcast),
    /// A registered user protocol.
    Custom(CustomLayer),
}

impl Layer {
    fn proto(&mut self) -> &mut dyn DynHandle {
        match self {
            Layer::Custom(p) => p,
            Layer::Fifo(p) => p,
            Layer::Retransmit(p) => p,
            Layer::ReliableBroadcast(p) => p,
            Layer::LamportAbcast(p) => p,
            Layer::FixedSequencer(p) => p,
            Layer::Heartbeat(p) => p,
            Layer::Omega(p) => p,
            Layer::ChandraToueg(p) => p,
            Layer::ConsensusAbcast(p) => p,
        }
    }

    /// Neko's name of the protocol.
    pub fn name(&self) -> &'static str {
        match self {
            Layer::Fifo(p) => p.name(),
            Layer::Retransmit(p) => p.name(),
            Layer::ReliableBroadcast(p) => p.name(),
            Layer::LamportAbcast(p) => p.name(),
            Layer::FixedSequencer(p) => p.name(),
            Layer::Heartbeat(p) => p.name(),
            Layer::Omega(p) => p.name(),
            Layer::ChandraToueg(p) => p.name(),
            Layer::ConsensusAbcast(p) => p.name(),
            Layer::Custom(p) => p.name(),
        }
    }
}

/// Object-safe handle over [`Microprotocol::handle`].
trait DynHandle {
    fn dyn_handle(&mut self, ctx: &Ctx, input: Input, out: &mut Out);
}

impl<P: Microprotocol> DynHandle for P {
    fn dyn_handle(&mut self, ctx: &Ctx, input: Input, out: &mut Out) {
        self.handle(ctx, input, out)
    }
}

impl DynHandle for CustomLayer {
    fn dyn_handle(&mut self, ctx: &Ctx, input: Input, out: &mut Out) {
        self.protocol_mut().handle(ctx, input, out)
    }
}

/// The checked wiring of a stack (the same in every process).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Wiring {
    pub ids: Vec<String>,
    pub below: Vec<LayerIx>,
    pub uses: Vec<Vec<LayerIx>>,
    /// Who hears a layer's indications addressed to "everybody above".
    pub above: Vec<Vec<LayerIx>>,
    /// Layers whose indications reach the application (those nobody else sits on or uses).
    pub app_hears: Vec<bool>,
}

impl Wiring {
    /// Checks a stack of built-in protocols (see [`Wiring::check_with`]).
    pub fn check(specs: &[LayerSpec]) -> Result<Wiring, StackError> {
        Self::check_with(specs, &Protocols::new())
    }

    /// Checks a stack: unique ids, known protocols, `below`/`uses` and ids, no cycles, every
    /// layer served by what it sits on and uses, parameters in range (a custom protocol's
    /// factory judges its parameters).
    pub fn check_with(specs: &[LayerSpec], protocols: &Protocols) -> Result<Wiring, StackError> {
        let err = |layer, field, message: String| StackError {
            layer,
            field,
            message,
        };
        let mut index: BTreeMap<&str, usize> = BTreeMap::new();
        for (i, s) in specs.iter().enumerate() {
            if s.id == "net" || s.id.is_empty() {
                return Err(err(
                    i,
                    "id",
                    format!(
                        "layer id {:?} is reserved or empty; expected another name",
                        s.id
                    ),
                ));
            }
            if let Some(j) = index.insert(&s.id, i) {
                return Err(err(
                    i,
                    "id",
                    format!(
                        "duplicate layer id {:?} (also layer {j}); expected unique ids",
                        s.id
                    ),
                ));
            }
            s.protocol.check().map_err(|(_, m)| StackError {
                layer: i,
                field: "protocol",
                message: m,
            })?;
        }
        let mut shapes = Vec::new();
        for (i, s) in specs.iter().enumerate() {
            let shape = s
                .protocol
                .shape(protocols)
                .map_err(|m| err(i, "protocol", m))?;
            if let ProtocolSpec::Custom { name, params } = &s.protocol {
                protocols
                    .build(name, params)
                    .map_err(|m| err(i, "protocol", m))?;
            }
            shapes.push(shape);
        }
        let resolve = |i: usize, field: &'static str, name: &str| -> Result<LayerIx, StackError> {
            if name == "net" {
                return Ok(NET);
            }
            index.get(name).map(|&j| j as LayerIx).ok_or_else(|| {
                let known: Vec<&str> = std::iter::once("net")
                    .chain(specs.iter().map(|s| s.id.as_str()))
                    .collect();
                err(
                    i,
                    field,
                    format!(
                        "unknown layer {name:?}; expected one of {}",
                        known.join(", ")
                    ),
                )
            })
        };
        let provides = |ix: LayerIx| {
            if ix == NET {
                Service::P2p
            } else {
                shapes[ix as usize].provides
            }
        };
        let mut below = Vec::new();
        let mut uses = Vec::new();
        for (i, s) in specs.iter().enumerate() {
            let b = resolve(i, "below", &s.below)?;
            if b as usize == i {
                return Err(err(i, "below", format!("layer {:?} sits on itself", s.id)));
            }
            let need = shapes[i].needs_below;
            if !provides(b).serves(need) {
                return Err(err(
                    i,
                    "below",
                    format!(
                        "layer {:?} ({:?}) needs {} below it, but {:?} provides {}",
                        s.id,
                        s.protocol,
                        need.name(),
                        s.below,
                        provides(b).name()
                    ),
                ));
            }
            let needs = &shapes[i].needs_uses;
            if s.uses.len() != needs.len() {
                return Err(err(
                    i,
                    "uses",
                    format!(
                        "layer {:?} ({:?}) uses {} layer(s) ({}), got {}",
                        s.id,
                        s.protocol,
                        needs.len(),
                        needs
                            .iter()
                            .map(|n| n.name())
                            .collect::<Vec<_>>()
                            .join(", "),
                        s.uses.len()
                    ),
                ));
            }
            let mut us = Vec::new();
            for (u, need) in s.uses.iter().zip(needs) {
                let ix = resolve(i, "uses", u)?;
                if ix == NET || !provides(ix).serves(*need) {
                    return Err(err(
                        i,
                        "uses",
                        format!(
                            "layer {:?} needs {} from {u:?}, which provides {}",
                            s.id,
                            need.name(),
                            provides(ix).name()
                        ),
                    ));
                }
                us.push(ix);
            }
            below.push(b);
            uses.push(us);
        }
        // Cycles through below/uses.
        fn visit(
            i: usize,
            below: &[LayerIx],
            uses: &[Vec<LayerIx>],
            state: &mut [u8],
        ) -> Option<usize> {
            if state[i] == 2 {
                return None;
            }
            if state[i] == 1 {
                return Some(i);
            }
            state[i] = 1;
            for &j in std::iter::once(&below[i]).chain(uses[i].iter()) {
                if j != NET {
                    if let Some(c) = visit(j as usize, below, uses, state) {
                        return Some(c);
                    }
                }
            }
            state[i] = 2;
            None
        }
        let mut state = vec![0u8; specs.len()];
        for i in 0..specs.len() {
            if let Some(c) = visit(i, &below, &uses, &mut state) {
                return Err(err(c, "below", format!("layer {:?} is part of a cycle of layers; expected layers to stack without loops", specs[c].id)));
            }
        }
        let mut above = vec![Vec::new(); specs.len()];
        for i in 0..specs.len() {
            for &j in std::iter::once(&below[i]).chain(uses[i].iter()) {
                if j != NET {
                    above[j as usize].push(i as LayerIx);
                }
            }
        }
        let app_hears = above.iter().map(|a| a.is_empty()).collect();
        Ok(Wiring {
            ids: specs.iter().map(|s| s.id.clone()).collect(),
            below,
            uses,
            above,
            app_hears,
        })
    }

    /// The index of a layer by id.
    pub fn index(&self, id: &str) -> Option<LayerIx> {
        self.ids.iter().position(|s| s == id).map(|i| i as LayerIx)
    }
}

/// Where an effect goes.
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Routed {
    /// To another layer of the same process.
    Layer {
        to: LayerIx,
        input: Input,
    },
    /// To the network: `layer` sends `req` (a `Send`) to the same layer of other processes.
    Net {
        layer: LayerIx,
        to: Vec<Pid>,
        msg: crate::wire::Wire,
    },
    /// To the application, from `layer`.
    App {
        layer: LayerIx,
        ind: Indication,
    },
    SetTimer {
        layer: LayerIx,
        timer: TimerId,
        after: Real,
    },
    CancelTimer {
        layer: LayerIx,
        timer: TimerId,
    },
}

fn to_layer(target: LayerIx, from: LayerIx, req: Request) -> Routed {
    match (target, req) {
        (NET, Request::Send { to, msg }) => Routed::Net {
            layer: from,
            to,
            msg,
        },
        (NET, other) => Routed::Layer {
            to: NET,
            input: Input::Request { from, req: other },
        },
        (t, req) => Routed::Layer {
            to: t,
            input: Input::Request { from, req },
        },
    }
}

/// Runs one layer instance's handler (the layer at index `ix` of a stack wired by `wiring`)
/// and says where each of its effects goes.
pub fn step_layer(
    layer: &mut Layer,
    wiring: &Wiring,
    ctx: &Ctx,
    ix: LayerIx,
    input: Input,
) -> Vec<Routed> {
    let mut out = Out::new();
    layer.proto().dyn_handle(ctx, input, &mut out);
    let i = ix as usize;
    let mut routed = Vec::new();
    for e in out.effects {
        match e {
            Effect::Down(req) => routed.push(to_layer(wiring.below[i], ix, req)),
            Effect::Use { slot, req } => {
                routed.push(to_layer(wiring.uses[i][slot as usize], ix, req))
            }
            Effect::Up { to: Some(APP), ind } => routed.push(Routed::App { layer: ix, ind }),
            Effect::Up { to: Some(t), ind } => routed.push(Routed::Layer {
                to: t,
                input: Input::Indication { from: ix, ind },
            }),
            Effect::Up { to: None, ind } => {
                for &a in &wiring.above[i] {
                    routed.push(Routed::Layer {
                        to: a,
                        input: Input::Indication {
                            from: ix,
                            ind: ind.clone(),
                        },
                    });
                }
                if wiring.app_hears[i] {
                    routed.push(Routed::App { layer: ix, ind });
                }
            }
            Effect::SetTimer { timer, after } => routed.push(Routed::SetTimer {
                layer: ix,
                timer,
                after,
            }),
            Effect::CancelTimer(timer) => routed.push(Routed::CancelTimer { layer: ix, timer }),
        }
    }
    routed
}

/// One process's stack of protocol instances.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Stack {
    pub layers: Vec<Layer>,
}

impl Stack {
    /// Fresh instances of every layer of a stack of built-in protocols.
    ///
    /// # Panics
    /// If a layer is a custom protocol (use [`Stack::with_protocols`]).
    pub fn new(specs: &[LayerSpec]) -> Self {
        Self::with_protocols(specs, &Protocols::new())
            .expect("Stack::new builds built-in protocols only")
    }

    /// Fresh instances of every layer; custom protocols are built from `protocols`.
    pub fn with_protocols(specs: &[LayerSpec], protocols: &Protocols) -> Result<Self, String> {
        Ok(Self {
            layers: specs
                .iter()
                .map(|s| s.protocol.instantiate(protocols))
                .collect::<Result<_, _>>()?,
        })
    }

    /// Runs one layer's handler and routes its effects.
    pub fn step(
        &mut self,
        wiring: &Wiring,
        ctx: &Ctx,
        layer: LayerIx,
        input: Input,
    ) -> Vec<Routed> {
        step_layer(&mut self.layers[layer as usize], wiring, ctx, layer, input)
    }

    /// Runs `input` at `layer` and every hop it causes inside the process, in FIFO order;
    /// returns what leaves the process (network sends, application indications, timers).
    pub fn step_local(
        &mut self,
        wiring: &Wiring,
        ctx: &Ctx,
        layer: LayerIx,
        input: Input,
    ) -> Vec<Routed> {
        let mut queue = std::collections::VecDeque::from([(layer, input)]);
        let mut out = Vec::new();
        while let Some((l, i)) = queue.pop_front() {
            for r in self.step(wiring, ctx, l, i) {
                match r {
                    Routed::Layer { to, input } if to != NET => queue.push_back((to, input)),
                    other => out.push(other),
                }
            }
        }
        out
    }

    /// Starts every layer, bottom-up in stack order.
    pub fn start_all(&mut self, wiring: &Wiring, ctx: &Ctx) -> Vec<Routed> {
        let mut out = Vec::new();
        for l in 0..self.layers.len() as LayerIx {
            out.extend(self.step_local(wiring, ctx, l, Input::Start));
        }
        out
    }
}

impl fmt::Display for ProtocolSpec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{self:?}")
    }
}
