//! Protocols by name (seed 3.5, 6.2): Neko composed protocol stacks in Java initializer code;
//! here a scenario names each layer's protocol with its configuration,
//! `protocol: Retransmit(period: 0.5)`, and a [`Protocols`] registry maps the name to the
//! protocol type. Built-in protocols are registered exactly as a user's are
//! ([`Protocols::with_builtins`], [`Protocols::protocol`]).

use std::collections::BTreeMap;
use std::fmt;
use std::sync::Arc;

use serde::de::DeserializeOwned;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::payload::{decode_bytes, Codec, WireError};
use crate::protocol::{FieldError, Layer, Microprotocol};
use crate::service::Shape;
use crate::stack::Stack;

/// A protocol (or algorithm) and its configuration as a scenario writes it, kept as RON text
/// (`Fifo`, `Retransmit(period: 0.5)`, `RingGossip(fanout: 2)`); a registry reads it into the
/// protocol's own configuration type.
#[derive(Clone, PartialEq, Eq, Hash)]
pub struct Spec {
    text: String,
}

impl Spec {
    /// A spec from its RON text.
    pub fn new(text: &str) -> Self {
        Self {
            text: text.trim().to_string(),
        }
    }

    /// The RON text.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// The protocol's name: the text's leading identifier.
    pub fn name(&self) -> &str {
        let end = self
            .text
            .find(|c: char| !(c.is_alphanumeric() || c == '_'))
            .unwrap_or(self.text.len());
        &self.text[..end]
    }

    /// Reads the configuration part into the configuration type `C` (serde, from RON; a bare
    /// name reads as `()`). Errors say where in the spec's text and start with its name.
    pub fn read_config<C: DeserializeOwned>(&self) -> Result<C, SpecError> {
        read(self.config_text()).map_err(|e| self.locate(e))
    }

    /// Reads the configuration into `C` and builds with `build`; either error is placed in the
    /// spec and prefixed with its name (a refusal by `build` points at its field).
    pub fn configure<C: DeserializeOwned, T>(
        &self,
        build: impl FnOnce(C) -> Result<T, FieldError>,
    ) -> Result<T, SpecError> {
        build(self.read_config()?).map_err(|e| {
            self.locate(SpecError {
                at: None,
                field: (!e.path.is_empty()).then(|| e.path.clone()),
                message: e.message(),
            })
        })
    }

    /// An error about the configuration text, placed in the spec's text and prefixed with the
    /// name.
    pub fn locate(&self, mut e: SpecError) -> SpecError {
        e.message = format!("{}: {}", self.name(), e.message);
        // The configuration text starts right after the name on the spec's first line.
        if let Some((line, col)) = e.at {
            e.at = Some(if line == 1 {
                (1, col + self.name().len())
            } else {
                (line, col)
            });
        }
        e
    }

    /// The configuration part after the name, as RON (none for a bare name).
    pub fn config_text(&self) -> Option<&str> {
        let rest = &self.text[self.name().len()..];
        (!rest.trim().is_empty()).then_some(rest)
    }
}

impl fmt::Debug for Spec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

impl fmt::Display for Spec {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text)
    }
}

impl Serialize for Spec {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match ron::value::RawValue::from_ron(&self.text) {
            Ok(raw) => raw.serialize(s),
            Err(e) => Err(serde::ser::Error::custom(e)),
        }
    }
}

impl<'de> Deserialize<'de> for Spec {
    /// Takes the value's RON text as it is (read from a RON document only).
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let raw = Box::<ron::value::RawValue>::deserialize(d)?;
        let spec = Self::new(raw.get_ron());
        if spec.name().is_empty() {
            return Err(serde::de::Error::custom(format!(
                "expected a name and its configuration, like `Fifo` or `Retransmit(period: 1.0)`; got `{}`",
                spec.text
            )));
        }
        Ok(spec)
    }
}

