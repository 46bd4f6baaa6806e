//! Scenario files: one experiment in RON (the seed's `robotsim.config`, 6.1, and its
//! initializer, 6.2). See docs/scenario.md for every field.
//!
//! Loading checks everything a run would trip on and reports the first problem as
//! `FILE:LINE:COL: what is wrong and what is expected`.

pub mod edit;
mod locate;

use std::collections::HashMap;
use std::fmt;
use std::path::Path;
use std::sync::Arc;

use nekosim_actors::registry::{Algorithms, Configured, Setting};
use nekosim_actors::world::born::random_born_points_clear;
use nekosim_actors::world::geometry::Point;
use nekosim_actors::world::motion::Pose;
use nekosim_actors::world::network::{ConfiguredNetwork, Networks, Partition};
use nekosim_actors::world::obstacle::Shape;
use nekosim_actors::world::sensor::{SensorModel, Sensors};
#[cfg(debug_assertions)]
use nekosim_actors::world::virtual_world::VirtualWorld;
use nekosim_actors::world::virtual_world::{RobotSpec, WorldConfig, WorldSize};
use nekosim_actors::{Algorithm, Comms, Fault};
use nekosim_protocols::payload::Codecs;
use nekosim_protocols::{FieldError, LayerSpec, Protocols, Spec, SpecError, StackError, Wiring};
use rand::{Rng, SeedableRng};
use serde::Deserialize;

pub use locate::{locate, spans, Pos, Spans};

/// The largest world extent and coordinate a scenario may use [units]: f64 positions there
/// are still exact to about 1e-7 units.
pub const MAX_COORDINATE: f64 = 1e9;

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
        let message = describe_ron(&e.code);
        ScenarioError {
            file: file.to_string(),
            pos: Some(name_start(text, e.position.line, e.position.col, &message)),
            message,
        }
    })
}

