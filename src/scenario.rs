//! Scenario files: one experiment in RON (the seed's `robotsim.config`, 6.1, and its
//! initializer, 6.2). See docs/scenario.md for every field.
//!
//! Loading checks everything a run would trip on and reports the first problem as
//! `FILE:LINE:COL: what is wrong and what is expected`.

mod build;
mod comms;
pub mod edit;
mod locate;

use std::collections::HashMap;
use std::fmt;
use std::path::Path;
use std::sync::Arc;

use nekosim_actors::registry::{Algorithms, Configured};
use nekosim_actors::world::geometry::Point;
use nekosim_actors::world::network::{ConfiguredNetwork, Networks};
use nekosim_actors::world::obstacle::Shape;
use nekosim_actors::world::sensor::{SensorModel, Sensors};
use nekosim_actors::world::virtual_world::{RobotSpec, WorldConfig};
use nekosim_actors::{Algorithm, Comms};
use nekosim_protocols::codec::Codecs;
use nekosim_protocols::{FieldError, LayerSpec, Protocols, Spec};
use serde::Deserialize;

pub use build::{MAX_OBSTACLE_CELLS, MAX_ROBOTS, MIN_BYTES_PER_ROBOT};
pub use locate::{locate, spans, Pos, Spans};
pub use nekosim_actors::registry::{MAX_COORDINATE, MAX_SPEED, MIN_RADIUS};

/// The densest packing of equal discs in the plane (hexagonal), the share of an area discs can
/// cover at most.
pub const PACKING_DENSITY: f64 = std::f64::consts::PI / (2.0 * 1.732_050_807_568_877_2);

/// A scenario file's content.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// Name of the experiment; defaults to the file's stem.
    #[serde(default)]
    pub name: Option<String>,
    /// Seed of every random stream of the run.
    #[serde(default)]
    pub seed: u64,
    /// Simulated seconds; the run ends then or when no event is left. Default: no limit.
    #[serde(default = "infinity")]
    pub until: f64,
    pub world: World,
    pub robots: Vec<RobotEntry>,
    /// Static obstacles (seed 7.2): `Segment(from, to)`, `Rect(min, max)`, `Polygon([..])`,
    /// `Circle(center, radius)`; numbered by their place in the list.
    #[serde(default)]
    pub obstacles: Vec<Shape>,
    /// actix arbiters (threads) hosting robots and sensors; the results do not depend on it.
    #[serde(default = "one")]
    pub arbiters: usize,
    /// The simulated network; default `Reliable(delay: 1.0)`.
    #[serde(default)]
    pub network: Option<Spec>,
    /// Every robot's protocol stack (bottom to top, any order); the algorithm sits on top.
    #[serde(default)]
    pub stack: Vec<LayerSpec>,
    #[serde(default)]
    pub faults: Vec<FaultSpec>,
    /// Animation settings of recordings (seed 6.1); default 25 frames per simulated second.
    #[serde(default)]
    pub animation: Option<Animation>,
    /// Every robot's radius unless its entry gives one (seed 6.1 `robot.size`).
    #[serde(default)]
    pub robot_size: Option<f64>,
    /// Where `nekosim run` writes its outputs unless the command line says (seed 6.1
    /// `animation.logpath`); paths are relative to the working directory.
    #[serde(default)]
    pub outputs: Outputs,
    /// The Look-Compute-Move settings (docs/lcm.md): synchrony, movement, lights, frames,
    /// sensing and the adversary; defaults without it.
    #[serde(default)]
    pub lcm: Option<nekosim_actors::lcm::LcmSettings>,
    /// How `nekosim check` explores the stack; the command line overrides each field.
    #[serde(default)]
    pub check: Option<CheckSettings>,
}