/// A layer's protocol and its configuration (`protocol: Retransmit(period: 0.5)`).
pub type ProtocolSpec = Spec;

/// Why a spec cannot be built: where in the spec's text (1-based line and column, when known),
/// which configuration field (when known) and what is wrong.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct SpecError {
    pub at: Option<(usize, usize)>,
    pub field: Option<String>,
    pub message: String,
}

/// Reads a spec's configuration into a shape and a fresh instance.
type BuildFn = fn(&Spec) -> Result<(Shape, Layer), SpecError>;

/// A protocol type's registered functions.
#[derive(Clone, Copy)]
struct Entry {
    type_id: std::any::TypeId,
    /// Reads the configuration text and builds the shape and a fresh instance.
    build: BuildFn,
    codec: Codec,
}

/// Entries by the name a scenario uses for them: the shape every registry shares (protocols,
/// and the actors crate's algorithms, network models and sensors).
#[derive(Clone)]
pub struct Named<E> {
    /// What the entries are, for errors ("protocol", "network", ...).
    what: &'static str,
    entries: BTreeMap<String, E>,
}

impl<E> fmt::Debug for Named<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Named")
            .field("what", &self.what)
            .field("names", &self.entries.keys().collect::<Vec<_>>())
            .finish()
    }
}

impl<E> Named<E> {
    /// No entry yet; `what` names the kind of entry in errors.
    pub fn new(what: &'static str) -> Self {
        Self {
            what,
            entries: BTreeMap::new(),
        }
    }

    /// Registers `entry` under `name` (replacing an earlier one).
    pub fn insert(&mut self, name: &str, entry: E) {
        self.entries.insert(name.to_string(), entry);
    }

    /// Registered names, sorted.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.entries.keys().map(String::as_str)
    }

    /// The entry `name`, or an error listing the registered names.
    pub fn by_name(&self, name: &str) -> Result<&E, String> {
        self.entries.get(name).ok_or_else(|| {
            let (what, names) = (self.what, self.names().collect::<Vec<_>>());
            if names.is_empty() {
                format!("unknown {what} {name:?}; no {what} is registered")
            } else {
                format!(
                    "unknown {what} {name:?}; expected one of {}",
                    names.join(", ")
                )
            }
        })
    }

    /// The entry `spec` names; the error points at the name.
    pub fn get(&self, spec: &Spec) -> Result<&E, SpecError> {
        self.by_name(spec.name()).map_err(|message| SpecError {
            at: Some((1, 1)),
            field: None,
            message,
        })
    }

    /// Name and entry pairs, sorted by name.
    pub fn iter(&self) -> impl Iterator<Item = (&str, &E)> {
        self.entries.iter().map(|(n, e)| (n.as_str(), e))
    }
}

/// Protocols by the name scenarios use for them. A new (or default) registry holds the
/// built-in protocols; [`Protocols::empty`] holds none.
#[derive(Clone, Debug)]
pub struct Protocols {
    entries: Named<Entry>,
    properties: Vec<StackProperty>,
}

/// A property a protocol's author states over the protocol's state at every process
/// (crashed ones included), checked by `nekosim check` alongside the properties of the
/// service the stack provides, whenever the protocol is in the stack checked. Made by
/// [`Protocols::invariant`] and [`Protocols::reachable`].
#[derive(Clone)]
pub struct StackProperty {
    pub name: &'static str,
    /// `true`: it holds in every reachable state (an invariant); `false`: it holds in some
    /// reachable state (a witness that the configuration is reachable at all).
    pub always: bool,
    applies: fn(&Stack) -> bool,
    condition: Arc<Condition>,
}

/// A condition over every process's stack, in process order.
type Condition = dyn Fn(&[&Stack]) -> bool + Send + Sync;

impl StackProperty {
    /// Whether the protocol it is about is in `stack`.
    pub fn applies_to(&self, stack: &Stack) -> bool {
        (self.applies)(stack)
    }

