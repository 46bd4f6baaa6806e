//! The microprotocol trait (seed 3.5): a deterministic, sans-IO state machine with its own
//! message, timer and configuration types. Handlers take `&mut self` plus the input and write
//! effects into an [`Out`]; they never perform IO, read a clock or draw random numbers, so the
//! simulator's actors, the stateright models and a real network host the very same code.
//!
//! The typed edge: a protocol sends and receives its own `Msg` values; the stack encodes them
//! into [`Payload`]s (the one wire encoding) and nests them in the headers of the layers below.
//! Messages of other layers (what the layer above asks it to carry) reach it as opaque
//! payloads, which it keeps, forwards and delivers as they are.

use std::any::Any;
use std::fmt::{self, Debug};
use std::hash::{Hash, Hasher};
use std::marker::PhantomData;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::payload::{Payload, WireError};
use crate::service::{Ctx, Effect, Indication, Input, LayerIx, Request, Shape};
use crate::symmetry::Rename;
use crate::wire::{Pid, Real};

/// What a protocol's messages and timers are: plain serde types with value semantics.
pub trait Message:
    Serialize + DeserializeOwned + Clone + Debug + Eq + Hash + Send + Sync + 'static
{
}

impl<T> Message for T where
    T: Serialize + DeserializeOwned + Clone + Debug + Eq + Hash + Send + Sync + 'static
{
}

/// The message type of a protocol that sends none of its own.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum NoMsg {}

/// The configuration of a protocol that takes none: `protocol: Fifo` or `Fifo()` in a
/// scenario; any field is an error.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoConfig {}

/// Why a value was refused: the one error every validation reports (the configurations of
/// protocols, algorithms, network models and sensors, and the scenario itself). `path` says
/// where the value is (a field, `over.lambda`, `[0]`, `robots[2].radius`; empty for the
/// configuration as a whole), `got` what was found there and `expected` what would be
/// accepted. The scenario loader places it in the file: `FILE:LINE:COL: got; expected ...`.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{}", self.message())]
pub struct FieldError {
    pub path: String,
    /// What was found, as a phrase (`period is -1`, `timeout 1 is shorter than the period 2`).
    pub got: String,
    /// What would be accepted (`a finite number > 0`); empty when there is nothing to add.
    pub expected: String,
}

impl FieldError {
    /// The value at `path` is wrong: `got` says what was found, `expected` what is accepted.
    pub fn new(path: &str, got: impl Into<String>, expected: impl Into<String>) -> Self {
        Self {
            path: path.to_string(),
            got: got.into(),
            expected: expected.into(),
        }
    }

    /// The value `value` at `path`, named `what` in the message, is not what was `expected`:
    /// `{what} is {value}; expected {expected}`.
    pub fn value(
        path: &str,
        what: &str,
        value: impl fmt::Display,
        expected: impl Into<String>,
    ) -> Self {
        Self::new(path, format!("{what} is {value}"), expected)
    }

    /// The configuration as a whole is wrong.
    pub fn whole(got: impl Into<String>, expected: impl Into<String>) -> Self {
        Self::new("", got, expected)
    }

    /// The message: `{got}; expected {expected}` (or `got` alone when nothing is expected).
    pub fn message(&self) -> String {
        if self.expected.is_empty() {
            self.got.clone()
        } else {
            format!("{}; expected {}", self.got, self.expected)
        }
    }

    /// The same error seen from the value holding this one at `outer` (`over` + `lambda` is
    /// `over.lambda`; an index such as `[0]` joins without a dot).
    pub fn inside(mut self, outer: &str) -> Self {
        self.path = match (outer.is_empty(), self.path.is_empty()) {
            (true, _) => self.path,
            (false, true) => outer.to_string(),
            (false, false) if self.path.starts_with('[') => format!("{outer}{}", self.path),
            (false, false) => format!("{outer}.{}", self.path),
        };
        self
    }

    /// The same error with `prefix: ` before what was found (the name of the configured
    /// protocol, algorithm or model).
    pub fn prefixed(mut self, prefix: &str) -> Self {
        self.got = format!("{prefix}: {}", self.got);
        self
    }

    /// Checks that `field`'s value `v` is a finite number > 0 (seconds).
    pub fn positive_seconds(field: &str, v: f64) -> Result<(), Self> {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(Self::value(
                field,
                field,
                v,
                "a finite number > 0 (seconds)",
            ))
        }
    }
}