/// A scenario file read and parsed, with the positions of its values.
#[derive(Debug)]
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

    fn finite(&self, path: &str, what: &str, v: f64) -> Result<f64, ScenarioError> {
        if v.is_finite() {
            Ok(v)
        } else {
            Err(self.err(FieldError::new(
                path,
                format!("{what} is {v}"),
                "a finite number",
            )))
        }
    }

    /// A robot entry's radius, or the scenario's `robot_size` (seed 6.1 `robot.size`).
    fn radius(&self, path: &str, radius: Option<f64>) -> Result<f64, ScenarioError> {
        radius.or(self.scenario.robot_size).ok_or_else(|| {
            self.err(FieldError::new(
                path,
                "no radius",
                "`radius: R` in the entry, or `robot_size: R` for every robot",
            ))
        })
    }

    /// `v` must be at most [`MAX_COORDINATE`] in size: beyond, f64 motion is no longer exact
    /// to a small fraction of a unit.
    fn within(&self, path: &str, what: &str, v: f64) -> Result<f64, ScenarioError> {
        if v.abs() <= MAX_COORDINATE {
            Ok(v)
        } else {
            Err(self.err(FieldError::new(
                path,
                format!("{what} is {v:e}"),
                format!("at most {MAX_COORDINATE:e} in size (beyond, positions lose the precision exact motion needs)"),
            )))
        }
    }

    fn positive(&self, path: &str, what: &str, v: f64) -> Result<f64, ScenarioError> {
        self.finite(path, what, v)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.err(FieldError::new(
                path,
                format!("{what} is {v}"),
                "a number > 0",
            )))
        }
    }

    /// A robot's algorithm, built by the registry; errors point into the spec at `path`.
    fn algorithm(
        &self,
        path: &str,
        spec: &Spec,
        setting: &Setting,
        registry: &Registry,
    ) -> Result<Box<dyn Algorithm>, ScenarioError> {
        registry
            .algorithms
            .build(spec, setting)
            .map_err(|e| self.spec_err(path, &e))
    }

    /// Checks the scenario and builds the robots, ids, born points and algorithms.
    pub fn build(&self, overrides: Overrides, registry: &Registry) -> Result<Built, ScenarioError> {
        let s = &self.scenario;
        let until = match overrides.until {
            Some(u) => u,
            None => s.until,
        };
        if until.is_nan() || until < 0.0 {
            return Err(self.err(FieldError::new(
                "until",
                format!("until is {until}"),
                "a time >= 0 in seconds",
            )));
        }
        if s.arbiters == 0 {
            return Err(self.err(FieldError::new("arbiters", "arbiters is 0", "at least 1")));
        }
        let seed = overrides.seed.unwrap_or(s.seed);
        let size = match s.world.size {
            Size::Infinite => WorldSize::Infinite,
            Size::Bounded { width, height } => {
                self.positive("world.size.width", "world width", width)?;
                self.positive("world.size.height", "world height", height)?;
                self.within("world.size.width", "world width", width)?;
                self.within("world.size.height", "world height", height)?;
                match s.world.origin {
                    Some((x, y)) => {
                        self.finite("world.origin[0]", "origin x", x)?;
                        self.finite("world.origin[1]", "origin y", y)?;
                        self.within("world.origin[0]", "origin x", x)?;
                        self.within("world.origin[1]", "origin y", y)?;
                        WorldSize::Bounded {
                            min: Point::new(x, y),
                            max: Point::new(x + width, y + height),
                        }
                    }
                    None => WorldSize::centred(width, height),
                }
            }
        };
        if let Some(c) = s.world.cell_size {
            self.positive("world.cell_size", "cell size", c)?;
        }
        if s.world.walls == Some(true) && size == WorldSize::Infinite {
            return Err(self.err(FieldError::new(
                "world.walls",
                "walls: true in an infinite world",
                "no `walls` (an infinite world has none)",
            )));
        }
        for (k, o) in s.obstacles.iter().enumerate() {
            if let Err(e) = o.check() {
                let path = match e.field.as_str() {
                    "" => format!("obstacles[{k}]"),
                    f if f.starts_with('[') => format!("obstacles[{k}][0]{f}"),
                    f => format!("obstacles[{k}].{f}"),
                };
                return Err(self.err(FieldError::new(
                    &path,
                    format!("obstacle {k}: {}", e.message),
                    e.expected,
                )));
            }
        }
        let world = WorldConfig {
            size,
            ghost_mode: s.world.ghost_mode,
            walls: s.world.walls.unwrap_or(true),
            turn: s.world.turn,
            cell_size: s.world.cell_size,
            obstacles: s.obstacles.clone().into(),
        };

        // Ids: explicit ones first, groups take the next free ids in order.
        let total: usize = s
            .robots
            .iter()
            .map(|r| match r {
                RobotEntry::Robot { .. } => 1,
                RobotEntry::Group { count, .. } => *count,
            })
            .sum();
        let mut taken = vec![None::<usize>; total];
        for (i, r) in s.robots.iter().enumerate() {
            if let RobotEntry::Robot { id, .. } = r {
                let path = format!("robots[{i}].id");
                let slot = taken.get_mut(*id as usize).ok_or_else(|| {
                    self.err(FieldError::new(
                        &path,
                        format!("robot id {id} is out of range"),
                        format!(
                            "an id in 0..={} (there are {total} robots)",
                            total.saturating_sub(1)
                        ),
                    ))
                })?;
                if let Some(first) = *slot {
                    return Err(self.err(FieldError::new(
                        &path,
                        format!("duplicate robot id {id} (also used by robots[{first}])"),
                        "unique ids",
                    )));
                }
                *slot = Some(i);
            }
        }

        // The stack first: algorithms are checked against it.
        let (comms, codecs, setting) = self.comms(total, registry)?;

        // Placement: explicit robots, then each group's listed points, then random points.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(0xB0B0);
        let mut placed: Vec<Option<RobotSpec>> = vec![None; total];
        let mut algorithms: Vec<Option<Box<dyn Algorithm>>> = (0..total).map(|_| None).collect();
        let check_spot = |placed: &[Option<RobotSpec>],
                          id: usize,
                          spec: &RobotSpec,
                          path: &str|
         -> Result<(), ScenarioError> {
            let (p, r) = (spec.pose.pos, spec.radius);
            if let WorldSize::Bounded { min, max } = size {
                if p.x < min.x + r || p.y < min.y + r || p.x > max.x - r || p.y > max.y - r {
                    return Err(self.err(FieldError::new(path, format!("robot {id} at ({}, {}) with radius {r} is not inside the world [{}, {}] x [{}, {}]", p.x, p.y, min.x, max.x, min.y, max.y), "a born point at least one radius inside")));
                }
            }
            if let Some(k) = s.obstacles.iter().position(|o| o.distance(p) < r) {
                return Err(self.err(FieldError::new(
                    path,
                    format!(
                        "robot {id} at ({}, {}) with radius {r} overlaps obstacle {k}",
                        p.x, p.y
                    ),
                    "a born point at least one radius away from every obstacle",
                )));
            }
            for (other, o) in placed.iter().enumerate() {
                if let Some(o) = o {
                    if (o.pose.pos - p).norm() < o.radius + r {
                        return Err(self.err(FieldError::new(
                            path,
                            format!(
                                "robot {id} at ({}, {}) overlaps robot {other} at ({}, {})",
                                p.x, p.y, o.pose.pos.x, o.pose.pos.y
                            ),
                            "born points at least the sum of the radii apart",
                        )));
                    }
                }
            }
            Ok(())
        };
        for (i, r) in s.robots.iter().enumerate() {
            if let RobotEntry::Robot {
                id,
                radius,
                at,
                angle,
                algorithm,
            } = r
            {
                let path = format!("robots[{i}]");
                let radius = &self.radius(&path, *radius)?;
                self.positive(&format!("{path}.radius"), "radius", *radius)?;
                self.finite(&format!("{path}.at[0]"), "x", at.0)?;
                self.finite(&format!("{path}.at[1]"), "y", at.1)?;
                self.within(&format!("{path}.at[0]"), "x", at.0)?;
                self.within(&format!("{path}.at[1]"), "y", at.1)?;
                self.within(&format!("{path}.radius"), "radius", *radius)?;
                self.finite(&format!("{path}.angle"), "angle", *angle)?;
                let spec = RobotSpec {
                    radius: *radius,
                    pose: Pose {
                        pos: Point::new(at.0, at.1),
                        angle: *angle,
                    },
                };
                check_spot(&placed, *id as usize, &spec, &format!("{path}.at"))?;
                placed[*id as usize] = Some(spec);
                algorithms[*id as usize] = Some(self.algorithm(
                    &format!("{path}.algorithm"),
                    algorithm,
                    &setting,
                    registry,
                )?);
            }
        }
        let mut free = (0..total).filter(|&k| taken[k].is_none());
        for (i, r) in s.robots.iter().enumerate() {
            if let RobotEntry::Group {
                count,
                radius,
                born,
                angle,
                algorithm,
            } = r
            {
                let path = format!("robots[{i}]");
                let radius = &self.radius(&path, *radius)?;
                self.positive(&format!("{path}.radius"), "radius", *radius)?;
                if let Some(a) = angle {
                    self.finite(&format!("{path}.angle"), "angle", *a)?;
                }
                let ids: Vec<usize> = free.by_ref().take(*count).collect();
                let listed: &[(f64, f64)] = match born {
                    Born::Random => &[],
                    Born::Points(ps) => ps,
                };
                if listed.len() > *count {
                    return Err(self.err(FieldError::new(
                        &format!("{path}.born"),
                        format!("{} born points for a group of {count}", listed.len()),
                        format!("at most {count}"),
                    )));
                }
                for (k, &(x, y)) in listed.iter().enumerate() {
                    let pp = format!("{path}.born[0][{k}]");
                    self.finite(&format!("{pp}[0]"), "x", x)?;
                    self.finite(&format!("{pp}[1]"), "y", y)?;
                    self.within(&format!("{pp}[0]"), "x", x)?;
                    self.within(&format!("{pp}[1]"), "y", y)?;
                    let spec = RobotSpec {
                        radius: *radius,
                        pose: Pose {
                            pos: Point::new(x, y),
                            angle: 0.0,
                        },
                    };
                    check_spot(&placed, ids[k], &spec, &pp)?;
                    placed[ids[k]] = Some(spec);
                }
                let rest = count - listed.len();
                if rest > 0 {
                    let (lo, hi) = nekosim_actors::algorithm::destination_area(size);
                    // Discs cannot cover more than the hexagonal packing's share of an area:
                    // refused at once rather than after a long random search.
                    let area = (hi.x - lo.x) * (hi.y - lo.y);
                    let disc = |r: f64| std::f64::consts::PI * r * r;
                    let covered: f64 = placed.iter().flatten().map(|s| disc(s.radius)).sum::<f64>()
                        + rest as f64 * disc(*radius);
                    if covered > PACKING_DENSITY * area {
                        return Err(self.place(
                            &format!("{path}.count"),
                            format!(
                                "{count} robots of radius {radius} cannot fit: with the robots before them they would cover {covered:.0} square units, more than the {:.0} that discs can fill of the {}x{} area where they are born; use a larger world or fewer/smaller robots",
                                PACKING_DENSITY * area,
                                hi.x - lo.x,
                                hi.y - lo.y
                            ),
                        ));
                    }
                    let occupied: Vec<(Point, f64)> = placed
                        .iter()
                        .flatten()
                        .map(|s| (s.pose.pos - lo.coords, s.radius))
                        .collect();
                    let r = *radius;
                    let clear = |q: Point| {
                        let q = q + lo.coords;
                        s.obstacles.iter().all(|o| o.distance(q) >= r)
                    };
                    let drawn = random_born_points_clear(
                        rest,
                        *radius,
                        hi.x - lo.x,
                        hi.y - lo.y,
                        &occupied,
                        &clear,
                        &mut rng,
                    )
                    .map_err(|e| self.place(&format!("{path}.count"), e.to_string()))?;
                    for (k, p) in drawn.into_iter().enumerate() {
                        let id = ids[listed.len() + k];
                        let pos = p + lo.coords;
                        placed[id] = Some(RobotSpec {
                            radius: *radius,
                            pose: Pose { pos, angle: 0.0 },
                        });
                    }
                }
                if ids.is_empty() {
                    continue;
                }
                let algorithm_path = format!("{path}.algorithm");
                let mut built = registry
                    .algorithms
                    .build_many(algorithm, &setting, ids.len())
                    .map_err(|e| self.spec_err(&algorithm_path, &e))?
                    .into_iter();
                for id in &ids {
                    let heading = match angle {
                        Some(a) => *a,
                        None => rng.gen_range(0.0..360.0),
                    };
                    if let Some(spec) = placed[*id].as_mut() {
                        spec.pose.angle = heading;
                    }
                    algorithms[*id] = built.next();
                }
            }
        }
        let robots: Vec<(RobotSpec, Box<dyn Algorithm>)> = placed
            .into_iter()
            .zip(algorithms)
            .map(|(p, a)| {
                (
                    p.expect("every id placed"),
                    a.expect("every id has an algorithm"),
                )
            })
            .collect();
        // The checks above are the kernel's (`VirtualWorld::new`, which the run applies again
        // as it builds its world): debug builds, the tests', make sure they agree; release
        // builds do not pay twice for every run of a sweep.
        #[cfg(debug_assertions)]
        {
            let specs: Vec<RobotSpec> = robots.iter().map(|r| r.0).collect();
            VirtualWorld::new(world.clone(), &specs)
                .map_err(|e| self.place("robots", e.to_string()))?;
        }
        let framerate = match &s.animation {
            None => crate::recording::DEFAULT_FRAMERATE,
            Some(a) => {
                if !(0.0..=crate::recording::MAX_FRAMERATE).contains(&a.framerate) {
                    return Err(self.err(FieldError::value(
                        "animation.framerate",
                        "animation framerate",
                        a.framerate,
                        format!(
                            "frames per simulated second from 0 to {}",
                            crate::recording::MAX_FRAMERATE
                        ),
                    )));
                }
                if a.enabled {
                    a.framerate
                } else {
                    0.0
                }
            }
        };
        // The 2D view: the panel from the world's lower-left corner (centred on the origin in
        // an infinite world), or the world itself.
        let view = match s.animation.as_ref().and_then(|a| a.panel) {
            Some((w, h)) => {
                self.positive("animation.panel[0]", "panel width", w)?;
                self.positive("animation.panel[1]", "panel height", h)?;
                self.within("animation.panel[0]", "panel width", w)?;
                self.within("animation.panel[1]", "panel height", h)?;
                let lo = match world.size {
                    WorldSize::Bounded { min, .. } => min,
                    WorldSize::Infinite => Point::new(-w / 2.0, -h / 2.0),
                };
                Some((lo, Point::new(lo.x + w, lo.y + h)))
            }
            None => match world.size {
                WorldSize::Bounded { min, max } => Some((min, max)),
                WorldSize::Infinite => None,
            },
        };
        let name = s.name.clone().unwrap_or_else(|| {
            Path::new(&self.file)
                .file_stem()
                .map_or("scenario".into(), |s| s.to_string_lossy().into_owned())
        });
        Ok(Built {
            comms,
            codecs,
            sensors: registry.sensors.clone(),
            framerate,
            labels: s.animation.as_ref().and_then(|a| a.labels),
            view,
            outputs: s.outputs.clone(),
            messages: s.network.is_some() || !s.stack.is_empty(),
            deliveries: !s.stack.is_empty(),
            name,
            seed,
            until,
            arbiters: s.arbiters,
            world,
            robots,
        })
    }
}

