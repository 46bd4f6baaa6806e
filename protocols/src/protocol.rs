//! The microprotocol trait (seed 3.5): a deterministic, sans-IO state machine. Handlers take
//! `&mut self` plus the input and write effects into an [`Out`]; they never perform IO, read a
//! clock or draw random numbers, so the simulator's actors and the stateright models run the
//! very same code.

use std::fmt::Debug;
use std::hash::Hash;

use crate::service::{Ctx, Indication, Input, LayerIx, Out, Request, TimerId};

/// A microprotocol: one layer of a process's stack.
pub trait Microprotocol: Clone + Debug + Eq + Hash + Send + Sync + 'static {
    /// Neko's name of the protocol.
    fn name(&self) -> &'static str;

    /// The process starts.
    fn on_start(&mut self, _ctx: &Ctx, _out: &mut Out) {}

    /// A request from the layer (or application) `from` above.
    fn on_request(&mut self, ctx: &Ctx, from: LayerIx, req: Request, out: &mut Out);

    /// An indication from the layer below (`from` is [`crate::service::NET`] for the network)
    /// or from a layer this one uses.
    fn on_indication(&mut self, ctx: &Ctx, from: LayerIx, ind: Indication, out: &mut Out);

    /// A timer of this layer fired.
    fn on_timer(&mut self, _ctx: &Ctx, _timer: TimerId, _out: &mut Out) {}

    /// Dispatches an input to the handlers.
    fn handle(&mut self, ctx: &Ctx, input: Input, out: &mut Out) {
        match input {
            Input::Start => self.on_start(ctx, out),
            Input::Request { from, req } => self.on_request(ctx, from, req, out),
            Input::Indication { from, ind } => self.on_indication(ctx, from, ind, out),
            Input::Timer(t) => self.on_timer(ctx, t, out),
        }
    }
}
