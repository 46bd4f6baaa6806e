//! User-defined microprotocols (seed 3.5, 6.2): a protocol written in Rust against
//! [`Microprotocol`] and registered by name, so scenario files can stack it like a built-in:
//! `Layer(id: "gossip", protocol: Custom(name: "Gossip", params: {"fanout": 2.0}), below: "net")`.
//!
//! Neko composed user protocols in Java initializer code; here a [`Protocols`] registry maps a
//! name to the service the protocol provides, the services it needs, and a factory from the
//! scenario's parameters. A registered instance is hosted exactly like a built-in one (one actor
//! per robot in the simulator, one step of a stateright actor in a model) because
//! [`CustomLayer`] keeps the `Clone + Eq + Hash` of the protocol behind a trait object.

use std::any::Any;
use std::collections::BTreeMap;
use std::fmt;
use std::hash::{Hash, Hasher};
use std::sync::Arc;

use crate::protocol::Microprotocol;
use crate::service::{Ctx, Input, Out};
use crate::stack::Service;

/// Object-safe view of a [`Microprotocol`], with clone, equality and hashing through `Any`.
pub trait DynProtocol: fmt::Debug + Send + Sync {
    /// Neko's name of the protocol.
    fn name(&self) -> &'static str;
    /// Dispatches an input (see [`Microprotocol::handle`]).
    fn handle(&mut self, ctx: &Ctx, input: Input, out: &mut Out);
    fn clone_box(&self) -> Box<dyn DynProtocol>;
    fn eq_dyn(&self, other: &dyn DynProtocol) -> bool;
    fn hash_dyn(&self, state: &mut dyn Hasher);
    fn as_any(&self) -> &dyn Any;
}

impl<P: Microprotocol> DynProtocol for P {
    fn name(&self) -> &'static str {
        Microprotocol::name(self)
    }

    fn handle(&mut self, ctx: &Ctx, input: Input, out: &mut Out) {
        Microprotocol::handle(self, ctx, input, out)
    }

    fn clone_box(&self) -> Box<dyn DynProtocol> {
        Box::new(self.clone())
    }

    fn eq_dyn(&self, other: &dyn DynProtocol) -> bool {
        other.as_any().downcast_ref::<P>() == Some(self)
    }

    fn hash_dyn(&self, mut state: &mut dyn Hasher) {
        std::any::TypeId::of::<P>().hash(&mut state);
        self.hash(&mut state);
    }

    fn as_any(&self) -> &dyn Any {
        self
    }
}

/// An instance of a registered protocol.
#[derive(Debug)]
pub struct CustomLayer(Box<dyn DynProtocol>);

impl CustomLayer {
    /// Wraps a protocol instance.
    pub fn new<P: Microprotocol>(protocol: P) -> Self {
        Self(Box::new(protocol))
    }

    /// The protocol, for handlers.
    pub fn protocol_mut(&mut self) -> &mut dyn DynProtocol {
        self.0.as_mut()
    }

    /// The protocol instance if it is a `P`.
    pub fn downcast_ref<P: Microprotocol>(&self) -> Option<&P> {
        self.0.as_any().downcast_ref()
    }

    /// Neko's name of the protocol.
    pub fn name(&self) -> &'static str {
        self.0.name()
    }
}

impl Clone for CustomLayer {
    fn clone(&self) -> Self {
        Self(self.0.clone_box())
    }
}

impl PartialEq for CustomLayer {
    fn eq(&self, other: &Self) -> bool {
        self.0.eq_dyn(other.0.as_ref())
    }
}

impl Eq for CustomLayer {}

impl Hash for CustomLayer {
    fn hash<H: Hasher>(&self, state: &mut H) {
        self.0.hash_dyn(state)
    }
}

/// A protocol's parameters as a scenario gives them.
pub type Params = BTreeMap<String, f64>;

/// Builds an instance from its parameters; `Err` says what is wrong with them.
pub type ProtocolFactory = Arc<dyn Fn(&Params) -> Result<CustomLayer, String> + Send + Sync>;

/// What a protocol provides and needs, as checked by [`crate::Wiring`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Shape {
    /// Service to the layers above.
    pub provides: Service,
    /// Service needed from the layer below.
    pub needs_below: Service,
    /// Services needed from used layers, in `uses` order.
    pub needs_uses: Vec<Service>,
}

#[derive(Clone)]
struct Entry {
    shape: Shape,
    factory: ProtocolFactory,
}

/// User protocols by name, for `Custom(name: ..)` in a scenario's stack.
#[derive(Clone, Default)]
pub struct Protocols {
    entries: BTreeMap<String, Entry>,
}

impl fmt::Debug for Protocols {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Protocols")
            .field("names", &self.entries.keys().collect::<Vec<_>>())
            .finish()
    }
}

impl PartialEq for Protocols {
    /// Registries are equal when they register the same names with the same shapes
    /// (factories are code and cannot be compared).
    fn eq(&self, other: &Self) -> bool {
        self.entries.len() == other.entries.len()
            && self
                .entries
                .iter()
                .zip(&other.entries)
                .all(|((a, x), (b, y))| a == b && x.shape == y.shape)
    }
}

impl Protocols {
    /// An empty registry (the built-in protocols need no registration).
    pub fn new() -> Self {
        Self::default()
    }

    /// Registers the protocol `name`: what it provides and needs, and how to build it.
    pub fn register<P: Microprotocol>(
        &mut self,
        name: &str,
        shape: Shape,
        factory: impl Fn(&Params) -> Result<P, String> + Send + Sync + 'static,
    ) -> &mut Self {
        let factory: ProtocolFactory = Arc::new(move |p| factory(p).map(CustomLayer::new));
        self.entries
            .insert(name.to_string(), Entry { shape, factory });
        self
    }

    /// The shape of `name`, or an error listing the registered names.
    pub fn shape(&self, name: &str) -> Result<&Shape, String> {
        self.entries.get(name).map(|e| &e.shape).ok_or_else(|| {
            let names: Vec<&str> = self.entries.keys().map(String::as_str).collect();
            if names.is_empty() {
                format!("unknown protocol {name:?}; no custom protocol is registered")
            } else {
                format!(
                    "unknown protocol {name:?}; registered: {}",
                    names.join(", ")
                )
            }
        })
    }

    /// A fresh instance of `name` with `params`.
    pub fn build(&self, name: &str, params: &Params) -> Result<CustomLayer, String> {
        self.shape(name)?;
        (self.entries[name].factory)(params).map_err(|e| format!("protocol {name:?}: {e}"))
    }

    /// Registered names, sorted.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.entries.keys().map(String::as_str)
    }
}