/// How a protocol's messages stand to rounds, for a model checker's round bound
/// ([`Microprotocol::ROUNDS`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rounds {
    /// Its messages belong to no round.
    None,
    /// It runs numbered rounds without end (a rotating coordinator moves on until a decision
    /// arrives): [`Microprotocol::round`] gives each message's round, and a model checker
    /// explores a stack holding it only up to a last round (`nekosim check --rounds`), which
    /// keeps its state space finite.
    Numbered,
    /// Its messages are headers around payloads of other layers (links): each belongs to the
    /// round of the payload it carries, which [`Microprotocol::round`] hands over as
    /// [`Round::Carries`].
    Carried,
}

/// The round one message belongs to ([`Microprotocol::round`]).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Round {
    /// None (a decision, an acknowledgement).
    None,
    /// Round `r`.
    At(u64),
    /// The round of this payload of another layer, which the message carries.
    Carries(Payload),
}

/// A microprotocol: one layer of a process's stack.
///
/// Adding one is one file with a type implementing this trait plus one registry line,
/// `registry.protocol::<MyProtocol>("MyProtocol")` (docs/extending.md walks through it).
pub trait Microprotocol: Clone + Debug + Eq + Hash + Send + Sync + 'static {
    /// The messages this layer exchanges with the same layer of other processes.
    type Msg: Message;
    /// The timers this layer sets (`()` for a single timer).
    type Timer: Message;
    /// The configuration a scenario gives: `protocol: Name(field: value, ...)` is
    /// deserialized into it by serde (derive with `#[serde(deny_unknown_fields)]`).
    type Config: DeserializeOwned;

    /// Neko's name of the protocol (logs).
    const NAME: &'static str;

    /// What the protocol provides and needs, for the stack's wiring checks.
    fn shape(config: &Self::Config) -> Shape;

    /// A fresh instance, or why the configuration is refused.
    fn new(config: Self::Config) -> Result<Self, FieldError>;

    /// The process starts.
    fn on_start(&mut self, _ctx: &Ctx, _out: &mut Out<Self>) {}

    /// A request from the layer (or application) `from` above, or from a layer using this
    /// one.
    fn on_request(&mut self, _ctx: &Ctx, _from: LayerIx, _req: Request, _out: &mut Out<Self>) {}

    /// One of this layer's own messages, sent by process `from`, arrived through the layer
    /// below.
    fn on_message(&mut self, _ctx: &Ctx, _from: Pid, _msg: Self::Msg, _out: &mut Out<Self>) {}

    /// Any other indication from the layer below (`from` is [`crate::NET`] for the network)
    /// or from a layer this one uses.
    fn on_indication(
        &mut self,
        _ctx: &Ctx,
        _from: LayerIx,
        _ind: Indication,
        _out: &mut Out<Self>,
    ) {
    }

    /// One of this layer's timers fired.
    fn on_timer(&mut self, _ctx: &Ctx, _timer: Self::Timer, _out: &mut Out<Self>) {}

    /// The readable form of a message in logs, traces, recordings and counterexamples; its
    /// first word is the message's type. Payloads inside print as the messages they encode.
    fn render(msg: &Self::Msg, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        Debug::fmt(msg, f)
    }

    /// Symmetry ([`crate::symmetry`]): this instance with every process id in its state
    /// renamed by `r`. A protocol that treats all processes alike implements it (and
    /// [`Microprotocol::renamed_msg`]) so a model checker may explore one state of each class
    /// equal up to renaming; the default, `None`, says the protocol is not symmetric (a fixed
    /// sequencer, a rotating coordinator, a tie-break by id).
    fn renamed(&self, _r: &Rename) -> Option<Self> {
        None
    }

    /// Symmetry: `msg` with every process id renamed by `r` (payloads inside by
    /// [`Rename::payload`]); `None` (the default) if the protocol is not symmetric.
    fn renamed_msg(_msg: &Self::Msg, _r: &Rename) -> Option<Self::Msg> {
        None
    }

    /// Symmetry: `timer` with every process id renamed; by default the timer itself (timers
    /// that name no process).
    fn renamed_timer(timer: &Self::Timer, _r: &Rename) -> Option<Self::Timer> {
        Some(timer.clone())
    }

    /// Rounds: how this protocol's messages stand to rounds ([`Rounds`]), for a model
    /// checker's round bound; the default, [`Rounds::None`], leaves its messages unbounded.
    const ROUNDS: Rounds = Rounds::None;

    /// Rounds: the round `msg` belongs to, read only when [`Microprotocol::ROUNDS`] is
    /// [`Rounds::Numbered`] or [`Rounds::Carried`].
    fn round(_msg: &Self::Msg) -> Round {
        Round::None
    }

    /// Spent messages: whether `msg` from `from` can no longer change this layer. Delivering
    /// it now, or in any state this layer reaches later, leaves the layer as it is and makes
    /// it do nothing. A model checker then forgets the message instead of keeping it in flight
    /// for ever, so states that differ only by such messages become one. The default, `false`,
    /// keeps every message; a protocol that says `true` where a delivery would still act gets
    /// wrong verdicts, so the answer must hold for every later state too (a set that only
    /// grows, a round already left).
    fn spent(&self, _ctx: &Ctx, _from: Pid, _msg: &Self::Msg) -> bool {
        false
    }

    /// Early arrivals: whether this layer, sitting on the network, passes up what each
    /// process sends it in the order that process sent it, and does nothing with a message
    /// that arrives before an earlier one from its sender but hold it: no message, upcall,
    /// timer or property reads it, until the earlier ones have arrived and it goes up as if
    /// it had arrived right after them. Every message the layer receives must be one it
    /// numbered. A model checker may then deliver each link's messages in send order only
    /// (an early arrival commutes with every step but the arrival it waits for), which a
    /// network that reorders but never loses can always do. The default, `false`, makes no
    /// such claim; a protocol that claims it falsely (one that acts on an early arrival, or
    /// asks for a retransmission) gets wrong verdicts.
    const HOLDS_EARLY: bool = false;

    /// Failure detectors: the processes this layer suspects now, or `None` (the default) if
    /// it is no failure detector. A model checker's liveness graph assumes eventual accuracy
    /// of the detectors a checked stack uses (from some point on, no live process suspects a
    /// live one) and reads it here, so a user's detector is assumed accurate as the built-in
    /// ones are.
    fn suspicions(&self) -> Option<Vec<Pid>> {
        None
    }
}

