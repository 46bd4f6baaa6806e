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

use crate::codec::Codec;
use crate::payload::{decode_bytes, WireError};
use crate::protocol::{FieldError, Layer, Microprotocol};
use crate::service::Shape;
use crate::stack::Stack;
use crate::symmetry::Rename;

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
    opts.from_str(text.unwrap_or("()")).map_err(|e| {
        let (at, message) = describe_ron(text.unwrap_or(""), &e);
        SpecError {
            // No text: the error is about the thing as named.
            at: text.map(|_| at),
            field: None,
            message,
        }
    })
}

fn build_entry<P: Microprotocol>(spec: &Spec) -> Result<(Shape, Layer), SpecError> {
    spec.configure(|config: P::Config| {
        let shape = P::shape(&config);
        P::new(config).map(|p| (shape, Layer::new(p)))
    })
}

/// A ron error in a reader's words, and where it is (1-based line and column in `text`): an
/// unknown field or variant at its name; a value of the wrong type at the value, as `field is
/// VALUE; expected WHAT`; a missing field at the structure that lacks it, saying what it
/// takes. Scenario, sweep and cluster files and every spec's configuration share it.
pub fn describe_ron(text: &str, e: &ron::error::SpannedError) -> ((usize, usize), String) {
    let chars = without_comments(text);
    let at = char_index(text, e.position.line, e.position.col);
    let pos = |i: usize| line_col(&chars, i);
    match &e.code {
        ron::Error::NoSuchStructField { found, .. }
        | ron::Error::NoSuchEnumVariant { found, .. } => {
            // ron reports a name just after it.
            let before: String = chars[..at].iter().collect();
            let trimmed = before.trim_end_matches(|c: char| c.is_whitespace() || c == ':');
            let start = trimmed
                .chars()
                .count()
                .saturating_sub(found.chars().count());
            let i = if trimmed.ends_with(found.as_str()) {
                start
            } else {
                at
            };
            (pos(i), describe(&e.code))
        }
        ron::Error::MissingStructField { field, outer } => {
            let start = struct_start(&chars, at).unwrap_or(at);
            let what = outer.as_deref().unwrap_or("the structure");
            (
                pos(start),
                format!(
                    "{what} is missing the field `{field}`; expected {}",
                    field_hint(outer.as_deref(), field)
                ),
            )
        }
        code => match expected_value(code, &chars, at) {
            Some((start, value, expected)) => {
                let message = match field_before(&chars, start) {
                    Some(f) => format!("{f} is {value}; expected {expected}"),
                    None => format!("found {value}; expected {expected}"),
                };
                (pos(start), message)
            }
            None => ((e.position.line, e.position.col), describe(code)),
        },
    }
}

/// The text's chars with comments blanked out (the same positions), so that no name or
/// bracket in a comment is taken for the document's.
fn without_comments(text: &str) -> Vec<char> {
    let mut chars: Vec<char> = text.chars().collect();
    let mut i = 0;
    while i < chars.len() {
        match (chars[i], chars.get(i + 1)) {
            ('"', _) => {
                i += 1;
                while i < chars.len() && chars[i] != '"' {
                    i += if chars[i] == '\\' { 2 } else { 1 };
                }
                i += 1;
            }
            ('/', Some('/')) => {
                while i < chars.len() && chars[i] != '\n' {
                    chars[i] = ' ';
                    i += 1;
                }
            }
            ('/', Some('*')) => {
                while i < chars.len() && !(chars[i] == '*' && chars.get(i + 1) == Some(&'/')) {
                    if chars[i] != '\n' {
                        chars[i] = ' ';
                    }
                    i += 1;
                }
                for c in chars.iter_mut().skip(i).take(2) {
                    *c = ' ';
                }
                i += 2;
            }
            _ => i += 1,
        }
    }
    chars
}

/// The char index of a 1-based line and column.
fn char_index(text: &str, line: usize, col: usize) -> usize {
    let mut i = 0;
    for (k, l) in text.split('\n').enumerate() {
        if k + 1 == line {
            return i + (col.saturating_sub(1)).min(l.chars().count());
        }
        i += l.chars().count() + 1;
    }
    text.chars().count()
}