/// How `nekosim check SCENARIO` explores the scenario's stack (docs/model-checking.md). A
/// field left out is derived from the scenario (processes, crashes, network) or takes the
/// command's default; an option on the command line wins over the field.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckSettings {
    /// The layer whose service is checked; default the stack's top layer.
    #[serde(default)]
    pub layer: Option<String>,
    /// Processes; default the scenario's robot count.
    #[serde(default)]
    pub processes: Option<u32>,
    /// Client requests (broadcasts or proposals); default 2.
    #[serde(default)]
    pub requests: Option<u32>,
    /// Processes that may crash; default the scenario's crash faults.
    #[serde(default)]
    pub crashes: Option<u32>,
    /// Network semantics; default derived from the scenario's network and faults.
    #[serde(default)]
    pub network: Option<CheckNetwork>,
    /// Protocol timer firings per process; default 1.
    #[serde(default)]
    pub timers: Option<u32>,
    /// Last Chandra-Toueg round explored; default 1.
    #[serde(default)]
    pub rounds: Option<u64>,
    /// Symmetry reduction (`nekosim check --symmetry`); default off.
    #[serde(default)]
    pub symmetry: Option<bool>,
}

/// The network semantics a check explores.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
pub enum CheckNetwork {
    Unordered,
    Ordered,
    Lossy,
}

/// Output paths a scenario sets for `nekosim run` (its `--log`, `--trace`, `--rrd` win).
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Outputs {
    #[serde(default)]
    pub log: Option<std::path::PathBuf>,
    #[serde(default)]
    pub trace: Option<std::path::PathBuf>,
    #[serde(default)]
    pub rrd: Option<std::path::PathBuf>,
}

fn default_framerate() -> f64 {
    crate::recording::DEFAULT_FRAMERATE
}

fn yes() -> bool {
    true
}

/// How recordings animate robots between events (the seed's animation settings, 6.1).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Animation {
    /// Frames per simulated second sampled from the motion formulas; 0: event instants only.
    #[serde(default = "default_framerate")]
    pub framerate: f64,
    /// `false`: no animation frames, the recording draws event instants only (seed
    /// `animation = false`).
    #[serde(default = "yes")]
    pub enabled: bool,
    /// The 2D view's extent `(width, height)` from the world's lower-left corner (an infinite
    /// world: centred on the origin), the seed's `animation.panel.width/height`; default the
    /// world's bounds.
    #[serde(default)]
    pub panel: Option<(f64, f64)>,
    /// Robot labels in recordings; default: shown up to 20 robots.
    #[serde(default)]
    pub labels: Option<bool>,
}

/// A fault to inject.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum FaultSpec {
    /// The robot stops moving, sensing and communicating at `at`.
    Crash { robot: u32, at: f64 },
    /// Messages between different groups are lost during `[from, to)`.
    Partition {
        groups: Vec<Vec<u32>>,
        from: f64,
        to: f64,
    },
}

fn infinity() -> f64 {
    f64::INFINITY
}

fn one() -> usize {
    1
}

/// The virtual world (seed 3.2, 6.1).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct World {
    pub size: Size,
    /// No robot-robot collisions (the boundary still holds robots in unless `walls: false`).
    #[serde(default)]
    pub ghost_mode: bool,
    /// Whether a bounded world's boundary stops robots like a wall; default true.
    /// `ghost_mode: true, walls: false` is the seed's ghost mode (no collisions at all).
    #[serde(default)]
    pub walls: Option<bool>,
    /// Which way MOVETO turns: `Shortest` (default) or `Anticlockwise` (the seed's, eq. 4.1).
    #[serde(default)]
    pub turn: nekosim_actors::world::motion::TurnRule,
    /// Lower-left corner of a bounded world; by default the world is centred on (0, 0).
    #[serde(default)]
    pub origin: Option<(f64, f64)>,
    /// Width of the spatial index's cells [units]; default four times the largest radius.
    #[serde(default)]
    pub cell_size: Option<f64>,
}

/// Extent of the world.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Size {
    Bounded { width: f64, height: f64 },
    Infinite,
}

/// One robot, or a group of alike robots.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum RobotEntry {
    Robot {
        id: u32,
        /// Default: the scenario's `robot_size`.
        #[serde(default)]
        radius: Option<f64>,
        at: (f64, f64),
        /// Heading [deg], anticlockwise from +x.
        #[serde(default)]
        angle: f64,
        #[serde(default = "idle")]
        algorithm: Spec,
    },
    Group {
        count: usize,
        /// Default: the scenario's `robot_size`.
        #[serde(default)]
        radius: Option<f64>,
        #[serde(default)]
        born: Born,
        /// Heading of every robot of the group [deg]; by default each draws one at random.
        #[serde(default)]
        angle: Option<f64>,
        #[serde(default = "idle")]
        algorithm: Spec,
    },
}

