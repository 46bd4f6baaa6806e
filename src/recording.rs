//! Rerun recordings of a run: the seed's animation module (seed 4.5.2, animation settings of
//! 6.1) rebuilt as a stream of drawings for the Rerun viewer, live (`--connect`) or saved
//! (`--rrd FILE`). docs/visualization.md describes what a recording shows.
//!
//! The module has two halves, so that what is drawn can be tested without Rerun:
//!
//! - [`Recorder`] (always compiled, pure): turns the run's [`Record`]s, the same stream the
//!   JSONL trace and the Neko log are written from, into calls on a [`Canvas`]. It keeps the
//!   little state a drawing needs (each robot's kinematic state, last corner, sensor, messages in
//!   flight) and samples the animation frames.
//! - [`rerun_canvas::RerunCanvas`] (cargo feature `rerun`): a [`Canvas`] that writes Rerun
//!   entities, buffered per entity and sent as columns.
//!
//! **Input.** The recorder consumes [`Record`]s rather than JSONL lines: they are what the
//! engine produces, they are typed, and the trace is a projection of them, so every trace
//! object corresponds to exactly one record. `nekosim check --rrd` turns a counterexample into
//! `Record`s (spawns, sends, receives, crashes) and feeds them through the same recorder.
//!
//! **Animation.** Between two kinematic records of a robot (spawn, motion step, motion finish,
//! crash) the built-in motion patterns are exactly linear in time: the position is
//! `pos_k + vel_k (t - t_k)` and the heading `angle_k + omega_k (t - t_k)` (seed eq. 3.1-3.2,
//! the patterns' `state_at`). Frames at `k / framerate` evaluate these formulas for every
//! moving robot; they never come from slicing the engine's time. A user-defined curved pattern
//! only exposes its step states in the record stream, so its frames follow the chord between
//! steps (the same limitation as rebuilding trajectories from the trace, docs/trace.md).
//!
//! **Determinism.** Everything drawn is a function of the records and the scenario: frames
//! are on simulated time, `events/s` counts events per simulated second, and robot and layer
//! colours come from ids and names, never from a hash map's order or the wall clock. Buffers
//! are sent when they reach a size, never on a timer, so the .rrd file's chunks and ids
//! ([`rrd_file`]) are a function of the run too.

use std::collections::{BTreeMap, VecDeque};

use nekosim_actors::world::geometry::{normalize_deg, Point, Vector};
use nekosim_actors::world::motion::Kinematics;
use nekosim_actors::world::observation::{Observation, Record};
use nekosim_actors::world::sensor::{Plan, Reach, SensorKind, Trigger};
use nekosim_actors::world::virtual_world::WorldSize;
use nekosim_actors::world::{Obstacle, RobotId};
use nekosim_protocols::payload::type_word;

use crate::log::NekoLog;

#[cfg(feature = "rerun")]
pub mod names;
#[cfg(feature = "rerun")]
pub mod rerun_canvas;
#[cfg(feature = "rerun")]
pub mod rrd_file;

/// Why a recording could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecordingError {
    /// The .rrd file (or its directory) could not be created: the user's input. Fatal before
    /// the run starts.
    #[error("{path}: cannot create the recording: {message}")]
    Create { path: String, message: String },
    /// The viewer URL is not a Rerun gRPC proxy URL: the user's input.
    #[error("{url}: not a Rerun viewer URL ({message}); expected e.g. rerun+http://127.0.0.1:9876/proxy")]
    Url { url: String, message: String },
    /// No viewer answered at the URL (none running, or another address): the user's input.
    #[error("{url}: cannot stream to the Rerun viewer: {message}; start one with `rerun` or check --connect")]
    Unreachable { url: String, message: String },
    /// Rerun refused data or could not finish the file (an internal error).
    #[error("recording: {0}")]
    Rerun(String),
    /// This build has no Rerun support (cargo feature `rerun` off): the user's input.
    #[error("this nekosim was built without Rerun support (cargo feature `rerun`); --rrd and --connect are unavailable")]
    Unsupported,
    /// The finished .rrd file could not be moved into place. (The cause is in the message, not
    /// a `source`, so that error chains do not print it twice.)
    #[error("{path}: cannot write the recording: {error}")]
    Write { path: String, error: std::io::Error },
}

impl RecordingError {
    /// Whether the user's input is at fault (exit 2) rather than nekosim or Rerun (exit 1).
    pub fn is_input_error(&self) -> bool {
        matches!(
            self,
            RecordingError::Create { .. }
                | RecordingError::Url { .. }
                | RecordingError::Unreachable { .. }
                | RecordingError::Unsupported
        )
    }
}

/// Where a recording goes.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Target {
    /// Save to this .rrd file.
    pub rrd: Option<std::path::PathBuf>,
    /// Stream to the viewer at this gRPC URL (`Some(None)`: the SDK's default URL).
    pub connect: Option<Option<String>>,
}