/// Collects a handler's effects, encoding the protocol's own messages and timers.
#[derive(Debug)]
pub struct Out<P: ?Sized> {
    ix: LayerIx,
    effects: Vec<Effect>,
    _p: PhantomData<fn() -> Box<P>>,
}

impl<P: Microprotocol> Out<P> {
    /// An empty collection for the layer at index `ix`.
    pub fn new(ix: LayerIx) -> Self {
        Self {
            ix,
            effects: Vec::new(),
            _p: PhantomData,
        }
    }

    /// The effects collected so far.
    pub fn effects(&self) -> &[Effect] {
        &self.effects
    }

    /// The effects, consumed.
    pub fn into_effects(self) -> Vec<Effect> {
        self.effects
    }

    /// This layer's index in its stack.
    pub fn layer(&self) -> LayerIx {
        self.ix
    }

    /// Encodes one of this layer's messages (to broadcast or propose it, or to keep it).
    pub fn encode(&self, msg: &P::Msg) -> Payload {
        Payload::encode(self.ix, msg)
    }

    /// Decodes one of this layer's messages from a payload (a decided value it proposed, a
    /// broadcast it made); `None` if the payload is another layer's.
    pub fn decode(&self, p: &Payload) -> Option<P::Msg> {
        (p.layer() == self.ix).then(|| p.decode().ok()).flatten()
    }

    /// Sends `msg` to the same layer of the processes `to`, through the layer below (nothing
    /// when `to` is empty).
    pub fn send(&mut self, to: Vec<Pid>, msg: P::Msg) {
        if !to.is_empty() {
            let msg = self.encode(&msg);
            self.effects.push(Effect::Down(Request::Send { to, msg }));
        }
    }

    /// A request to the layer below.
    pub fn down(&mut self, req: Request) {
        self.effects.push(Effect::Down(req));
    }

    /// A request to the `slot`-th layer this layer uses.
    pub fn use_layer(&mut self, slot: u8, req: Request) {
        self.effects.push(Effect::Use { slot, req });
    }