/// Where a group's robots are born (seed 6.1 `bornpoint`).
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Born {
    /// At random, inside the world (an 800×800 square centred on (0, 0) in an infinite world),
    /// clear of every other robot.
    #[default]
    Random,
    /// At these points, in order; robots beyond the list are born at random.
    Points(Vec<(f64, f64)>),
}

/// `Idle`, the algorithm of a robot that names none.
fn idle() -> Spec {
    Spec::new("Idle")
}

/// A problem with a scenario, located when possible.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub struct ScenarioError {
    pub file: String,
    pub pos: Option<Pos>,
    pub message: String,
}

impl fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.pos {
            Some(p) => write!(f, "{}:{}:{}: {}", self.file, p.line, p.col, self.message),
            None => write!(f, "{}: {}", self.file, self.message),
        }
    }
}

/// Algorithms and protocols by name: what a robot's `algorithm: Name(config)` and a layer's
/// `protocol: Name(config)` name, built-in and the user's alike.
#[derive(Debug)]
pub struct Registry {
    /// The algorithms robots run.
    pub algorithms: Algorithms,
    /// The network models a scenario's `network` names.
    pub networks: Networks,
    /// Sensors robots read beside the built-in ones (`robot.read::<S>("Name", ..)`).
    pub sensors: Sensors,
    /// The protocols for the `stack`.
    pub protocols: Protocols,
    /// The applications cluster files name (`app: BroadcastLoad(...)`, real-network mode).
    pub apps: crate::apps::Apps,
}

impl Default for Registry {
    /// [`Registry::with_builtins`].
    fn default() -> Self {
        Self::with_builtins()
    }
}

impl Registry {
    /// The built-in algorithms and protocols (the same as [`Registry::with_builtins`]).
    pub fn new() -> Self {
        Self::default()
    }

    /// The built-in algorithms ([`Algorithms::with_builtins`]) and protocols
    /// ([`Protocols::with_builtins`]).
    pub fn with_builtins() -> Self {
        Self {
            algorithms: Algorithms::with_builtins(),
            networks: Networks::with_builtins(),
            sensors: Sensors::new(),
            protocols: Protocols::with_builtins(),
            apps: crate::apps::Apps::with_builtins(),
        }
    }

    /// Registers the algorithm `A` under `name`, for `algorithm: Name(config)` in a scenario
    /// (see docs/extending.md).
    pub fn algorithm<A: Configured>(&mut self, name: &str) -> &mut Self {
        self.algorithms.algorithm::<A>(name);
        self
    }

    /// Registers the sensor `S` under `name`, for `robot.read::<S>("Name", ..)` and
    /// `robot.activate::<S>("Name", ..)` (see docs/extending.md).
    pub fn sensor<S: SensorModel>(&mut self, name: &str) -> &mut Self {
        self.sensors.sensor::<S>(name);
        self
    }

    /// Registers the network model `N` under `name`, for `network: Name(config)` in a scenario
    /// (see docs/extending.md).
    pub fn network<N: ConfiguredNetwork>(&mut self, name: &str) -> &mut Self {
        self.networks.network::<N>(name);
        self
    }

    /// Registers the microprotocol `P` under `name`, for `protocol: Name(config)` in a
    /// scenario's `stack` (see docs/extending.md).
    pub fn protocol<P: nekosim_protocols::Microprotocol>(&mut self, name: &str) -> &mut Self {
        self.protocols.protocol::<P>(name);
        self
    }

    /// Registers the application `A` under `name`, for `app: Name(config)` in a cluster file
    /// (docs/real-network.md).
    pub fn app<A: crate::apps::ConfiguredApp>(&mut self, name: &str) -> &mut Self {
        self.apps.app::<A>(name);
        self
    }
}

/// Command-line overrides of the file.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Overrides {
    pub seed: Option<u64>,
    pub until: Option<f64>,
}

