//! Scenario files: one experiment in RON (the seed's `robotsim.config`, 6.1, and its
//! initializer, 6.2). See docs/scenario.md for every field.
//!
//! Loading checks everything a run would trip on and reports the first problem as
//! `FILE:LINE:COL: what is wrong and what is expected`.

mod locate;

use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::path::Path;
use std::sync::Arc;

use nekosim_actors::algorithm::{Gathering, Idle, RandomMovement, Script, ScriptStep, SpeedRange};
use nekosim_actors::world::born::random_born_points;
use nekosim_actors::world::geometry::Point;
use nekosim_actors::world::motion::Pose;
use nekosim_actors::world::network::{NetworkSpec, Partition};
use nekosim_actors::world::virtual_world::{RobotSpec, VirtualWorld, WorldConfig, WorldSize};
use nekosim_actors::{Algorithm, Comms, Fault};
use nekosim_protocols::payload::Codecs;
use nekosim_protocols::{LayerSpec, Protocols, StackError, Wiring};
use rand::{Rng, SeedableRng};
use serde::Deserialize;

pub use locate::{locate, Pos};

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
    /// actix arbiters (threads) hosting robots and sensors; the results do not depend on it.
    #[serde(default = "one")]
    pub arbiters: usize,
    /// The simulated network; default `Reliable(delay: 1.0)`.
    #[serde(default)]
    pub network: Option<NetworkSpec>,
    /// Every robot's protocol stack (bottom to top, any order); the algorithm sits on top.
    #[serde(default)]
    pub stack: Vec<LayerSpec>,
    #[serde(default)]
    pub faults: Vec<FaultSpec>,
    /// Animation settings of recordings (seed 6.1); default 25 frames per simulated second.
    #[serde(default)]
    pub animation: Option<Animation>,
}

/// How recordings animate robots between events (the seed's animation settings, 6.1).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Animation {
    /// Frames per simulated second sampled from the motion formulas; 0: event instants only.
    pub framerate: f64,
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

fn five() -> f64 {
    5.0
}

fn ninety() -> f64 {
    90.0
}

/// The virtual world (seed 3.2, 6.1).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct World {
    pub size: Size,
    /// No robot-robot collisions (the boundary still holds robots in).
    #[serde(default)]
    pub ghost_mode: bool,
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
        radius: f64,
        at: (f64, f64),
        /// Heading [deg], anticlockwise from +x.
        #[serde(default)]
        angle: f64,
        #[serde(default)]
        algorithm: AlgorithmSpec,
    },
    Group {
        count: usize,
        radius: f64,
        #[serde(default)]
        born: Born,
        /// Heading of every robot of the group [deg]; by default each draws one at random.
        #[serde(default)]
        angle: Option<f64>,
        #[serde(default)]
        algorithm: AlgorithmSpec,
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

/// A robot's algorithm.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum AlgorithmSpec {
    #[default]
    Idle,
    Script(Vec<ScriptStep>),
    /// Seed 5.1. Ranges are `(min, max)`; by default move speed in [3, 13) and turn speed
    /// `3 + move_speed × U`, as the seed's code.
    RandomMovement {
        #[serde(default)]
        move_speed: Option<(f64, f64)>,
        #[serde(default)]
        turn_speed: Option<(f64, f64)>,
        /// Wait after a move that took no time (boxed in) [s]; default 1.
        #[serde(default)]
        retry: Option<f64>,
    },
    /// Seed 5.2. By default move speed in [3, 6) and turn speed `3 + move_speed × U`.
    Gathering {
        #[serde(default)]
        move_speed: Option<(f64, f64)>,
        #[serde(default)]
        turn_speed: Option<(f64, f64)>,
        /// GPS error factor.
        #[serde(default)]
        error: f64,
        /// Wait after a move that took no time (gathered, or blocked) [s]; default 1.
        #[serde(default)]
        retry: Option<f64>,
    },
    /// Seed 5.3: multicast a random GOTO order to all others, obey the first order received.
    AskForHelp,
    /// Agreement: propose the own position to consensus `layer`, go to the decided point.
    MeetingPoint {
        layer: String,
        #[serde(default = "five")]
        move_speed: f64,
        #[serde(default = "ninety")]
        turn_speed: f64,
    },
    /// Reserve each straight path through the total-order `layer` before moving along it.
    PathReservation {
        layer: String,
        #[serde(default = "five")]
        move_speed: f64,
        #[serde(default = "ninety")]
        turn_speed: f64,
    },
    /// Neko's latency test: `count` broadcasts through `layer` at exponential intervals.
    BroadcastLoad {
        layer: String,
        count: u32,
        mean_interval: f64,
    },
    /// An algorithm registered in Rust under `name` (see [`Registry`]).
    Custom {
        name: String,
        #[serde(default)]
        params: BTreeMap<String, f64>,
    },
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

/// Builds a custom algorithm from its parameters.
pub type Factory =
    Box<dyn Fn(&BTreeMap<String, f64>) -> Result<Box<dyn Algorithm>, String> + Send + Sync>;

/// Algorithms and protocols by name: custom algorithms for `Custom(name: ..)`, and the
/// protocols a scenario's `stack` names (`protocol: Name(config)`), built-in and the user's
/// alike.
pub struct Registry {
    factories: BTreeMap<String, Factory>,
    /// The protocols for the `stack`.
    pub protocols: Protocols,
}

impl Default for Registry {
    /// [`Registry::with_builtins`].
    fn default() -> Self {
        Self::with_builtins()
    }
}

impl fmt::Debug for Registry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Registry")
            .field("names", &self.factories.keys().collect::<Vec<_>>())
            .field("protocols", &self.protocols)
            .finish()
    }
}