impl Target {
    /// Whether anything is to be recorded.
    pub fn is_some(&self) -> bool {
        self.rrd.is_some() || self.connect.is_some()
    }
}

/// Animation frames per simulated second when a scenario does not say.
pub const DEFAULT_FRAMERATE: f64 = 25.0;

/// The highest animation rate a scenario may ask for [frames per simulated second]: a frame is
/// a row per moving robot group, so a rate far beyond what a viewer can show would only make
/// the run crawl (10^9 frames per second never ended a 20 s run).
pub const MAX_FRAMERATE: f64 = 1000.0;

/// How long a leg of a robot's path stays drawn behind it [simulated s] (the default
/// blueprint's visible time range of `world/paths`).
pub const TRAIL_SECONDS: f64 = 10.0;

/// Window of the `events_per_second` metric [simulated s]: one second, so the rate does not
/// depend on the sampling period (a frame period is too short to count events meaningfully).
pub const EVENT_RATE_WINDOW: f64 = 1.0;

/// When a drawing holds: a simulated instant [s], and the trace `seq` of the record that caused
/// it (`None` for animation frames and metric samples, which lie between events).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stamp {
    /// Simulated time [s].
    pub t: f64,
    pub seq: Option<u64>,
}

/// An RGB colour.
pub type Rgb = [u8; 3];

/// Colour of crashed robots.
pub const GREY: Rgb = [128, 128, 128];

/// Figures sampled over the run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Metrics {
    /// Collision records so far.
    pub collisions: u64,
    /// Message copies sent and not yet received (lost copies stay in flight).
    pub in_flight: u64,
    /// Broadcast deliveries to algorithms so far.
    pub deliveries: u64,
    /// Records per simulated second over the last [`EVENT_RATE_WINDOW`] (a sliding window).
    pub events_per_second: f64,
}

/// A message copy on its way: from the sender's position to the receiver's, both taken when it
/// was sent.
#[derive(Clone, Debug, PartialEq)]
pub struct Flight {
    pub from: RobotId,
    pub to: RobotId,
    pub origin: Point,
    pub target: Point,
    /// The message's outermost type (`FIFO`, `LAMPORT`, an application type).
    pub label: String,
    /// The whole message as the log renders it (`FIFO#0(LAMPORT(ts 1, 1:0, M 1))`).
    pub text: String,
    /// When it was sent [simulated s].
    pub sent: f64,
    /// When it arrives, as the network decided at the send (`None`: unknown or lost). The
    /// arrow then ends where the receiver will be at that instant, predicted from its current
    /// motion and predicted again whenever its motion changes, so it is exact at the receive.
    pub arrive: Option<f64>,
}

/// Something on a process's lane of the space-time diagram.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mark {
    /// A broadcast delivered to the algorithm.
    Deliver,
    /// A consensus decision.
    Decide,
    /// The robot crashed: its lane ends.
    Crash,
}