impl Source {
    /// Network, stack and faults, checked against `n` robots.
    fn comms(
        &self,
        n: usize,
        registry: &Registry,
    ) -> Result<(Comms, Arc<Codecs>, Setting), ScenarioError> {
        let s = &self.scenario;
        let network = s
            .network
            .clone()
            .unwrap_or_else(|| Spec::new("Reliable(delay: 1.0)"));
        registry
            .networks
            .build(&network)
            .map_err(|e| self.spec_err("network", &e))?;
        let (wiring, _) =
            Wiring::check(&s.stack, &registry.protocols).map_err(|e| self.stack_err(&e))?;
        let mut faults = Vec::new();
        let robot_ok = |path: String, r: u32| -> Result<u32, ScenarioError> {
            if (r as usize) < n {
                Ok(r)
            } else {
                Err(self.err(FieldError::new(
                    &path,
                    format!("robot {r} does not exist"),
                    format!("an id in 0..={}", n.saturating_sub(1)),
                )))
            }
        };
        for (i, f) in s.faults.iter().enumerate() {
            let p = format!("faults[{i}]");
            match f {
                FaultSpec::Crash { robot, at } => {
                    let robot = robot_ok(format!("{p}.robot"), *robot)?;
                    self.finite(&format!("{p}.at"), "crash time", *at)?;
                    if *at < 0.0 {
                        return Err(self.err(FieldError::new(
                            &format!("{p}.at"),
                            format!("crash time is {at}"),
                            "a time >= 0",
                        )));
                    }
                    faults.push(Fault::Crash { robot, at: *at });
                }
                FaultSpec::Partition { groups, from, to } => {
                    for (g, group) in groups.iter().enumerate() {
                        for (k, r) in group.iter().enumerate() {
                            robot_ok(format!("{p}.groups[{g}][{k}]"), *r)?;
                        }
                    }
                    self.finite(&format!("{p}.from"), "partition start", *from)?;
                    self.finite(&format!("{p}.to"), "partition end", *to)?;
                    if to < from {
                        return Err(self.err(FieldError::new(
                            &format!("{p}.to"),
                            format!("partition ends at {to} before it starts at {from}"),
                            "from <= to",
                        )));
                    }
                    faults.push(Fault::Partition(Partition {
                        groups: groups.clone(),
                        from: *from,
                        to: *to,
                    }));
                }
            }
        }
        Ok((
            Comms {
                network,
                networks: registry.networks.clone(),
                stack: s.stack.clone(),
                faults,
                protocols: registry.protocols.clone(),
            },
            wiring.codecs.clone(),
            Setting {
                layers: wiring
                    .ids
                    .iter()
                    .cloned()
                    .zip(wiring.provides.iter().copied())
                    .collect(),
            },
        ))
    }