    /// Whether it holds of the processes' stacks, in process order.
    pub fn holds(&self, stacks: &[&Stack]) -> bool {
        (self.condition)(stacks)
    }
}

impl std::fmt::Debug for StackProperty {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StackProperty")
            .field("name", &self.name)
            .field("always", &self.always)
            .finish_non_exhaustive()
    }
}

fn has_layer<P: Microprotocol>(stack: &Stack) -> bool {
    stack.layers.iter().any(|l| l.downcast_ref::<P>().is_some())
}

impl PartialEq for Protocols {
    /// Registries are equal when they register the same names to the same protocols.
    fn eq(&self, other: &Self) -> bool {
        self.entries.iter().count() == other.entries.iter().count()
            && self
                .entries
                .iter()
                .zip(other.entries.iter())
                .all(|((a, x), (b, y))| a == b && x.type_id == y.type_id)
    }
}

/// Reads a configuration text (none for a bare name: `()`) into a `C`; positions in the error
/// are in the text.
fn read<C: DeserializeOwned>(text: Option<&str>) -> Result<C, SpecError> {
    let opts =
        ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
    opts.from_str(text.unwrap_or("()")).map_err(|e| SpecError {
        // No text: the error is about the thing as named.
        at: text.map(|t| name_start(t, &e)),
        field: None,
        message: describe(&e.code),
    })
}

fn build_entry<P: Microprotocol>(spec: &Spec) -> Result<(Shape, Layer), SpecError> {
    spec.configure(|config: P::Config| {
        let shape = P::shape(&config);
        P::new(config).map(|p| (shape, Layer::new(p)))
    })
}

/// Where an error starts: ron reports an unknown field or a bad value just after it; point at
/// the name or the value itself.
fn name_start(text: &str, e: &ron::error::SpannedError) -> (usize, usize) {
    let (line, col) = (e.position.line, e.position.col);
    let Some(l) = text.lines().nth(line.saturating_sub(1)) else {
        return (line, col);
    };
    let chars: Vec<char> = l.chars().collect();
    let end = col.saturating_sub(1).min(chars.len());
    if let ron::Error::NoSuchStructField { found, .. } = &e.code {
        let before: String = chars[..end].iter().collect();
        let trimmed = before.trim_end_matches(|c: char| c.is_whitespace() || c == ':');
        if trimmed.ends_with(found.as_str()) {
            return (line, trimmed.chars().count() - found.chars().count() + 1);
        }
        return (line, col);
    }
    // A scalar that ends right before the position: its first character.
    let mut i = end;
    if i > 0 && chars[i - 1] == '"' {
        i -= 1;
        while i > 0 && chars[i - 1] != '"' {
            i -= 1;
        }
        i = i.saturating_sub(1);
    } else {
        while i > 0 && (chars[i - 1].is_alphanumeric() || "._+-".contains(chars[i - 1])) {
            i -= 1;
        }
    }
    (line, i + 1)
}