impl Registry {
    /// The built-in protocols and no custom algorithm (the same as [`Registry::with_builtins`]).
    pub fn new() -> Self {
        Self::default()
    }

    /// The built-in protocols ([`Protocols::with_builtins`]) and no custom algorithm.
    pub fn with_builtins() -> Self {
        Self {
            factories: BTreeMap::new(),
            protocols: Protocols::with_builtins(),
        }
    }

    /// Registers `factory` under `name`.
    pub fn register(
        &mut self,
        name: &str,
        factory: impl Fn(&BTreeMap<String, f64>) -> Result<Box<dyn Algorithm>, String>
            + Send
            + Sync
            + 'static,
    ) -> &mut Self {
        self.factories.insert(name.to_string(), Box::new(factory));
        self
    }

    /// Registers the microprotocol `P` under `name`, for `protocol: Name(config)` in a
    /// scenario's `stack` (see docs/extending.md).
    pub fn protocol<P: nekosim_protocols::Microprotocol>(&mut self, name: &str) -> &mut Self {
        self.protocols.protocol::<P>(name);
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
    /// Animation frames per simulated second of recordings; 0: event instants only.
    pub framerate: f64,
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
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| ScenarioError {
            file: file.clone(),
            pos: None,
            message: format!("cannot read the scenario file: {e}"),
        })?;
        Self::parse(&file, &text)
    }

    /// Parses scenario text; `file` names it in errors.
    pub fn parse(file: &str, text: &str) -> Result<Self, ScenarioError> {
        let opts = ron::Options::default()
            .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME);
        let scenario: Scenario = opts.from_str(text).map_err(|e| {
            let message = describe_ron(&e.code);
            ScenarioError {
                file: file.to_string(),
                pos: Some(name_start(text, e.position.line, e.position.col, &message)),
                message,
            }
        })?;
        Ok(Self {
            file: file.to_string(),
            scenario,
            spans: locate(text),
        })
    }

    fn err(&self, path: &str, message: impl Into<String>) -> ScenarioError {
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
            Err(self.err(path, format!("{what} is {v}; expected a finite number")))
        }
    }

    fn positive(&self, path: &str, what: &str, v: f64) -> Result<f64, ScenarioError> {
        self.finite(path, what, v)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.err(path, format!("{what} is {v}; expected a number > 0")))
        }
    }

    fn range(
        &self,
        path: &str,
        what: &str,
        r: Option<(f64, f64)>,
    ) -> Result<Option<SpeedRange>, ScenarioError> {
        let Some((lo, hi)) = r else { return Ok(None) };
        self.positive(&format!("{path}[0]"), what, lo)?;
        self.positive(&format!("{path}[1]"), what, hi)?;
        if hi < lo {
            return Err(self.err(
                path,
                format!(
                    "{what} range ({lo}, {hi}) is reversed; expected (min, max) with min <= max"
                ),
            ));
        }
        Ok(Some(SpeedRange {
            min: lo,
            spread: hi - lo,
        }))
    }

    fn algorithm(
        &self,
        path: &str,
        spec: &AlgorithmSpec,
        registry: &Registry,
    ) -> Result<Box<dyn Algorithm>, ScenarioError> {
        Ok(match spec {
            AlgorithmSpec::Idle => Box::new(Idle),
            AlgorithmSpec::AskForHelp => Box::new(nekosim_actors::algorithm::AskForHelp),
            AlgorithmSpec::PathReservation {
                layer,
                move_speed,
                turn_speed,
            } => {
                self.positive(&format!("{path}.move_speed"), "move speed", *move_speed)?;
                self.positive(&format!("{path}.turn_speed"), "turn speed", *turn_speed)?;
                let total_order = self.scenario.stack.iter().any(|l| {
                    &l.id == layer
                        && registry.protocols.build(&l.protocol).is_ok_and(|(sh, _)| {
                            sh.provides.serves(nekosim_protocols::Service::TOTAL_ORDER)
                        })
                });
                if !total_order {
                    return Err(self.err(&format!("{path}.layer"), format!("{layer:?} is not a total-order broadcast layer of the stack; expected the id of one")));
                }
                Box::new(nekosim_actors::algorithm::PathReservation {
                    layer: layer.clone(),
                    move_speed: *move_speed,
                    turn_speed: *turn_speed,
                })
            }
            AlgorithmSpec::MeetingPoint {
                layer,
                move_speed,
                turn_speed,
            } => {
                self.positive(&format!("{path}.move_speed"), "move speed", *move_speed)?;
                self.positive(&format!("{path}.turn_speed"), "turn speed", *turn_speed)?;
                if !self.scenario.stack.iter().any(|l| &l.id == layer) {
                    return Err(self.err(
                        &format!("{path}.layer"),
                        format!(
                            "no layer {layer:?} in the stack; expected the id of a consensus layer"
                        ),
                    ));
                }
                Box::new(nekosim_actors::algorithm::MeetingPoint {
                    layer: layer.clone(),
                    move_speed: *move_speed,
                    turn_speed: *turn_speed,
                })
            }
            AlgorithmSpec::BroadcastLoad {
                layer,
                count,
                mean_interval,
            } => {
                self.positive(
                    &format!("{path}.mean_interval"),
                    "mean interval",
                    *mean_interval,
                )?;
                if !self.scenario.stack.iter().any(|l| &l.id == layer) {
                    return Err(self.err(
                        &format!("{path}.layer"),
                        format!(
                            "no layer {layer:?} in the stack; expected the id of a broadcast layer"
                        ),
                    ));
                }
                Box::new(nekosim_actors::algorithm::BroadcastLoad {
                    layer: layer.clone(),
                    count: *count,
                    mean_interval: *mean_interval,
                })
            }
            AlgorithmSpec::Script(steps) => {
                for (k, step) in steps.iter().enumerate() {
                    let p = format!("{path}[0][{k}]");
                    match *step {
                        ScriptStep::Turn { angle, turn_speed } => {
                            self.finite(&format!("{p}.angle"), "turn angle", angle)?;
                            self.positive(&format!("{p}.turn_speed"), "turn speed", turn_speed)?;
                        }
                        ScriptStep::Forward {
                            distance,
                            move_speed,
                        } => {
                            self.finite(&format!("{p}.distance"), "distance", distance)?;
                            if distance < 0.0 {
                                return Err(self.err(
                                    &format!("{p}.distance"),
                                    format!("distance is {distance}; expected a number >= 0"),
                                ));
                            }
                            self.positive(&format!("{p}.move_speed"), "move speed", move_speed)?;
                        }
                        ScriptStep::MoveTo {
                            x,
                            y,
                            move_speed,
                            turn_speed,
                        } => {
                            self.finite(&format!("{p}.x"), "x", x)?;
                            self.finite(&format!("{p}.y"), "y", y)?;
                            self.positive(&format!("{p}.move_speed"), "move speed", move_speed)?;
                            self.positive(&format!("{p}.turn_speed"), "turn speed", turn_speed)?;
                        }
                        ScriptStep::Wait(d) => {
                            self.finite(&format!("{p}[0]"), "wait", d)?;
                            if d < 0.0 {
                                return Err(self.err(
                                    &format!("{p}[0]"),
                                    format!("wait is {d}; expected a duration >= 0"),
                                ));
                            }
                        }
                    }
                }
                Box::new(Script(steps.clone()))
            }
            AlgorithmSpec::RandomMovement {
                move_speed,
                turn_speed,
                retry,
            } => {
                let d = RandomMovement::default();
                Box::new(RandomMovement {
                    move_speed: self
                        .range(&format!("{path}.move_speed"), "move speed", *move_speed)?
                        .unwrap_or(d.move_speed),
                    turn_speed: self.range(
                        &format!("{path}.turn_speed"),
                        "turn speed",
                        *turn_speed,
                    )?,
                    retry: match retry {
                        Some(r) => self.positive(&format!("{path}.retry"), "retry", *r)?,
                        None => d.retry,
                    },
                })
            }
            AlgorithmSpec::Gathering {
                move_speed,
                turn_speed,
                error,
                retry,
            } => {
                let d = Gathering::default();
                self.finite(&format!("{path}.error"), "error factor", *error)?;
                if *error < 0.0 {
                    return Err(self.err(
                        &format!("{path}.error"),
                        format!("error factor is {error}; expected a number >= 0"),
                    ));
                }
                Box::new(Gathering {
                    move_speed: self
                        .range(&format!("{path}.move_speed"), "move speed", *move_speed)?
                        .unwrap_or(d.move_speed),
                    turn_speed: self.range(
                        &format!("{path}.turn_speed"),
                        "turn speed",
                        *turn_speed,
                    )?,
                    error: *error,
                    retry: match retry {
                        Some(r) => self.positive(&format!("{path}.retry"), "retry", *r)?,
                        None => d.retry,
                    },
                })
            }
            AlgorithmSpec::Custom { name, params } => {
                let Some(f) = registry.factories.get(name) else {
                    let known: Vec<&str> = registry.factories.keys().map(String::as_str).collect();
                    return Err(self.err(
                        &format!("{path}.name"),
                        format!(
                            "unknown algorithm {name:?}; registered custom algorithms: {}",
                            if known.is_empty() {
                                "none".to_string()
                            } else {
                                known.join(", ")
                            }
                        ),
                    ));
                };
                f(params).map_err(|m| self.err(&format!("{path}.params"), m))?
            }
        })
    }

    /// Checks the scenario and builds the robots, ids, born points and algorithms.
    pub fn build(&self, overrides: Overrides, registry: &Registry) -> Result<Built, ScenarioError> {
        let s = &self.scenario;
        let until = match overrides.until {
            Some(u) => u,
            None => s.until,
        };
        if until.is_nan() || until < 0.0 {
            return Err(self.err(
                "until",
                format!("until is {until}; expected a time >= 0 in seconds"),
            ));
        }
        if s.arbiters == 0 {
            return Err(self.err("arbiters", "arbiters is 0; expected at least 1"));
        }
        let seed = overrides.seed.unwrap_or(s.seed);
        let size = match s.world.size {
            Size::Infinite => WorldSize::Infinite,
            Size::Bounded { width, height } => {
                self.positive("world.size.width", "world width", width)?;
                self.positive("world.size.height", "world height", height)?;
                match s.world.origin {
                    Some((x, y)) => {
                        self.finite("world.origin[0]", "origin x", x)?;
                        self.finite("world.origin[1]", "origin y", y)?;
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
        let world = WorldConfig {
            size,
            ghost_mode: s.world.ghost_mode,
            cell_size: s.world.cell_size,
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
                    self.err(
                        &path,
                        format!(
                            "robot id {id} is out of range; with {total} robots ids are 0..={}",
                            total.saturating_sub(1)
                        ),
                    )
                })?;
                if let Some(first) = *slot {
                    return Err(self.err(&path, format!("duplicate robot id {id} (also used by robots[{first}]); expected unique ids")));
                }
                *slot = Some(i);
            }
        }

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
                    return Err(self.err(
                        path,
                        format!(
                            "robot {id} at ({}, {}) with radius {r} is not inside the world [{}, {}] x [{}, {}]; expected a born point at least one radius inside",
                            p.x, p.y, min.x, max.x, min.y, max.y
                        ),
                    ));
                }
            }
            for (other, o) in placed.iter().enumerate() {
                if let Some(o) = o {
                    if (o.pose.pos - p).norm() < o.radius + r {
                        return Err(self.err(path, format!("robot {id} at ({}, {}) overlaps robot {other} at ({}, {}); expected born points at least the sum of the radii apart", p.x, p.y, o.pose.pos.x, o.pose.pos.y)));
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
                self.positive(&format!("{path}.radius"), "radius", *radius)?;
                self.finite(&format!("{path}.at[0]"), "x", at.0)?;
                self.finite(&format!("{path}.at[1]"), "y", at.1)?;
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
                algorithms[*id as usize] =
                    Some(self.algorithm(&format!("{path}.algorithm"), algorithm, registry)?);
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
                    return Err(self.err(
                        &format!("{path}.born"),
                        format!(
                            "{} born points for a group of {count}; expected at most {count}",
                            listed.len()
                        ),
                    ));
                }
                for (k, &(x, y)) in listed.iter().enumerate() {
                    let pp = format!("{path}.born[0][{k}]");
                    self.finite(&format!("{pp}[0]"), "x", x)?;
                    self.finite(&format!("{pp}[1]"), "y", y)?;
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
                    let occupied: Vec<(Point, f64)> = placed
                        .iter()
                        .flatten()
                        .map(|s| (s.pose.pos - lo.coords, s.radius))
                        .collect();
                    let drawn = random_born_points(
                        rest,
                        *radius,
                        hi.x - lo.x,
                        hi.y - lo.y,
                        &occupied,
                        &mut rng,
                    )
                    .map_err(|e| self.err(&format!("{path}.count"), e.to_string()))?;
                    for (k, p) in drawn.into_iter().enumerate() {
                        let id = ids[listed.len() + k];
                        let pos = p + lo.coords;
                        placed[id] = Some(RobotSpec {
                            radius: *radius,
                            pose: Pose { pos, angle: 0.0 },
                        });
                    }
                }
                for id in &ids {
                    let heading = match angle {
                        Some(a) => *a,
                        None => rng.gen_range(0.0..360.0),
                    };
                    if let Some(spec) = placed[*id].as_mut() {
                        spec.pose.angle = heading;
                    }
                    algorithms[*id] =
                        Some(self.algorithm(&format!("{path}.algorithm"), algorithm, registry)?);
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
        // The kernel's own checks, as a second net.
        let specs: Vec<RobotSpec> = robots.iter().map(|r| r.0).collect();
        VirtualWorld::new(world, &specs).map_err(|e| self.err("robots", e.to_string()))?;
        let (comms, codecs) = self.comms(total, registry)?;
        let framerate = match &s.animation {
            None => crate::recording::DEFAULT_FRAMERATE,
            Some(a) => {
                if !(0.0..=crate::recording::MAX_FRAMERATE).contains(&a.framerate) {
                    return Err(self.err(
                        "animation.framerate",
                        format!(
                            "animation framerate is {}; expected frames per simulated second from 0 to {}",
                            a.framerate,
                            crate::recording::MAX_FRAMERATE
                        ),
                    ));
                }
                a.framerate
            }
        };
        let name = s.name.clone().unwrap_or_else(|| {
            Path::new(&self.file)
                .file_stem()
                .map_or("scenario".into(), |s| s.to_string_lossy().into_owned())
        });
        Ok(Built {
            comms,
            codecs,
            framerate,
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
    fn comms(&self, n: usize, registry: &Registry) -> Result<(Comms, Arc<Codecs>), ScenarioError> {
        let s = &self.scenario;
        let network = s.network.clone().unwrap_or_default();
        network
            .check()
            .map_err(|(f, m)| self.err(&format!("network.{f}"), m))?;
        let (wiring, _) =
            Wiring::check(&s.stack, &registry.protocols).map_err(|e| self.stack_err(&e))?;
        let mut faults = Vec::new();
        let robot_ok = |path: String, r: u32| -> Result<u32, ScenarioError> {
            if (r as usize) < n {
                Ok(r)
            } else {
                Err(self.err(
                    &path,
                    format!(
                        "robot {r} does not exist; expected an id in 0..={}",
                        n.saturating_sub(1)
                    ),
                ))
            }
        };
        for (i, f) in s.faults.iter().enumerate() {
            let p = format!("faults[{i}]");
            match f {
                FaultSpec::Crash { robot, at } => {
                    let robot = robot_ok(format!("{p}.robot"), *robot)?;
                    self.finite(&format!("{p}.at"), "crash time", *at)?;
                    if *at < 0.0 {
                        return Err(self.err(
                            &format!("{p}.at"),
                            format!("crash time is {at}; expected a time >= 0"),
                        ));
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
                        return Err(self.err(&format!("{p}.to"), format!("partition ends at {to} before it starts at {from}; expected from <= to")));
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
                stack: s.stack.clone(),
                faults,
                protocols: registry.protocols.clone(),
            },
            wiring.codecs,
        ))
    }

    /// A stack error at its place: inside a layer's protocol text when it says where, else at
    /// the offending field.
    fn stack_err(&self, e: &StackError) -> ScenarioError {
        let base = self.spans.get(&format!("stack[{}].protocol", e.layer));
        match (e.at, base) {
            (Some((line, col)), Some(base)) => ScenarioError {
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
                message: e.message.clone(),
            },
            _ => self.err(
                &format!("stack[{}].{}", e.layer, e.field),
                e.message.clone(),
            ),
        }
    }
}

/// ron places errors about a name (an unknown field or variant) just after it; point at the
/// name itself when it is right before the reported column.
fn name_start(text: &str, line: usize, col: usize, message: &str) -> Pos {
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
fn describe_ron(e: &ron::Error) -> String {
    let s = e.to_string();
    match e {
        ron::Error::NoSuchStructField { .. } | ron::Error::NoSuchEnumVariant { .. } => {
            format!("{s} (see docs/scenario.md for the accepted fields)")
        }
        _ => s,
    }
}