    /// A stack error at its place: inside a layer's protocol text when it says where, else at
    /// the offending field.
    fn stack_err(&self, e: &StackError) -> ScenarioError {
        let path = format!("stack[{}].protocol", e.layer);
        match (e.at, e.field.strip_prefix("protocol")) {
            (Some(at), _) => self.err_in(&path, at, &e.message),
            (None, Some(rest)) => self.place(&format!("{path}{rest}"), e.message.clone()),
            (None, None) => self.place(
                &format!("stack[{}].{}", e.layer, e.field),
                e.message.clone(),
            ),
        }
    }

    /// An error about the spec (a name and its configuration) at `path`: inside its text when
    /// it says where, else at the offending field.
    fn spec_err(&self, path: &str, e: &SpecError) -> ScenarioError {
        match (e.at, &e.field) {
            (Some(at), None) => self.err_in(path, at, &e.message),
            (Some(at), Some(f)) => self.err_in(&format!("{path}.{f}"), at, &e.message),
            (None, Some(f)) if f.starts_with('[') => {
                self.place(&format!("{path}{f}"), e.message.clone())
            }
            (None, Some(f)) => self.place(&format!("{path}.{f}"), e.message.clone()),
            (None, None) => self.place(path, e.message.clone()),
        }
    }

    /// An error at `(line, col)` of the value at `path` (1-based, within the value's text).
    fn err_in(&self, path: &str, (line, col): (usize, usize), message: &str) -> ScenarioError {
        let Some(base) = self.spans.get(path) else {
            return self.place(path, message);
        };
        ScenarioError {
            file: self.file.clone(),
            pos: Some(if line == 1 {
                Pos {
                    line: base.line,
                    col: base.col + col - 1,
                }
            } else {
                Pos {
                    line: base.line + line - 1,
                    col,
                }
            }),
            message: message.to_string(),
        }
    }
}

