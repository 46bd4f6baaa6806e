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
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use crate::payload::{Codec, Codecs, Payload, WireError};
use crate::protocol::Layer;
use crate::registry::{ProtocolSpec, Protocols};
use crate::service::{Ctx, Effect, Indication, Input, LayerIx, Request, Service, APP, NET};
use crate::wire::{app_codec, Pid, Real};

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
    /// A layer `id` running `protocol` (its RON text, `"Retransmit(period: 1.0)"`) on `below`,
    /// using `uses`.
    pub fn new(id: &str, protocol: &str, below: &str, uses: &[&str]) -> Self {
        Self {
            id: id.to_string(),
            protocol: ProtocolSpec::new(protocol),
            below: below.to_string(),
            uses: uses.iter().map(|u| u.to_string()).collect(),
        }
    }
}

/// A wiring or configuration mistake; `layer` is the index in the stack list, `field` the
/// offending field (`"below"`, `"protocol"`, `"protocol.period"`, ...) and `at`, for an error
/// inside the protocol's RON text, the 1-based line and column in that text.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct StackError {
    pub layer: usize,
    pub field: String,
    pub at: Option<(usize, usize)>,
    pub message: String,
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
    /// What each layer provides.
    pub provides: Vec<Service>,
    /// How to render each layer's messages and the application's.
    pub codecs: Arc<Codecs>,
}

impl Wiring {
    /// Checks a stack and builds one process's fresh instances: unique ids, known protocols
    /// whose configurations read and are accepted, `below`/`uses` naming layers, no cycles,
    /// every layer served by what it sits on and uses.
    pub fn check(
        specs: &[LayerSpec],
        protocols: &Protocols,
    ) -> Result<(Wiring, Stack), StackError> {
        let err = |layer, field: &str, message: String| StackError {
            layer,
            field: field.to_string(),
            at: None,
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
        }
        let mut shapes = Vec::new();
        let mut layers = Vec::new();
        let mut codecs = Vec::new();
        for (i, s) in specs.iter().enumerate() {
            let (shape, layer) = protocols.build(&s.protocol).map_err(|e| StackError {
                layer: i,
                field: match &e.field {
                    Some(f) => format!("protocol.{f}"),
                    None => "protocol".into(),
                },
                at: e.at,
                message: e.message,
            })?;
            codecs.push(protocols.codec(&s.protocol).expect("built"));
            shapes.push(shape);
            layers.push(layer);
        }
        let resolve = |i: usize, field: &'static str, name: &str| -> Result<LayerIx, StackError> {
            if name == "net" {
                return Ok(NET);
            }
            index.get(name).map(|&j| j as LayerIx).ok_or_else(|| {
                // A layer never sits on or uses itself: it is no candidate.
                let known: Vec<&str> = std::iter::once("net")
                    .chain(
                        (specs.iter().enumerate())
                            .filter_map(|(j, s)| (j != i).then_some(s.id.as_str())),
                    )
                    .collect();
                err(
                    i,
                    field,
                    format!(
                        "unknown layer {name:?} in `{field}`; expected one of {}",
                        known.join(", ")
                    ),
                )
            })
        };
        let provides = |ix: LayerIx| {
            if ix == NET {
                Service::P2P
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
                        need.what,
                        s.below,
                        provides(b).what
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
                        needs.iter().map(|n| n.what).collect::<Vec<_>>().join(", "),
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
                            need.what,
                            provides(ix).what
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
        let wiring = Wiring {
            ids: specs.iter().map(|s| s.id.clone()).collect(),
            below,
            uses,
            above,
            app_hears,
            provides: shapes.iter().map(|s| s.provides).collect(),
            codecs: Arc::new(Codecs {
                layers: codecs,
                app: app_codec(),
            }),
        };
        Ok((wiring, Stack { layers }))
    }

    /// The readable form of a payload (or of anything holding payloads) of this stack.
    pub fn render<T: fmt::Display + ?Sized>(&self, value: &T) -> String {
        crate::payload::render(&self.codecs, value)
    }

    /// The readable form of a timer of layer `layer`.
    pub fn render_timer(&self, layer: LayerIx, timer: &Payload) -> String {
        struct Timer<'a>(&'a Codec, &'a Payload);
        impl fmt::Display for Timer<'_> {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                match (self.0.render_timer)(self.1.bytes(), f) {
                    Ok(r) => r,
                    Err(e) => write!(f, "<{}: {e}>", self.0.protocol),
                }
            }
        }
        match self.codec(layer) {
            Some(c) => self.render(&Timer(c, timer)),
            None => format!("{timer}"),
        }
    }

    /// The codec of a layer (or of the application).
    pub fn codec(&self, layer: LayerIx) -> Option<&Codec> {
        if layer == APP {
            Some(&self.codecs.app)
        } else {
            self.codecs.layers.get(layer as usize)
        }
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
        msg: Payload,
    },
    /// To the application, from `layer`.
    App {
        layer: LayerIx,
        ind: Indication,
    },
    SetTimer {
        layer: LayerIx,
        timer: Payload,
        after: Real,
    },
    CancelTimer {
        layer: LayerIx,
        timer: Payload,
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
/// and says where each of its effects goes. An input whose payload does not decode as the
/// layer's own type (which the stack never produces; bytes from a real network may) is
/// refused with the decoding error and changes nothing.
pub fn step_layer(
    layer: &mut Layer,
    wiring: &Wiring,
    ctx: &Ctx,
    ix: LayerIx,
    input: Input,
) -> Result<Vec<Routed>, WireError> {
    let effects = layer.handle(ctx, ix, input)?;
    let i = ix as usize;
    let mut routed = Vec::new();
    for e in effects {
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
    Ok(routed)
}

/// One process's stack of protocol instances.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Stack {
    pub layers: Vec<Layer>,
}

impl Stack {
    /// This stack with every process id renamed ([`crate::symmetry`]), or `None` if one of
    /// its layers is not symmetric.
    pub fn renamed(&self, r: &crate::symmetry::Rename) -> Option<Self> {
        let layers = self
            .layers
            .iter()
            .map(|l| l.renamed(r))
            .collect::<Option<_>>()?;
        Some(Self { layers })
    }

    /// Runs one layer's handler and routes its effects.
    pub fn step(
        &mut self,
        wiring: &Wiring,
        ctx: &Ctx,
        layer: LayerIx,
        input: Input,
    ) -> Result<Vec<Routed>, WireError> {
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
            // The stack's own payloads always decode; a foreign one changes nothing.
            for r in self.step(wiring, ctx, l, i).unwrap_or_default() {
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