    /// An indication to one layer above (or the application, [`crate::APP`]).
    pub fn up_to(&mut self, to: LayerIx, ind: Indication) {
        self.effects.push(Effect::Up { to: Some(to), ind });
    }

    /// An indication to every layer above and using this one.
    pub fn up(&mut self, ind: Indication) {
        self.effects.push(Effect::Up { to: None, ind });
    }

    /// Sets (or moves) `timer` to fire after `after` seconds.
    pub fn set_timer(&mut self, timer: P::Timer, after: f64) {
        self.effects.push(Effect::SetTimer {
            timer: Payload::encode(self.ix, &timer),
            after: Real::new(after),
        });
    }

    /// Cancels `timer`.
    pub fn cancel_timer(&mut self, timer: P::Timer) {
        self.effects
            .push(Effect::CancelTimer(Payload::encode(self.ix, &timer)));
    }
}

/// Dispatches an untyped input to a protocol's typed handlers; returns its effects. A
/// payload that does not decode as the layer's own type (never produced by the stack itself;
/// possible from a real network) is dropped.
pub fn dispatch<P: Microprotocol>(
    p: &mut P,
    ctx: &Ctx,
    ix: LayerIx,
    input: Input,
) -> Result<Vec<Effect>, WireError> {
    let mut out = Out::<P>::new(ix);
    match input {
        Input::Start => p.on_start(ctx, &mut out),
        Input::Request { from, req } => p.on_request(ctx, from, req, &mut out),
        Input::Indication {
            ind: Indication::Deliver { from, msg },
            ..
        } if msg.layer() == ix => p.on_message(ctx, from, msg.decode()?, &mut out),
        Input::Indication { from, ind } => p.on_indication(ctx, from, ind, &mut out),
        Input::Timer(t) if t.layer() == ix => p.on_timer(ctx, t.decode()?, &mut out),
        Input::Timer(t) => {
            return Err(WireError(format!(
                "a timer of layer {} reached layer {ix}",
                t.layer()
            )))
        }
    }
    Ok(out.effects)
}

/// Object-safe view of a [`Microprotocol`], with clone, equality and hashing through `Any`.
trait DynProtocol: Debug + Send + Sync {
    fn name(&self) -> &'static str;
    fn handle(&mut self, ctx: &Ctx, ix: LayerIx, input: Input) -> Result<Vec<Effect>, WireError>;
    fn clone_box(&self) -> Box<dyn DynProtocol>;
    fn eq_dyn(&self, other: &dyn DynProtocol) -> bool;
    fn hash_dyn(&self, state: &mut dyn Hasher);
    fn as_any(&self) -> &dyn Any;
    fn renamed_dyn(&self, r: &Rename) -> Option<Box<dyn DynProtocol>>;
    fn rounds(&self) -> Rounds;
    fn round_dyn(&self, msg: &Payload) -> Option<Round>;
    fn spent_dyn(&self, ctx: &Ctx, from: Pid, msg: &Payload) -> bool;
    fn holds_early(&self) -> bool;
    fn suspicions(&self) -> Option<Vec<Pid>>;
}

impl<P: Microprotocol> DynProtocol for P {
    fn name(&self) -> &'static str {
        P::NAME
    }

    fn handle(&mut self, ctx: &Ctx, ix: LayerIx, input: Input) -> Result<Vec<Effect>, WireError> {
        dispatch(self, ctx, ix, input)
    }

    fn clone_box(&self) -> Box<dyn DynProtocol> {
        Box::new(self.clone())
    }

    fn eq_dyn(&self, other: &dyn DynProtocol) -> bool {
        other.as_any().downcast_ref::<P>() == Some(self)
    }

    fn hash_dyn(&self, mut state: &mut dyn Hasher) {
        self.hash(&mut state);
    }

    fn as_any(&self) -> &dyn Any {
        self
    }

    fn renamed_dyn(&self, r: &Rename) -> Option<Box<dyn DynProtocol>> {
        Some(Box::new(self.renamed(r)?))
    }

    fn rounds(&self) -> Rounds {
        P::ROUNDS
    }

    fn round_dyn(&self, msg: &Payload) -> Option<Round> {
        Some(P::round(&msg.decode().ok()?))
    }

    fn spent_dyn(&self, ctx: &Ctx, from: Pid, msg: &Payload) -> bool {
        msg.decode().is_ok_and(|m| self.spent(ctx, from, &m))
    }

    fn holds_early(&self) -> bool {
        P::HOLDS_EARLY
    }

    fn suspicions(&self) -> Option<Vec<Pid>> {
        Microprotocol::suspicions(self)
    }
}