/// ron places errors about a name (an unknown field or variant) just after it; point at the
/// name itself when it is right before the reported column.
pub(crate) fn name_start(text: &str, line: usize, col: usize, message: &str) -> Pos {
    let at = Pos { line, col };
    let Some(src_line) = text.lines().nth(line.saturating_sub(1)) else {
        return at;
    };
    let before: String = src_line.chars().take(col.saturating_sub(1)).collect();
    let trimmed = before.trim_end_matches(|c: char| c.is_whitespace() || c == ':');
    message
        .split('`')
        .skip(1)
        .step_by(2)
        .filter(|n| !n.is_empty() && n.chars().all(|c| c.is_alphanumeric() || c == '_'))
        .find(|n| {
            trimmed.ends_with(n)
                && !trimmed[..trimmed.len() - n.len()]
                    .ends_with(|c: char| c.is_alphanumeric() || c == '_')
        })
        .map_or(at, |n| Pos {
            line,
            col: trimmed.chars().count() - n.chars().count() + 1,
        })
}

/// ron's error, said as what is wrong and what is expected.
pub(crate) fn describe_ron(e: &ron::Error) -> String {
    let s = e.to_string();
    match e {
        ron::Error::NoSuchStructField { .. } | ron::Error::NoSuchEnumVariant { .. } => {
            format!("{s} (see docs/scenario.md for the accepted fields)")
        }
        _ => s,
    }
}
