//! The applications a cluster's nodes run (docs/real-network.md): what drives the stack in
//! real-network mode, as a robot algorithm drives it in simulation. A cluster file names one
//! with its configuration, `app: BroadcastLoad(layer: "abcast", count: 50, period: 0.02)`, and
//! an [`Apps`] registry reads the configuration into the application's own type (serde). The
//! built-in applications are registered exactly as a user's are ([`Apps::with_builtins`],
//! [`crate::scenario::Registry::app`]).
//!
//! An application is sans-IO like a microprotocol: it is told the start, the indications of
//! the stack's layers and its own timers, and answers by asking [`AppIo`] for requests
//! (broadcast, propose) and timers.

use std::fmt;

use nekosim_actors::registry::Setting;
use nekosim_protocols::app::app_payload;
use nekosim_protocols::registry::Named;
use nekosim_protocols::service::{Indication, Request};
use nekosim_protocols::{FieldError, Pid, Service, Spec, SpecError};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

/// What an application asks for.
#[derive(Clone, Debug, PartialEq)]
pub enum AppAction {
    /// A request to layer `layer` (`op` names it in the trace: `broadcast`, `propose`).
    Request {
        layer: String,
        op: &'static str,
        req: Request,
    },
    /// Call [`NodeApp::timer`] with `tag` after `seconds`.
    After { seconds: f64, tag: u64 },
}

/// The application's view of its node: who it is, and where its requests go.
#[derive(Debug)]
pub struct AppIo {
    pub me: Pid,
    pub n: u32,
    /// Seconds since the start.
    pub now: f64,
    actions: Vec<AppAction>,
}

impl AppIo {
    /// A view for node `me` of `n` at `now`.
    pub fn new(me: Pid, n: u32, now: f64) -> Self {
        Self {
            me,
            n,
            now,
            actions: Vec::new(),
        }
    }

    /// Broadcasts the application's own message through `layer` (broadcast layers).
    pub fn broadcast<M: Serialize>(&mut self, layer: &str, msg: &M) {
        self.actions.push(AppAction::Request {
            layer: layer.into(),
            op: "broadcast",
            req: Request::Broadcast {
                msg: app_payload(msg),
            },
        });
    }

    /// Proposes the application's own value to instance `k` of `layer` (consensus layers).
    pub fn propose<M: Serialize>(&mut self, layer: &str, k: u64, value: &M) {
        self.actions.push(AppAction::Request {
            layer: layer.into(),
            op: "propose",
            req: Request::Propose {
                k,
                value: app_payload(value),
            },
        });
    }

    /// Asks for [`NodeApp::timer`] with `tag` after `seconds` (real seconds).
    pub fn after(&mut self, seconds: f64, tag: u64) {
        self.actions.push(AppAction::After { seconds, tag });
    }

    /// What was asked for, in order.
    pub fn take(&mut self) -> Vec<AppAction> {
        std::mem::take(&mut self.actions)
    }
}

/// A node's application.
pub trait NodeApp: fmt::Debug + 'static {
    /// The node starts.
    fn start(&mut self, io: &mut AppIo);
    /// A layer the application hears indicates something (a delivery, a decision, a
    /// suspicion).
    fn indication(&mut self, _io: &mut AppIo, _layer: &str, _ind: &Indication) {}
    /// A timer asked for with [`AppIo::after`] fired.
    fn timer(&mut self, _io: &mut AppIo, _tag: u64) {}
    /// Whether the application is done: the node then stops (after a moment for its peers).
    fn done(&self) -> bool {
        false
    }
}

/// An application a cluster file can name: its configuration type and how it is built.
pub trait ConfiguredApp: NodeApp + Sized {
    /// What `app: Name(field: value, ...)` is read into (derive `Deserialize` with
    /// `#[serde(deny_unknown_fields)]`).
    type Config: DeserializeOwned;

    /// The application of node `me` of `n`, or why the configuration is refused (checked
    /// against the stack's layers in `setting`).
    fn configure(
        config: Self::Config,
        setting: &Setting,
        me: Pid,
        n: u32,
    ) -> Result<Self, FieldError>;
}

type BuildFn = fn(&Spec, &Setting, Pid, u32) -> Result<Box<dyn NodeApp>, SpecError>;

fn build_entry<A: ConfiguredApp>(
    spec: &Spec,
    setting: &Setting,
    me: Pid,
    n: u32,
) -> Result<Box<dyn NodeApp>, SpecError> {
    spec.configure(|c| A::configure(c, setting, me, n))
        .map(|a| Box::new(a) as Box<dyn NodeApp>)
}

/// Applications by the name cluster files use for them.
#[derive(Clone, Debug)]
pub struct Apps {
    entries: Named<BuildFn>,
}