/// A ron error in the words of a scenario error.
fn describe(e: &ron::Error) -> String {
    match e {
        ron::Error::MissingStructField { field, .. } => format!("missing field `{field}`"),
        ron::Error::NoSuchStructField {
            expected, found, ..
        } => {
            if expected.is_empty() {
                format!("unknown field `{found}`; this protocol takes no configuration")
            } else {
                format!(
                    "unknown field `{found}`; expected one of {}",
                    expected
                        .iter()
                        .map(|f| format!("`{f}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            }
        }
        other => other.to_string(),
    }
}

fn render_entry<P: Microprotocol>(
    bytes: &[u8],
    f: &mut fmt::Formatter<'_>,
) -> Result<fmt::Result, WireError> {
    let msg: P::Msg = decode_bytes(bytes)?;
    Ok(P::render(&msg, f))
}

fn render_timer_entry<P: Microprotocol>(
    bytes: &[u8],
    f: &mut fmt::Formatter<'_>,
) -> Result<fmt::Result, WireError> {
    let t: P::Timer = decode_bytes(bytes)?;
    Ok(fmt::Debug::fmt(&t, f))
}

/// The codec of a protocol type (how hosts render its messages and timers).
pub fn codec_of<P: Microprotocol>(name: &'static str) -> Codec {
    Codec {
        protocol: name,
        render: render_entry::<P>,
        render_timer: render_timer_entry::<P>,
        rename: crate::symmetry::rename_msg_entry::<P>,
        rename_timer: crate::symmetry::rename_timer_entry::<P>,
    }
}

/// `name` as a `&'static str`: each distinct name is allocated once per process.
pub fn intern(name: &str) -> &'static str {
    static NAMES: std::sync::Mutex<std::collections::BTreeSet<&'static str>> =
        std::sync::Mutex::new(std::collections::BTreeSet::new());
    let mut names = NAMES.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(n) = names.get(name) {
        return n;
    }
    let n: &'static str = Box::leak(name.to_string().into_boxed_str());
    names.insert(n);
    n
}

impl Protocols {
    /// A registry without any protocol.
    pub fn empty() -> Self {
        Self {
            entries: Named::new("protocol"),
            properties: Vec::new(),
        }
    }

    /// Registers the protocol `P` under `name` (replacing an earlier registration).
    pub fn protocol<P: Microprotocol>(&mut self, name: &str) -> &mut Self {
        self.entries.insert(
            name,
            Entry {
                type_id: std::any::TypeId::of::<P>(),
                build: build_entry::<P>,
                codec: codec_of::<P>(intern(name)),
            },
        );
        self
    }

    /// Registered names, sorted.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.entries.names()
    }

    /// States an invariant of protocol `P`: `holds` of `P`'s state at every process (in
    /// process order, crashed ones included) in every reachable state of a check whose stack
    /// runs `P`.
    pub fn invariant<P: Microprotocol>(
        &mut self,
        name: &str,
        holds: impl Fn(&[&P]) -> bool + Send + Sync + 'static,
    ) -> &mut Self {
        self.stack_property::<P>(name, true, holds)
    }

    /// States a reachability claim of protocol `P`: some reachable state satisfies `holds`;
    /// the check shows a path to one as a witness.
    pub fn reachable<P: Microprotocol>(
        &mut self,
        name: &str,
        holds: impl Fn(&[&P]) -> bool + Send + Sync + 'static,
    ) -> &mut Self {
        self.stack_property::<P>(name, false, holds)
    }

    fn stack_property<P: Microprotocol>(
        &mut self,
        name: &str,
        always: bool,
        holds: impl Fn(&[&P]) -> bool + Send + Sync + 'static,
    ) -> &mut Self {
        let condition = move |stacks: &[&Stack]| {
            let states: Vec<&P> = stacks
                .iter()
                .filter_map(|s| s.layers.iter().find_map(|l| l.downcast_ref::<P>()))
                .collect();
            holds(&states)
        };
        self.properties.push(StackProperty {
            name: intern(name),
            always,
            applies: has_layer::<P>,
            condition: Arc::new(condition),
        });
        self
    }

    /// The properties stated with [`Protocols::invariant`] and [`Protocols::reachable`].
    pub fn properties(&self) -> &[StackProperty] {
        &self.properties
    }

    fn entry(&self, spec: &ProtocolSpec) -> Result<&Entry, SpecError> {
        self.entries.get(spec)
    }

    /// Reads `spec`'s configuration and builds what the protocol provides and needs and a
    /// fresh instance. Positions in the error are in `spec`'s text.
    pub fn build(&self, spec: &ProtocolSpec) -> Result<(Shape, Layer), SpecError> {
        (self.entry(spec)?.build)(spec)
    }

    /// The codec of `spec`'s protocol.
    pub fn codec(&self, spec: &ProtocolSpec) -> Result<Codec, SpecError> {
        self.entry(spec).map(|e| e.codec)
    }
}