/// Where a recording draws; one method per entity family of docs/visualization.md.
///
/// Robots are drawn in groups of [`ROBOT_GROUP`] consecutive ids (robot `i` is instance
/// `i % ROBOT_GROUP` of group `i / ROBOT_GROUP`): a Rerun row replaces a whole batch, so each
/// row of a group carries every robot of the group. The per-robot setters (`spawn`, `colour`,
/// `path`, `destination`, `sensor`) change what the group shows; the next [`Canvas::poses`]
/// call of the group commits them in a row at its stamp, with the group's exact poses.
pub trait Canvas {
    /// The world's bounds (`None`: an infinite world). Called once, first.
    fn world(&mut self, bounds: Option<(Point, Point)>);
    /// The world's obstacles, each as the closed (or open, for a segment) line that draws it;
    /// called once, before the run.
    fn obstacles(&mut self, _outlines: &[Vec<Point>]) {}
    /// A robot exists: its radius and colour.
    fn spawn(&mut self, robot: RobotId, radius: f64, colour: Rgb);
    /// A robot's colour changes (grey when it crashed).
    fn colour(&mut self, robot: RobotId, colour: Rgb);
    /// A leg of the robot's path, from its previous corner to where it is at `at`, drawn at
    /// `at` (a viewer shows the legs of the last [`TRAIL_SECONDS`]).
    fn leg(&mut self, at: Stamp, robot: RobotId, from: Point, to: Point);
    /// Where the robot's current motion ends (`None`: no motion).
    fn destination(&mut self, robot: RobotId, dest: Option<Point>);
    /// The reach of the robot's push sensor, centre to border (`None`: none active); the
    /// circle follows the robot.
    fn sensor(&mut self, robot: RobotId, reach: Option<f64>);
    /// A robot's exact pose at one of its kinematic records (spawn, motion step or finish,
    /// crash), in 64-bit floats: where the motion formulas start from.
    fn pose(&mut self, at: Stamp, robot: RobotId, pos: Point, angle: f64);
    /// The exact poses `(position, heading)` at `at` of robots `first, first + 1, ...` (a whole
    /// group, `first` a multiple of [`ROBOT_GROUP`]), at an event or an animation frame: one
    /// row of the group, with the changes set since its last row.
    fn poses(&mut self, at: Stamp, first: RobotId, poses: &[(Point, f64)]);
    /// A view or proximity query's range, from request to reply (`None`: answered).
    fn query(&mut self, at: Stamp, robot: RobotId, circle: Option<(Point, f64)>);
    /// Collision number `k` (from 0) at contact point `point`.
    fn collision(&mut self, at: Stamp, k: u64, point: Point, label: &str);
    /// Every copy in flight on `layer`, drawn in `colour`.
    fn messages(&mut self, at: Stamp, layer: &str, colour: Rgb, flights: &[Flight]);
    /// A Neko log line at a level ([`level_of`]).
    fn log(&mut self, at: Stamp, level: Level, line: &str);
    /// The space-time diagram: `flight` arrived at `at` (drawn then, from the sender's lane at
    /// the send to the receiver's lane at the receive), on `layer` in `colour`.
    fn exchange(&mut self, _at: Stamp, _layer: &str, _colour: Rgb, _flight: &Flight) {}
    /// The space-time diagram: `mark` on `robot`'s lane at `at`, labelled `label` (a
    /// delivery's message id, a decision's instance).
    fn mark(&mut self, _at: Stamp, _robot: RobotId, _mark: Mark, _label: &str) {}
    /// A document shown beside the drawings (a check's verdict, in Markdown).
    fn note(&mut self, _markdown: &str) {}
    /// The messages in flight on `layer` as packets along their arrows, at `at`.
    fn packets(&mut self, _at: Stamp, _layer: &str, _colour: Rgb, _packets: &[Point]) {}
    /// The run's figures.
    fn metrics(&mut self, at: Stamp, m: &Metrics);
}

/// How much a log line matters, as the recording's log view shows it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// What robots and protocols do: motions, sensing, messages, deliveries.
    Info,
    /// Something a reader should notice: a collision, a suspicion.
    Warn,
    /// A failure: a crash, a violated property.
    Error,
}

impl Level {
    /// Rerun's name of the level.
    pub fn name(self) -> &'static str {
        match self {
            Self::Info => "INFO",
            Self::Warn => "WARN",
            Self::Error => "ERROR",
        }
    }
}

/// The level of a record's log line: collisions and suspicions warn, crashes are errors, the
/// rest is information.
pub fn level_of(obs: &Observation) -> Level {
    match obs {
        Observation::Collision { .. } | Observation::Suspect { .. } => Level::Warn,
        Observation::Crash { .. } => Level::Error,
        _ => Level::Info,
    }
}

/// Robots per drawn group (one Rerun entity per group and entity family).
pub const ROBOT_GROUP: u32 = 16;

/// A canvas that draws nothing (the recorder's own cost, and builds without Rerun).
#[derive(Clone, Copy, Debug, Default)]
pub struct NoCanvas;

impl Canvas for NoCanvas {
    fn world(&mut self, _: Option<(Point, Point)>) {}
    fn spawn(&mut self, _: RobotId, _: f64, _: Rgb) {}
    fn colour(&mut self, _: RobotId, _: Rgb) {}
    fn leg(&mut self, _: Stamp, _: RobotId, _: Point, _: Point) {}
    fn destination(&mut self, _: RobotId, _: Option<Point>) {}
    fn sensor(&mut self, _: RobotId, _: Option<f64>) {}
    fn pose(&mut self, _: Stamp, _: RobotId, _: Point, _: f64) {}
    fn poses(&mut self, _: Stamp, _: RobotId, _: &[(Point, f64)]) {}
    fn query(&mut self, _: Stamp, _: RobotId, _: Option<(Point, f64)>) {}
    fn collision(&mut self, _: Stamp, _: u64, _: Point, _: &str) {}
    fn messages(&mut self, _: Stamp, _: &str, _: Rgb, _: &[Flight]) {}
    fn log(&mut self, _: Stamp, _: Level, _: &str) {}
    fn metrics(&mut self, _: Stamp, _: &Metrics) {}
}

#[derive(Clone, Debug)]
struct RobotState {
    /// Time of the kinematic state [s].
    t: f64,
    state: Kinematics,
    radius: f64,
    crashed: bool,
    /// Where the robot was at its latest kinematic record.
    corner: Point,
    /// Reach of each armed push sensor that shows one (push proximity), centre to border
    /// [units].
    sensors: BTreeMap<SensorKind, f64>,
    /// The pull sensor whose range is drawn until its reply.
    querying: Option<SensorKind>,
}