impl Default for Apps {
    /// [`Apps::with_builtins`].
    fn default() -> Self {
        Self::with_builtins()
    }
}

impl Apps {
    /// A registry without any application.
    pub fn empty() -> Self {
        Self {
            entries: Named::new("application"),
        }
    }

    /// The built-in applications, under their names.
    pub fn with_builtins() -> Self {
        let mut r = Self::empty();
        r.app::<BroadcastLoad>("BroadcastLoad")
            .app::<Proposals>("Proposals");
        r
    }

    /// Registers the application `A` under `name`.
    pub fn app<A: ConfiguredApp>(&mut self, name: &str) -> &mut Self {
        self.entries.insert(name, build_entry::<A>);
        self
    }

    /// Reads `spec`'s configuration and builds node `me`'s application.
    pub fn build(
        &self,
        spec: &Spec,
        setting: &Setting,
        me: Pid,
        n: u32,
    ) -> Result<Box<dyn NodeApp>, SpecError> {
        (self.entries.get(spec)?)(spec, setting, me, n)
    }
}

/// `layer` must be a layer of the stack serving `service`.
fn layer_serving(setting: &Setting, layer: &str, service: Service) -> Result<(), FieldError> {
    match setting.layer(layer) {
        Some(s) if s.serves(service) => Ok(()),
        Some(s) => Err(FieldError::new(
            "layer",
            format!("layer {layer:?} provides {}", s.name),
            format!("a layer providing {}", service.name),
        )),
        None => Err(FieldError::new(
            "layer",
            format!("unknown layer {layer:?}"),
            format!(
                "a layer of the stack ({})",
                setting
                    .layers
                    .iter()
                    .map(|(id, _)| id.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )),
    }
}

/// Every node broadcasts `count` messages (`"pI.K"`) through `layer`, one every `period`
/// seconds from the start; done when it delivered every node's.
#[derive(Debug)]
pub struct BroadcastLoad {
    config: BroadcastLoadConfig,
    /// Deliveries on the layer, and those the whole cluster makes.
    delivered: u64,
    expected: u64,
}

/// `BroadcastLoad(layer: "abcast", count: 50, period: 0.02)`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BroadcastLoadConfig {
    pub layer: String,
    pub count: u32,
    pub period: f64,
}

impl ConfiguredApp for BroadcastLoad {
    type Config = BroadcastLoadConfig;

    fn configure(c: Self::Config, setting: &Setting, _: Pid, n: u32) -> Result<Self, FieldError> {
        layer_serving(setting, &c.layer, Service::BROADCAST)?;
        if !(c.period.is_finite() && c.period >= 0.0) {
            return Err(FieldError::new(
                "period",
                format!("period is {}", c.period),
                "a number of seconds >= 0",
            ));
        }
        Ok(Self {
            expected: u64::from(n) * u64::from(c.count),
            config: c,
            delivered: 0,
        })
    }
}

impl NodeApp for BroadcastLoad {
    fn start(&mut self, io: &mut AppIo) {
        for k in 0..self.config.count {
            io.after(f64::from(k) * self.config.period, u64::from(k));
        }
    }

    fn timer(&mut self, io: &mut AppIo, k: u64) {
        let msg = format!("p{}.{k}", io.me);
        io.broadcast(&self.config.layer, &msg);
    }

    fn indication(&mut self, _: &mut AppIo, layer: &str, ind: &Indication) {
        if layer == self.config.layer && matches!(ind, Indication::BDeliver { .. }) {
            self.delivered += 1;
        }
    }

    fn done(&self) -> bool {
        self.delivered >= self.expected
    }
}

/// Every node proposes `"pI"` to consensus instances `0..count` of `layer`; done when it
/// decided them all.
#[derive(Debug)]
pub struct Proposals {
    config: ProposalsConfig,
    decided: u64,
}

/// `Proposals(layer: "consensus", count: 5)`.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProposalsConfig {
    pub layer: String,
    pub count: u32,
}

impl ConfiguredApp for Proposals {
    type Config = ProposalsConfig;

    fn configure(c: Self::Config, setting: &Setting, _: Pid, _: u32) -> Result<Self, FieldError> {
        layer_serving(setting, &c.layer, Service::CONSENSUS)?;
        Ok(Self {
            config: c,
            decided: 0,
        })
    }
}

impl NodeApp for Proposals {
    fn start(&mut self, io: &mut AppIo) {
        let value = format!("p{}", io.me);
        for k in 0..self.config.count {
            io.propose(&self.config.layer, u64::from(k), &value);
        }
    }

    fn indication(&mut self, _: &mut AppIo, layer: &str, ind: &Indication) {
        if layer == self.config.layer && matches!(ind, Indication::Decide { .. }) {
            self.decided += 1;
        }
    }

    fn done(&self) -> bool {
        self.decided >= u64::from(self.config.count)
    }
}