/// A scenario ready to run.
#[derive(Debug)]
pub struct Built {
    pub name: String,
    pub seed: u64,
    pub until: f64,
    pub arbiters: usize,
    pub world: WorldConfig,
    pub robots: Vec<(RobotSpec, Box<dyn Algorithm>)>,
    pub comms: Comms,
    /// How the stack's messages render in the log, trace and recording.
    pub codecs: Arc<Codecs>,
    /// Sensors registered beside the built-in ones.
    pub sensors: Sensors,
    /// Animation frames per simulated second of recordings; 0: event instants only.
    pub framerate: f64,
    /// Robot labels in recordings (`animation.labels`; `None`: by the robot count).
    pub labels: Option<bool>,
    /// What the recording's 2D view frames (`animation.panel`, else a bounded world's box).
    pub view: Option<(Point, Point)>,
    /// The scenario's output paths (`outputs`).
    pub outputs: Outputs,
    /// Whether robots can exchange messages: the scenario names a network or a stack (what
    /// decides whether a recording plots messages).
    pub messages: bool,
    /// Whether a protocol can deliver to the algorithms: the scenario has a stack.
    pub deliveries: bool,
    /// What the run reports on (`lcm.predicates`).
    pub predicates: Vec<nekosim_actors::lcm::predicate::Predicate>,
}

impl Built {
    /// The engine's configuration of this run: the built world, robots, communication and
    /// sensors, records kept in the output when `record` (for a caller that reads them, as
    /// tests and replays do; a run that writes its outputs uses [`crate::runner::run`]).
    pub fn into_config(self, record: bool) -> nekosim_actors::SimConfig {
        nekosim_actors::SimConfig {
            seed: self.seed,
            until: self.until,
            world: self.world,
            robots: self.robots,
            arbiters: self.arbiters,
            record,
            observers: Default::default(),
            comms: self.comms,
            sensors: self.sensors,
        }
    }
}

/// The text of the `what` file (scenario, sweep, cluster) at `path`, and its name for errors.
pub fn read_file(path: &Path, what: &str) -> Result<(String, String), ScenarioError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| ScenarioError {
        file: file.clone(),
        pos: None,
        message: format!("cannot read the {what} file: {e}"),
    })?;
    Ok((file, text))
}

/// Reads RON `text` (named `file` in errors) into a `T`, with implicit `Some`; a syntax or
/// type error is reported at its FILE:LINE:COL (scenario, sweep and cluster files alike).
pub fn read_ron<T: serde::de::DeserializeOwned>(
    file: &str,
    text: &str,
) -> Result<T, ScenarioError> {
    let opts =
        ron::Options::default().with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
    opts.from_str(text).map_err(|e| {
        let ((line, col), mut message) = nekosim_protocols::registry::describe_ron(text, &e);
        if let ron::Error::NoSuchStructField { .. } | ron::Error::NoSuchEnumVariant { .. } = e.code
        {
            message.push_str(" (see docs/scenario.md for the accepted fields)");
        }
        ScenarioError {
            file: file.to_string(),
            pos: Some(Pos { line, col }),
            message,
        }
    })
}

/// A scenario file read and parsed, with the positions of its values.
#[derive(Clone, Debug)]
pub struct Source {
    pub file: String,
    pub scenario: Scenario,
    spans: HashMap<String, Pos>,
}

impl Source {
    /// Reads and parses a scenario file.
    pub fn load(path: &Path) -> Result<Self, ScenarioError> {
        let (file, text) = read_file(path, "scenario")?;
        Self::parse(&file, &text)
    }

    /// Parses scenario text; `file` names it in errors.
    pub fn parse(file: &str, text: &str) -> Result<Self, ScenarioError> {
        let scenario: Scenario = read_ron(file, text)?;
        Ok(Self {
            file: file.to_string(),
            scenario,
            spans: locate(text),
        })
    }

    /// A validation's error, placed at its path.
    fn err(&self, e: FieldError) -> ScenarioError {
        self.place(&e.path, e.message())
    }

    /// `message` at the value at `path`.
    pub fn place(&self, path: &str, message: impl Into<String>) -> ScenarioError {
        // Fall back to the closest enclosing value that has a position.
        let mut p = path.to_string();
        let pos = loop {
            if let Some(pos) = self.spans.get(&p) {
                break Some(*pos);
            }
            match p.rfind(['.', '[']) {
                Some(i) => p.truncate(i),
                None => break self.spans.get("").copied(),
            }
        };
        ScenarioError {
            file: self.file.clone(),
            pos,
            message: message.into(),
        }
    }
}
