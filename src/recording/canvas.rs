//! What a recording draws on: the [`Canvas`] trait, one method per entity family of
//! docs/visualization.md, and the values its methods take (instants, message copies, marks,
//! log levels, figures). The [`super::Recorder`] calls it; [`super::rerun_canvas`] writes
//! Rerun entities, and tests implement it to see what would be drawn.

use nekosim_actors::world::geometry::Point;
use nekosim_actors::world::observation::Observation;
use nekosim_actors::world::RobotId;

use super::colour::Rgb;

/// When a drawing holds: a simulated instant [s], and the trace `seq` of the record that caused
/// it (`None` for animation frames and metric samples, which lie between events).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stamp {
    /// Simulated time [s].
    pub t: f64,
    pub seq: Option<u64>,
}

/// Figures sampled over the run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Metrics {
    /// Collision records so far.
    pub collisions: u64,
    /// Message copies on their way: sent, not lost by the network, and neither received nor
    /// past their arrival time (a copy that reaches a crashed robot is received by no one).
    pub in_flight: u64,
    /// Broadcast deliveries to algorithms so far.
    pub deliveries: u64,
    /// Records per simulated second over the last [`super::EVENT_RATE_WINDOW`] (a sliding
    /// window).
    pub events_per_second: f64,
}

/// A message copy: from the sender's position to the receiver's, both taken when it was sent.
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
    /// When it arrives, as the network decided at the send (`None`: unknown, or lost). The
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
    /// `at` (a viewer shows the legs of the last [`super::TRAIL_SECONDS`]).
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
    /// Every copy the network lost on `layer` in the last [`super::LOST_SECONDS`], drawn in
    /// `colour` as lost: it never flies, so it gets no arrow, only a mark that it was sent.
    fn lost(&mut self, _at: Stamp, _layer: &str, _colour: Rgb, _lost: &[Flight]) {}
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
    /// A line of the log at an instant the recording marks (where a replayed lasso's stem
    /// ends and its cycle's repetitions begin and end), so the instant is on the timeline.
    fn milestone(&mut self, _at: Stamp, _text: &str) {}
    /// The messages in flight on `layer` as packets along their arrows, at `at`.
    fn packets(&mut self, _at: Stamp, _layer: &str, _colour: Rgb, _packets: &[Point]) {}
    /// The run's figures.
    fn metrics(&mut self, at: Stamp, m: &Metrics);
    /// A Look-Compute-Move robot's last snapshot, from where it looked (`from`) to each robot
    /// it saw, labelled with its current phase, until its cycle ends (`None`).
    fn look(&mut self, _at: Stamp, _robot: RobotId, _sight: Option<Sight<'_>>) {}
}

/// What a Look-Compute-Move robot saw and which phase it is in ([`Canvas::look`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sight<'a> {
    pub from: Point,
    pub seen: &'a [Point],
    /// `look`, `compute` or `move`.
    pub phase: &'static str,
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