impl RobotState {
    /// The widest range among the armed push sensors, drawn around the robot.
    fn widest_sensor(&self) -> Option<f64> {
        self.sensors.values().copied().reduce(f64::max)
    }

    fn moving(&self) -> bool {
        !self.crashed && (self.state.vel != Vector::zeros() || self.state.omega != 0.0)
    }

    /// The motion formulas of the built-in patterns, evaluated at `t`.
    fn at(&self, t: f64) -> (Point, f64) {
        let dt = t - self.t;
        let angle = self.state.angle + self.state.omega * dt;
        // The heading usually stays in [0, 360), where `normalize_deg` is the identity: the
        // remainder is not worth its cost for every robot at every frame.
        let angle = if (0.0..360.0).contains(&angle) {
            angle
        } else {
            normalize_deg(angle)
        };
        (self.state.pos + self.state.vel * dt, angle)
    }
}

/// A distinct colour for robot `i` (hues spaced by the golden angle).
pub fn robot_colour(i: u32) -> Rgb {
    hsv(f64::from(i) * 137.507_764, 0.75, 0.9)
}

/// The colour of a protocol layer, from its name (FNV-1a, so it does not depend on the run).
pub fn layer_colour(layer: &str) -> Rgb {
    let mut h: u32 = 0x811c_9dc5;
    for b in layer.bytes() {
        h ^= u32::from(b);
        h = h.wrapping_mul(0x0100_0193);
    }
    hsv(f64::from(h % 360), 0.9, 1.0)
}