/// The 1-based line and column of a char index.
fn line_col(chars: &[char], i: usize) -> (usize, usize) {
    let before = &chars[..i.min(chars.len())];
    let line = before.iter().filter(|&&c| c == '\n').count() + 1;
    let col = before.iter().rev().take_while(|&&c| c != '\n').count() + 1;
    (line, col)
}

/// Where the structure whose closing parenthesis is at or just before `at` starts: its name,
/// or its opening parenthesis.
fn struct_start(chars: &[char], at: usize) -> Option<usize> {
    let mut i = at.min(chars.len());
    while i > 0 && chars[i - 1].is_whitespace() {
        i -= 1;
    }
    // ron stops on the `)` or just after it.
    let close = if chars.get(i) == Some(&')') {
        i
    } else if i > 0 && chars[i - 1] == ')' {
        i - 1
    } else {
        return None;
    };
    let mut depth = 0;
    let mut k = close + 1;
    while k > 0 {
        k -= 1;
        match chars[k] {
            ')' | ']' => depth += 1,
            '(' | '[' => {
                depth -= 1;
                if depth == 0 {
                    let mut n = k;
                    while n > 0 && (chars[n - 1].is_alphanumeric() || chars[n - 1] == '_') {
                        n -= 1;
                    }
                    return Some(n);
                }
            }
            _ => {}
        }
    }
    None
}

/// What a field that is missing takes, for the fields whose value is not obvious.
fn field_hint(outer: Option<&str>, field: &str) -> String {
    match (outer, field) {
        (Some("Layer"), "below") => {
            "`below: \"net\"` or `below: \"ID\"`, the id of the layer this one sits on".into()
        }
        (Some("Layer"), "id") => "`id: \"ID\"`, the layer's name in the stack".into(),
        (Some("Layer"), "protocol") => "`protocol: Name(..)`, a registered protocol".into(),
        _ => format!("`{field}: VALUE`"),
    }
}

/// For an error about a value's type: where the value starts, its text, and what was expected.
fn expected_value(code: &ron::Error, chars: &[char], at: usize) -> Option<(usize, String, String)> {
    let start = value_start(chars, at);
    let value = value_text(chars, start);
    let expected: String = match code {
        ron::Error::ExpectedInteger | ron::Error::InvalidIntegerDigit { .. } => "an integer".into(),
        // ron reads the integer part of `1.5` and then wants a comma at the point.
        ron::Error::ExpectedComma
            if chars.get(at) == Some(&'.') && at > 0 && chars[at - 1].is_ascii_digit() =>
        {
            "an integer".into()
        }
        ron::Error::IntegerOutOfBounds if value.starts_with('-') => "an integer >= 0".into(),
        ron::Error::IntegerOutOfBounds => {
            "a smaller integer (the field's type cannot hold it)".into()
        }
        ron::Error::ExpectedFloat => "a number".into(),
        ron::Error::ExpectedBoolean => "`true` or `false`".into(),
        ron::Error::ExpectedString => "a string in double quotes".into(),
        ron::Error::ExpectedChar => "a character in single quotes".into(),
        ron::Error::ExpectedArray => "a list `[..]`".into(),
        ron::Error::ExpectedMap => "a map `{..}`".into(),
        ron::Error::ExpectedOption => "`Some(..)` or `None`".into(),
        ron::Error::ExpectedUnit => "`()`".into(),
        ron::Error::ExpectedStructLike => "a structure `(..)`".into(),
        ron::Error::ExpectedNamedStructLike(n) => format!("`{n}(..)`"),
        ron::Error::ExpectedDifferentStructName { expected, .. } => format!("`{expected}(..)`"),
        ron::Error::InvalidValueForType { expected, .. } => expected.clone(),
        ron::Error::ExpectedDifferentLength { expected, .. } => expected.clone(),
        _ => return None,
    };
    if value.is_empty() {
        return None;
    }
    Some((start, value, expected))
}