/// An instance of any protocol, as a stack holds it (value semantics: `Clone + Eq + Hash`,
/// so stacks can be model-checked).
#[derive(Debug)]
pub struct Layer(Box<dyn DynProtocol>);

impl Layer {
    /// Wraps a protocol instance.
    pub fn new<P: Microprotocol>(protocol: P) -> Self {
        Self(Box::new(protocol))
    }

    /// Runs the handler for `input`, this layer being at index `ix`.
    pub fn handle(
        &mut self,
        ctx: &Ctx,
        ix: LayerIx,
        input: Input,
    ) -> Result<Vec<Effect>, WireError> {
        self.0.handle(ctx, ix, input)
    }

    /// The protocol instance if it is a `P`.
    pub fn downcast_ref<P: Microprotocol>(&self) -> Option<&P> {
        self.0.as_any().downcast_ref()
    }

    /// Neko's name of the protocol.
    pub fn name(&self) -> &'static str {
        self.0.name()
    }

    /// This instance with its process ids renamed ([`Microprotocol::renamed`]), or `None`
    /// if its protocol is not symmetric.
    pub fn renamed(&self, r: &Rename) -> Option<Self> {
        self.0.renamed_dyn(r).map(Self)
    }

    /// How its protocol's messages stand to rounds ([`Microprotocol::ROUNDS`]).
    pub fn rounds(&self) -> Rounds {
        self.0.rounds()
    }

    /// The round of `msg`, one of this layer's messages ([`Microprotocol::round`]); `None`
    /// if it does not decode as one.
    pub fn round(&self, msg: &Payload) -> Option<Round> {
        self.0.round_dyn(msg)
    }

    /// Whether `msg` from `from`, one of this layer's messages, is spent here
    /// ([`Microprotocol::spent`]); `false` if it does not decode as one.
    pub fn spent(&self, ctx: &Ctx, from: Pid, msg: &Payload) -> bool {
        self.0.spent_dyn(ctx, from, msg)
    }

    /// Whether its protocol holds early arrivals back ([`Microprotocol::HOLDS_EARLY`]).
    pub fn holds_early(&self) -> bool {
        self.0.holds_early()
    }

    /// Whom its failure detector suspects now ([`Microprotocol::suspicions`]); `None` if it
    /// is no failure detector.
    pub fn suspicions(&self) -> Option<Vec<Pid>> {
        self.0.suspicions()
    }
}

impl Clone for Layer {
    fn clone(&self) -> Self {
        Self(self.0.clone_box())
    }
}

impl PartialEq for Layer {
    fn eq(&self, other: &Self) -> bool {
        self.0.eq_dyn(other.0.as_ref())
    }
}

impl Eq for Layer {}

impl Hash for Layer {
    fn hash<H: Hasher>(&self, state: &mut H) {
        self.0.hash_dyn(state)
    }
}

#[cfg(test)]
mod tests {
    use super::FieldError;

    #[test]
    fn a_field_error_says_where_what_was_found_and_what_is_expected() {
        let e = FieldError::value("lambda", "lambda", -2.0, "a finite number >= 0");
        assert_eq!(
            (e.path.as_str(), e.got.as_str(), e.expected.as_str()),
            ("lambda", "lambda is -2", "a finite number >= 0")
        );
        assert_eq!(e.to_string(), "lambda is -2; expected a finite number >= 0");
        // Seen from the model holding it, under its name.
        let outer = e.clone().prefixed("RandomDelay").inside("over");
        assert_eq!(outer.path, "over.lambda");
        assert_eq!(
            outer.to_string(),
            "RandomDelay: lambda is -2; expected a finite number >= 0"
        );
        assert_eq!(e.clone().inside("steps").inside("").path, "steps.lambda");
        assert_eq!(
            FieldError::new("[0]", "wait is -1", "")
                .inside("steps")
                .path,
            "steps[0]"
        );
        assert_eq!(FieldError::whole("no layer", "").inside("net").path, "net");
        assert_eq!(FieldError::whole("no layer", "").to_string(), "no layer");
    }
}