fn hsv(hue: f64, s: f64, v: f64) -> Rgb {
    let h = normalize_deg(hue) / 60.0;
    let c = v * s;
    let x = c * (1.0 - (h % 2.0 - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    let q = |u: f64| ((u + m) * 255.0).round() as u8;
    [q(r), q(g), q(b)]
}

/// Key of an in-flight copy: (sender, receiver, layer, message).
type FlightKey = (RobotId, RobotId, String, nekosim_protocols::Payload);

/// Turns a run's records into drawings on a [`Canvas`].
#[derive(Debug)]
pub struct Recorder<C: Canvas> {
    canvas: C,
    robots: Vec<RobotState>,
    log: NekoLog,
    /// Animation frames per simulated second; 0: event instants only.
    framerate: f64,
    /// Next animation frame's number.
    frame: u64,
    /// Period of metric samples [s].
    period: f64,
    next_sample: u64,
    metrics: Metrics,
    /// Times of the records in the last [`EVENT_RATE_WINDOW`] before the next sample.
    recent: VecDeque<f64>,
    /// Copies in flight, per layer, in send order.
    flights: BTreeMap<String, Vec<(FlightKey, Flight)>>,
    last_t: f64,
    /// A group's poses, reused between rows.
    poses: Vec<(Point, f64)>,
}

impl<C: Canvas> Recorder<C> {
    /// A recorder of a world with `size`, animated at `framerate` frames per simulated second
    /// (0: event instants only).
    pub fn new(mut canvas: C, size: &WorldSize, framerate: f64) -> Self {
        canvas.world(match size {
            WorldSize::Bounded { min, max } => Some((*min, *max)),
            WorldSize::Infinite => None,
        });
        let framerate = if framerate.is_finite() && framerate > 0.0 {
            framerate
        } else {
            0.0
        };
        Self {
            canvas,
            robots: Vec::new(),
            log: NekoLog::new(),
            framerate,
            frame: 0,
            period: if framerate > 0.0 {
                1.0 / framerate
            } else {
                1.0
            },
            next_sample: 1,
            metrics: Metrics::default(),
            recent: VecDeque::new(),
            flights: BTreeMap::new(),
            last_t: 0.0,
            poses: Vec::new(),
        }
    }

    /// Draws the world's obstacles (before the run).
    pub fn obstacles(&mut self, shapes: &[nekosim_actors::world::obstacle::Shape]) {
        if !shapes.is_empty() {
            let outlines: Vec<Vec<Point>> = shapes.iter().map(|s| s.outline()).collect();
            self.canvas.obstacles(&outlines);
        }
    }

    /// The canvas, e.g. to finish it.
    pub fn canvas_mut(&mut self) -> &mut C {
        &mut self.canvas
    }

    /// Gives the canvas back.
    pub fn into_canvas(self) -> C {
        self.canvas
    }

    /// Draws frames and metric samples strictly before `t`: everything at those instants has
    /// been recorded, and nothing at `t` yet.
    fn advance(&mut self, t: f64) {
        loop {
            let frame_t = (self.framerate > 0.0).then(|| self.frame as f64 / self.framerate);
            let sample_t = self.next_sample as f64 * self.period;
            let next = match frame_t {
                Some(f) if f <= sample_t => f,
                _ => sample_t,
            };
            if next >= t {
                break;
            }
            if frame_t == Some(next) {
                let at = Stamp { t: next, seq: None };
                let groups = self.robots.len().div_ceil(ROBOT_GROUP as usize);
                for g in 0..groups {
                    let first = g * ROBOT_GROUP as usize;
                    let last = (first + ROBOT_GROUP as usize).min(self.robots.len());
                    if self.robots[first..last].iter().any(RobotState::moving) {
                        self.commit(at, first as RobotId);
                    }
                }
                let layers: Vec<String> = self
                    .flights
                    .iter()
                    .filter(|(_, l)| l.iter().any(|(_, f)| f.arrive.is_some()))
                    .map(|(layer, _)| layer.clone())
                    .collect();
                for layer in layers {
                    self.draw_packets(at, &layer);
                }
                self.frame += 1;
            }
            if sample_t == next {
                self.sample(next);
            }
        }
    }

    fn sample(&mut self, t: f64) {
        self.metrics.events_per_second = self.event_rate(t);
        self.canvas.metrics(Stamp { t, seq: None }, &self.metrics);
        self.next_sample += 1;
    }

    /// Records per simulated second in the window `(t - EVENT_RATE_WINDOW, t]`.
    fn event_rate(&mut self, t: f64) -> f64 {
        while self
            .recent
            .front()
            .is_some_and(|&r| r <= t - EVENT_RATE_WINDOW)
        {
            self.recent.pop_front();
        }
        self.recent.len() as f64 / EVENT_RATE_WINDOW
    }

    /// Draws the animation up to `end` (the run's end time, frames at `end` included) and a
    /// last metric sample at `end` unless one falls there already.
    pub fn finish(&mut self, end: f64) {
        let end = if end.is_finite() {
            end.max(self.last_t)
        } else {
            self.last_t
        };
        self.advance(end + f64::EPSILON * end.abs().max(1.0));
        let last_sample = (self.next_sample - 1) as f64 * self.period;
        if last_sample < end || self.next_sample == 1 {
            self.metrics.events_per_second = self.event_rate(end);
            self.canvas
                .metrics(Stamp { t: end, seq: None }, &self.metrics);
        }
    }

    fn pos_now(&self, robot: RobotId, t: f64) -> Point {
        self.robots
            .get(robot as usize)
            .map_or(Point::origin(), |r| r.at(t).0)
    }

    /// A row of `robot`'s group at `at`: every robot of the group where the motion formulas
    /// put it then.
    fn commit(&mut self, at: Stamp, robot: RobotId) {
        let first = robot - robot % ROBOT_GROUP;
        let end = (first + ROBOT_GROUP).min(self.robots.len() as RobotId);
        self.poses.clear();
        self.poses.extend(
            self.robots[first as usize..end as usize]
                .iter()
                .map(|r| r.at(at.t)),
        );
        self.canvas.poses(at, first, &self.poses);
    }

    /// A new kinematic state: a leg of the path when the robot changed place.
    fn kinematic(&mut self, at: Stamp, robot: RobotId, state: Kinematics) {
        let Some(r) = self.robots.get_mut(robot as usize) else {
            return;
        };
        r.t = at.t;
        r.state = state;
        self.canvas.pose(at, robot, state.pos, state.angle);
        if r.corner != state.pos {
            let from = std::mem::replace(&mut r.corner, state.pos);
            self.canvas.leg(at, robot, from, state.pos);
        }
        // The robot's motion changed: where the messages on their way to it will find it.
        let r = &self.robots[robot as usize];
        let mut moved = Vec::new();
        for (layer, list) in &mut self.flights {
            let mut changed = false;
            for (_, f) in list.iter_mut().filter(|(_, f)| f.to == robot) {
                if let Some(t) = f.arrive {
                    let target = r.at(t).0;
                    changed |= target != f.target;
                    f.target = target;
                }
            }
            if changed {
                moved.push(layer.clone());
            }
        }
        for layer in moved {
            self.draw_messages(at, &layer);
        }
    }

    /// Each message in flight on `layer` as a packet along its arrow, at its progress at `t`
    /// (copies without an arrival time have none).
    fn draw_packets(&mut self, at: Stamp, layer: &str) {
        let packets: Vec<Point> = self
            .flights
            .get(layer)
            .map(|l| {
                l.iter()
                    .filter_map(|(_, f)| {
                        let arrive = f.arrive?;
                        let span = arrive - f.sent;
                        let k = if span > 0.0 {
                            ((at.t - f.sent) / span).clamp(0.0, 1.0)
                        } else {
                            1.0
                        };
                        Some(f.origin + (f.target - f.origin) * k)
                    })
                    .collect()
            })
            .unwrap_or_default();
        self.canvas
            .packets(at, layer, layer_colour(layer), &packets);
    }

    /// Draws one record. Records must come in processing order.
    pub fn record(&mut self, rec: &Record) {
        self.advance(rec.t);
        self.last_t = rec.t;
        self.recent.push_back(rec.t);
        let at = Stamp {
            t: rec.t,
            seq: Some(rec.seq),
        };
        match &rec.obs {
            Observation::Spawn {
                robot,
                pos,
                angle,
                radius,
            } => {
                let i = *robot as usize;
                let state = Kinematics::at_rest(nekosim_actors::world::motion::Pose {
                    pos: *pos,
                    angle: *angle,
                });
                let fresh = RobotState {
                    t: rec.t,
                    state,
                    radius: *radius,
                    crashed: false,
                    corner: *pos,
                    sensors: BTreeMap::new(),
                    querying: None,
                };
                if self.robots.len() <= i {
                    // Robots not spawned yet are drawn invisible (radius 0) where this one is.
                    let placeholder = RobotState {
                        radius: 0.0,
                        ..fresh.clone()
                    };
                    for j in self.robots.len()..i {
                        self.canvas.spawn(j as RobotId, 0.0, GREY);
                    }
                    self.robots.resize(i + 1, placeholder);
                }
                self.robots[i] = fresh;
                self.canvas.spawn(*robot, *radius, robot_colour(*robot));
                self.kinematic(at, *robot, state);
                self.commit(at, *robot);
            }
            Observation::MotionStep {
                robot,
                state,
                progress,
                ..
            } => {
                self.kinematic(at, *robot, *state);
                self.canvas.destination(*robot, Some(progress.dest));
                self.commit(at, *robot);
            }
            Observation::MotionFinish { robot, state, .. } => {
                self.kinematic(at, *robot, *state);
                self.canvas.destination(*robot, None);
                self.commit(at, *robot);
            }
            Observation::Crash { robot, state } => {
                self.kinematic(at, *robot, *state);
                if let Some(r) = self.robots.get_mut(*robot as usize) {
                    r.crashed = true;
                    if !std::mem::take(&mut r.sensors).is_empty() {
                        self.canvas.sensor(*robot, None);
                    }
                }
                self.canvas.colour(*robot, GREY);
                self.canvas.destination(*robot, None);
                self.commit(at, *robot);
                self.canvas.mark(at, *robot, Mark::Crash, "crash");
            }
            Observation::Collision {
                robot,
                other,
                pos,
                other_pos,
                ..
            } => {
                let point = match other {
                    Obstacle::Boundary | Obstacle::Object(_) => *other_pos,
                    Obstacle::Robot(o) => {
                        let r1 = self.robots.get(*robot as usize).map_or(1.0, |r| r.radius);
                        let r2 = self.robots.get(*o as usize).map_or(1.0, |r| r.radius);
                        pos + (other_pos - pos) * (r1 / (r1 + r2))
                    }
                };
                let label = format!("p{robot} × {other}");
                self.canvas
                    .collision(at, self.metrics.collisions, point, &label);
                self.metrics.collisions += 1;
            }
            Observation::SensorRequest { robot, query, plan } => {
                let Some(r) = self.robots.get_mut(*robot as usize) else {
                    return self.log_line(at, rec);
                };
                let (pos, _) = r.at(rec.t);
                // A range of centre distances is drawn as is; a range of free distances
                // (border to border) is wider by the robot's radius.
                let circle = |reach: Reach| match reach {
                    Reach::Centres(d) => d,
                    Reach::Borders(d) => r.radius + d,
                };
                match plan {
                    // A push sensor triggered by entries shows its range while armed.
                    Some(Plan {
                        trigger: Trigger::Entry { .. },
                        reach: Some(reach),
                    }) => {
                        let reach = circle(*reach);
                        r.sensors.insert(query.sensor, reach);
                        self.canvas.sensor(*robot, r.widest_sensor());
                        self.commit(at, *robot);
                    }
                    // A pull reading shows its range until the reply.
                    Some(Plan {
                        trigger: Trigger::Pull,
                        reach: Some(reach),
                    }) => {
                        let reach = circle(*reach);
                        self.canvas.query(at, *robot, Some((pos, reach)));
                        r.querying = Some(query.sensor);
                    }
                    Some(Plan {
                        trigger: Trigger::Off,
                        ..
                    })
                    | None
                        if r.sensors.remove(&query.sensor).is_some() =>
                    {
                        self.canvas.sensor(*robot, r.widest_sensor());
                        self.commit(at, *robot);
                    }
                    _ => {}
                }
            }
            Observation::SensorReply {
                robot,
                sensor,
                interrupt: false,
                ..
            } if self
                .robots
                .get(*robot as usize)
                .is_some_and(|r| r.querying == Some(*sensor)) =>
            {
                self.robots[*robot as usize].querying = None;
                self.canvas.query(at, *robot, None);
            }
            Observation::Send {
                robot,
                to,
                layer,
                msg,
                arrive,
            } => {
                let origin = self.pos_now(*robot, rec.t);
                let mut added = Vec::with_capacity(to.len());
                let text = msg.to_string();
                for (k, dest) in to.iter().enumerate() {
                    let arrive = arrive.get(k).copied().flatten();
                    let flight = Flight {
                        from: *robot,
                        to: *dest,
                        origin,
                        target: self.pos_now(*dest, arrive.unwrap_or(rec.t)),
                        label: type_word(&text).to_string(),
                        text: text.clone(),
                        sent: rec.t,
                        arrive,
                    };
                    added.push(((*robot, *dest, layer.clone(), msg.clone()), flight));
                }
                self.metrics.in_flight += added.len() as u64;
                self.flights.entry(layer.clone()).or_default().extend(added);
                self.draw_messages(at, layer);
            }
            Observation::Receive {
                robot,
                from,
                layer,
                msg,
            } => {
                if let Some(list) = self.flights.get_mut(layer) {
                    if let Some(i) = list.iter().position(|(k, _)| {
                        k.0 == *from && k.1 == *robot && &k.2 == layer && &k.3 == msg
                    }) {
                        let (_, flight) = list.remove(i);
                        self.metrics.in_flight -= 1;
                        self.draw_messages(at, layer);
                        self.canvas
                            .exchange(at, layer, layer_colour(layer), &flight);
                    }
                }
            }
            Observation::Deliver { robot, id, .. } => {
                self.metrics.deliveries += 1;
                self.canvas.mark(at, *robot, Mark::Deliver, &id.to_string());
            }
            Observation::Decide { robot, k, .. } => {
                self.canvas
                    .mark(at, *robot, Mark::Decide, &format!("decide #{k}"));
            }
            _ => {}
        }
        self.log_line(at, rec);
    }

    fn log_line(&mut self, at: Stamp, rec: &Record) {
        if let Some(line) = self.log.line(rec) {
            self.canvas.log(at, level_of(&rec.obs), &line);
        }
    }

    fn draw_messages(&mut self, at: Stamp, layer: &str) {
        let flights: Vec<Flight> = self
            .flights
            .get(layer)
            .map(|l| l.iter().map(|(_, f)| f.clone()).collect())
            .unwrap_or_default();
        self.canvas
            .messages(at, layer, layer_colour(layer), &flights);
        self.draw_packets(at, layer);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nekosim_actors::world::motion::{Progress, StepKind};

    /// Remembers every call as text.
    #[derive(Debug, Default)]
    struct Tape(Vec<String>);

    fn s(at: Stamp) -> String {
        match at.seq {
            Some(q) => format!("{}#{q}", at.t),
            None => format!("{}", at.t),
        }
    }

    impl Canvas for Tape {
        fn world(&mut self, bounds: Option<(Point, Point)>) {
            self.0.push(format!("world {bounds:?}"));
        }
        fn spawn(&mut self, robot: RobotId, radius: f64, _: Rgb) {
            self.0.push(format!("spawn p{robot} r{radius}"));
        }
        fn colour(&mut self, robot: RobotId, c: Rgb) {
            self.0.push(format!("colour p{robot} {c:?}"));
        }
        fn leg(&mut self, at: Stamp, robot: RobotId, from: Point, to: Point) {
            self.0.push(format!(
                "{} leg p{robot} {} {} -> {} {}",
                s(at),
                from.x,
                from.y,
                to.x,
                to.y
            ));
        }
        fn destination(&mut self, robot: RobotId, dest: Option<Point>) {
            self.0
                .push(format!("dest p{robot} {:?}", dest.map(|d| (d.x, d.y))));
        }
        fn sensor(&mut self, robot: RobotId, reach: Option<f64>) {
            self.0.push(format!("sensor p{robot} {reach:?}"));
        }
        fn pose(&mut self, at: Stamp, robot: RobotId, pos: Point, angle: f64) {
            self.0.push(format!(
                "{} pose p{robot} {} {} {angle}",
                s(at),
                pos.x,
                pos.y
            ));
        }
        fn poses(&mut self, at: Stamp, first: RobotId, poses: &[(Point, f64)]) {
            let p: Vec<String> = poses
                .iter()
                .map(|(p, a)| format!("{} {} {a}", p.x, p.y))
                .collect();
            self.0
                .push(format!("{} poses g{first} [{}]", s(at), p.join(", ")));
        }
        fn query(&mut self, at: Stamp, robot: RobotId, c: Option<(Point, f64)>) {
            self.0
                .push(format!("{} query p{robot} {:?}", s(at), c.map(|c| c.1)));
        }
        fn collision(&mut self, at: Stamp, k: u64, p: Point, label: &str) {
            self.0
                .push(format!("{} collision {k} {} {} {label}", s(at), p.x, p.y));
        }
        fn messages(&mut self, at: Stamp, layer: &str, _: Rgb, flights: &[Flight]) {
            self.0
                .push(format!("{} messages {layer} {}", s(at), flights.len()));
        }
        fn log(&mut self, _: Stamp, _: Level, _: &str) {}
        fn metrics(&mut self, at: Stamp, m: &Metrics) {
            self.0.push(format!(
                "{} metrics c{} f{} d{} e{}",
                s(at),
                m.collisions,
                m.in_flight,
                m.deliveries,
                m.events_per_second
            ));
        }
    }

    fn rec(t: f64, seq: u64, obs: Observation) -> Record {
        Record { t, seq, obs }
    }

    fn moving(x: f64, vx: f64) -> Kinematics {
        Kinematics {
            pos: Point::new(x, 0.0),
            angle: 0.0,
            vel: Vector::new(vx, 0.0),
            omega: 0.0,
        }
    }

    #[test]
    fn frames_follow_the_motion_formulas_and_stop_when_the_robot_rests() {
        let bounds = WorldSize::Bounded {
            min: Point::new(0.0, 0.0),
            max: Point::new(10.0, 10.0),
        };
        let mut r = Recorder::new(Tape::default(), &bounds, 2.0);
        r.record(&rec(
            0.0,
            0,
            Observation::Spawn {
                robot: 0,
                pos: Point::new(1.0, 0.0),
                angle: 0.0,
                radius: 0.5,
            },
        ));
        r.record(&rec(
            0.0,
            1,
            Observation::MotionStep {
                robot: 0,
                step: StepKind::StartForward,
                state: moving(1.0, 2.0),
                progress: Progress {
                    dest: Point::new(4.0, 0.0),
                    ..Progress::default()
                },
            },
        ));
        r.record(&rec(
            1.5,
            2,
            Observation::MotionFinish {
                robot: 0,
                state: moving(4.0, 0.0),
                outcome: nekosim_actors::world::MotionOutcome::Arrived,
            },
        ));
        r.finish(2.0);
        let tape = r.into_canvas().0;
        assert_eq!(
            tape,
            [
                "world Some(([0.0, 0.0], [10.0, 10.0]))",
                "spawn p0 r0.5",
                "0#0 pose p0 1 0 0",
                "0#0 poses g0 [1 0 0]",
                // Starting on the spot: no leg, a destination.
                "0#1 pose p0 1 0 0",
                "dest p0 Some((4.0, 0.0))",
                "0#1 poses g0 [1 0 0]",
                // Frames at 0, 0.5 and 1 s: x = 1 + 2 t; metrics every frame period.
                "0 poses g0 [1 0 0]",
                "0.5 poses g0 [2 0 0]",
                // Events per second over the last second: 2 records at 0 s, then 1 at 1.5 s.
                "0.5 metrics c0 f0 d0 e2",
                "1 poses g0 [3 0 0]",
                "1 metrics c0 f0 d0 e0",
                "1.5#2 pose p0 4 0 0",
                "1.5#2 leg p0 1 0 -> 4 0",
                "dest p0 None",
                "1.5#2 poses g0 [4 0 0]",
                // At rest from 1.5 s on: no more frames, only metric samples.
                "1.5 metrics c0 f0 d0 e1",
                "2 metrics c0 f0 d0 e1",
            ]
        );
    }

    #[test]
    fn collisions_mark_the_contact_point_and_messages_fly_until_received() {
        let mut r = Recorder::new(Tape::default(), &WorldSize::Infinite, 0.0);
        for (i, x) in [(0u32, 0.0), (1, 3.0)] {
            r.record(&rec(
                0.0,
                u64::from(i),
                Observation::Spawn {
                    robot: i,
                    pos: Point::new(x, 0.0),
                    angle: 0.0,
                    radius: if i == 0 { 1.0 } else { 2.0 },
                },
            ));
        }
        r.record(&rec(
            0.5,
            2,
            Observation::Collision {
                robot: 0,
                other: Obstacle::Robot(1),
                pos: Point::new(0.0, 0.0),
                angle: 0.0,
                other_pos: Point::new(3.0, 0.0),
            },
        ));
        let msg =
            nekosim_protocols::AppMsg::new("HELLO", nekosim_protocols::Content::None).payload();
        r.record(&rec(
            0.6,
            3,
            Observation::Send {
                robot: 0,
                to: vec![1],
                layer: "app".into(),
                msg: msg.clone(),
                arrive: vec![Some(1.6)],
            },
        ));
        r.record(&rec(
            1.6,
            4,
            Observation::Receive {
                robot: 1,
                from: 0,
                layer: "app".into(),
                msg,
            },
        ));
        let tape = r.into_canvas().0;
        let drawn: Vec<&str> = tape
            .iter()
            .map(String::as_str)
            .filter(|l| l.contains("collision") || l.contains("messages"))
            .collect();
        assert_eq!(
            drawn,
            [
                // One third of the way: radius 1 of a 1 + 2 reach.
                "0.5#2 collision 0 1 0 p0 × p1",
                "0.6#3 messages app 1",
                "1.6#4 messages app 0",
            ]
        );
    }
}