/// Where the value the error is about starts: ron reports a scalar at its start or just after
/// it.
fn value_start(chars: &[char], at: usize) -> usize {
    let at = at.min(chars.len());
    if at < chars.len()
        && !chars[at].is_whitespace()
        && !",)]".contains(chars[at])
        && (at == 0 || !is_scalar_char(chars[at - 1]) || chars[at] == '"')
    {
        return at;
    }
    let mut i = at;
    if i > 0 && chars[i - 1] == '"' {
        i -= 1;
        while i > 0 && chars[i - 1] != '"' {
            i -= 1;
        }
        return i.saturating_sub(1);
    }
    while i > 0 && is_scalar_char(chars[i - 1]) {
        i -= 1;
    }
    i
}

fn is_scalar_char(c: char) -> bool {
    c.is_alphanumeric() || "._+-".contains(c)
}

/// The value's text from `start`: a string, a bracketed value or a scalar (shortened when
/// long).
fn value_text(chars: &[char], start: usize) -> String {
    let Some(&first) = chars.get(start) else {
        return String::new();
    };
    let mut end = start + 1;
    if first == '"' {
        while end < chars.len() && chars[end] != '"' {
            end += if chars[end] == '\\' { 2 } else { 1 };
        }
        end = (end + 1).min(chars.len());
    } else if "([{".contains(first) || first.is_alphabetic() {
        // A name, and what its parentheses hold.
        end = start;
        while end < chars.len() && (chars[end].is_alphanumeric() || chars[end] == '_') {
            end += 1;
        }
        if end > start && chars.get(end) != Some(&'(') {
            return chars[start..end].iter().collect();
        }
        let mut depth = 0i32;
        while end < chars.len() {
            match chars[end] {
                '(' | '[' | '{' => depth += 1,
                ')' | ']' | '}' => {
                    depth -= 1;
                    if depth <= 0 {
                        end += usize::from(depth == 0);
                        break;
                    }
                }
                ',' if depth == 0 => break,
                _ => {}
            }
            end += 1;
        }
    } else {
        while end < chars.len() && is_scalar_char(chars[end]) {
            end += 1;
        }
    }
    let text: String = chars[start..end.min(chars.len())].iter().collect();
    let text = text.trim().to_string();
    if text.chars().count() > 40 {
        format!("{}..", text.chars().take(40).collect::<String>())
    } else {
        text
    }
}

/// The field whose value starts at `start`, or encloses it (`move_speed` for the second
/// number of `move_speed: (3.0, 1e999)`).
fn field_before(chars: &[char], start: usize) -> Option<String> {
    let mut depth = 0i32;
    let mut i = start;
    while i > 0 {
        i -= 1;
        match chars[i] {
            ')' | ']' | '}' => depth += 1,
            '(' | '[' | '{' => depth -= 1,
            ':' if depth <= 0 => {
                let mut j = i;
                while j > 0 && chars[j - 1].is_whitespace() {
                    j -= 1;
                }
                let end = j;
                while j > 0 && (chars[j - 1].is_alphanumeric() || chars[j - 1] == '_') {
                    j -= 1;
                }
                return (j < end).then(|| chars[j..end].iter().collect());
            }
            _ => {}
        }
        if depth < 0 && i > 0 && (chars[i - 1].is_alphanumeric() || chars[i - 1] == '_') {
            // The opening of a named structure or variant: its name is not a field.
            return None;
        }
    }
    None
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

/// Renames an encoded message of protocol `P` (a codec entry).
fn rename_msg_entry<P: Microprotocol>(bytes: &[u8], r: &Rename) -> Option<Vec<u8>> {
    let msg: P::Msg = decode_bytes(bytes).ok()?;
    postcard::to_allocvec(&P::renamed_msg(&msg, r)?).ok()
}

/// Renames an encoded timer of protocol `P` (a codec entry).
fn rename_timer_entry<P: Microprotocol>(bytes: &[u8], r: &Rename) -> Option<Vec<u8>> {
    let t: P::Timer = decode_bytes(bytes).ok()?;
    postcard::to_allocvec(&P::renamed_timer(&t, r)?).ok()
}

/// The codec of a protocol type (how hosts render its messages and timers).
pub fn codec_of<P: Microprotocol>(name: &'static str) -> Codec {
    Codec {
        protocol: name,
        render: render_entry::<P>,
        render_timer: render_timer_entry::<P>,
        rename: rename_msg_entry::<P>,
        rename_timer: rename_timer_entry::<P>,
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
