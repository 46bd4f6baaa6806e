//! A process's stack of microprotocol instances (seed 3.5, 6.2) and the routing of their
//! effects. The `compose` module builds a stack and its [`Wiring`] from a scenario's
//! `stack: [Layer(id, protocol, below, uses)]`.
//!
//! The stack itself never delivers anything on its own: [`Stack::step`] runs one layer's
//! handler and says where each effect goes ([`Routed`]). Every host of a stack routes the
//! same way: the simulator turns every hop into an event of its scheduler; the model checker
//! and the real-network node apply the hops inside one process at once
//! ([`Stack::step_local`]) and carry out what leaves it.

use std::collections::VecDeque;
use std::fmt;
use std::sync::Arc;

use crate::codec::{Codec, Codecs};
use crate::payload::{Payload, WireError};
use crate::protocol::Layer;
use crate::service::{Ctx, Effect, Indication, Input, LayerIx, Request, Service, APP, NET};
use crate::wire::{Pid, Real};

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
    /// The readable form of a payload (or of anything holding payloads) of this stack.
    pub fn render<T: fmt::Display + ?Sized>(&self, value: &T) -> String {
        crate::codec::render(&self.codecs, value)
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
        // The stack's own payloads always decode; a foreign one changes nothing.
        self.step_local_with(wiring, ctx, layer, input, |_, _| {})
            .unwrap_or_default()
    }

    /// [`Stack::step_local`], telling `hop` of every input that passes from one layer to
    /// another on the way (for a host that records what layers tell each other). An `input`
    /// that `layer` refuses (a payload that does not decode as the layer's, which bytes from
    /// a real network may be) is returned as the error and changes nothing; the hops after
    /// it carry the stack's own payloads.
    pub fn step_local_with(
        &mut self,
        wiring: &Wiring,
        ctx: &Ctx,
        layer: LayerIx,
        input: Input,
        mut hop: impl FnMut(LayerIx, &Input),
    ) -> Result<Vec<Routed>, WireError> {
        let mut queue = VecDeque::new();
        let mut out = Vec::new();
        let mut route = |r: Routed, queue: &mut VecDeque<(LayerIx, Input)>| match r {
            Routed::Layer { to, input } if to != NET => {
                hop(to, &input);
                queue.push_back((to, input));
            }
            other => out.push(other),
        };
        for r in self.step(wiring, ctx, layer, input)? {
            route(r, &mut queue);
        }
        while let Some((l, i)) = queue.pop_front() {
            for r in self.step(wiring, ctx, l, i).unwrap_or_default() {
                route(r, &mut queue);
            }
        }
        Ok(out)
    }

    /// Whether `msg` from `from`, arriving at `layer`, can no longer change this stack
    /// ([`Microprotocol::spent`]).
    pub fn spent(&self, ctx: &Ctx, layer: LayerIx, from: Pid, msg: &Payload) -> bool {
        self.layers
            .get(layer as usize)
            .is_some_and(|l| l.spent(ctx, from, msg))
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
