//! The recorder: turns a run's [`Record`]s into drawings on a [`Canvas`], keeping the little
//! state a drawing needs (each robot's kinematic state, last corner and sensors, the message
//! copies in flight and lost) and sampling the animation frames and the metrics. The module
//! doc of [`super`] says what it draws and why it is exact.

use std::collections::{BTreeMap, VecDeque};

use nekosim_actors::world::geometry::{normalize_deg, Point, Vector};
use nekosim_actors::world::motion::Kinematics;
use nekosim_actors::world::observation::{Observation, Record};
use nekosim_actors::world::sensor::{Plan, Reach, SensorKind, Trigger};
use nekosim_actors::world::virtual_world::WorldSize;
use nekosim_actors::world::{Obstacle, RobotId};
use nekosim_protocols::codec::type_word;

use super::canvas::{level_of, Canvas, Flight, Mark, Metrics, Sight, Stamp, ROBOT_GROUP};
use super::colour::{layer_colour, light_colour, robot_colour, GREY};
use super::flights::Flights;
use super::EVENT_RATE_WINDOW;
use crate::log::NekoLog;
use nekosim_actors::lcm::record::LcmRecord;

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
    /// Copies in flight and copies lost recently.
    flights: Flights,
    last_t: f64,
    /// A group's poses, reused between rows.
    poses: Vec<(Point, f64)>,
    /// Each Look-Compute-Move robot's snapshot in its current cycle.
    sight: BTreeMap<RobotId, (Point, Vec<Point>)>,
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
            flights: Flights::default(),
            last_t: 0.0,
            poses: Vec::new(),
            sight: BTreeMap::new(),
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

    /// Draws what happens between records up to `t`: animation frames and metric samples
    /// strictly before `t` (everything at those instants has been recorded, and nothing at
    /// `t` yet), the ends of flights nobody received, due strictly before `t` (a receive at
    /// `t` may still end one), and lost copies that stop being drawn at or before `t`.
    fn advance(&mut self, t: f64) {
        loop {
            let frame_t = (self.framerate > 0.0).then(|| self.frame as f64 / self.framerate);
            let sample_t = self.next_sample as f64 * self.period;
            let due = self.flights.next_due().filter(|d| *d < t);
            let expiry = self.flights.next_expiry().filter(|e| *e <= t);
            let next = [frame_t, Some(sample_t), due, expiry]
                .into_iter()
                .flatten()
                .filter(|i| *i < t || Some(*i) == expiry)
                .min_by(f64::total_cmp);
            let Some(next) = next else { break };
            let between = Stamp { t: next, seq: None };
            if due == Some(next) {
                for layer in self.flights.retire_due(next) {
                    self.draw_messages(between, &layer);
                }
            }
            if expiry == Some(next) {
                for layer in self.flights.expire_lost(next) {
                    self.draw_lost(between, &layer);
                }
            }
            // An expiry may fall at `t`; frames and samples there wait for its records.
            if frame_t == Some(next) && next < t {
                let groups = self.robots.len().div_ceil(ROBOT_GROUP as usize);
                for g in 0..groups {
                    let first = g * ROBOT_GROUP as usize;
                    let last = (first + ROBOT_GROUP as usize).min(self.robots.len());
                    if self.robots[first..last].iter().any(RobotState::moving) {
                        self.commit(between, first as RobotId);
                    }
                }
                for layer in self.flights.moving_layers() {
                    self.draw_packets(between, &layer);
                }
                self.frame += 1;
            }
            if sample_t == next && next < t {
                self.sample(next);
            }
        }
    }

    fn sample(&mut self, t: f64) {
        self.metrics.events_per_second = self.event_rate(t);
        self.metrics.in_flight = self.flights.in_flight();
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
            self.metrics.in_flight = self.flights.in_flight();
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
        for layer in self.flights.retarget(robot, |t| r.at(t).0) {
            self.draw_messages(at, &layer);
        }
    }

    /// Each message in flight on `layer` as a packet along its arrow, at its progress at `t`
    /// (copies without an arrival time have none).
    fn draw_packets(&mut self, at: Stamp, layer: &str) {
        let packets: Vec<Point> = self
            .flights
            .flying(layer)
            .filter_map(|f| {
                let arrive = f.arrive?;
                let span = arrive - f.sent;
                let k = if span > 0.0 {
                    ((at.t - f.sent) / span).clamp(0.0, 1.0)
                } else {
                    1.0
                };
                Some(f.origin + (f.target - f.origin) * k)
            })
            .collect();
        self.canvas
            .packets(at, layer, layer_colour(layer), &packets);
    }

    /// Draws one record. Records must come in processing order.
    pub fn record(&mut self, rec: &Record) {
        self.record_dropping(rec, &[]);
    }

    /// Draws one record, a send of which the network drops the copies to `to[k]` where
    /// `dropped[k]` holds, beside those its `arrive` says it drops: a model checker's path
    /// drops a copy at a later step, and a dropped copy is drawn as lost from its send and
    /// never counts as in flight, as in a run. Records must come in processing order.
    pub fn record_dropping(&mut self, rec: &Record, dropped: &[bool]) {
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
                let text = msg.to_string();
                let label = type_word(&text).to_string();
                let (mut flying, mut lost) = (false, false);
                for (k, dest) in to.iter().enumerate() {
                    // No arrival times at all: unknown (a model checker's path), dropped
                    // where `dropped` says; a copy without one: the network dropped it.
                    let (arrive, dropped) = match arrive.get(k) {
                        Some(Some(t)) => (Some(*t), false),
                        Some(None) => (None, true),
                        None => (None, dropped.get(k).copied().unwrap_or(false)),
                    };
                    let flight = Flight {
                        from: *robot,
                        to: *dest,
                        origin,
                        target: self.pos_now(*dest, arrive.unwrap_or(rec.t)),
                        label: label.clone(),
                        text: text.clone(),
                        sent: rec.t,
                        arrive,
                    };
                    self.flights.send(layer, msg, flight, dropped);
                    flying |= !dropped;
                    lost |= dropped;
                }
                if flying {
                    self.draw_messages(at, layer);
                }
                if lost {
                    self.draw_lost(at, layer);
                }
            }
            Observation::Receive {
                robot,
                from,
                layer,
                msg,
            } => {
                if let Some(flight) = self.flights.receive(layer, *from, *robot, msg, rec.t) {
                    self.draw_messages(at, layer);
                    self.canvas
                        .exchange(at, layer, layer_colour(layer), &flight);
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
            Observation::Light {
                robot,
                light,
                pending,
            } => {
                let crashed = self.robots.get(*robot as usize).is_some_and(|r| r.crashed);
                if !crashed {
                    self.canvas.colour(*robot, light_colour(*light, *pending));
                    self.commit(at, *robot);
                }
            }
            Observation::Lcm(r) => self.lcm(at, r),
            _ => {}
        }
        self.log_line(at, rec);
    }

    /// A Look-Compute-Move robot's phases: its snapshot drawn from the Look to the end of its
    /// cycle, labelled with the phase, and its destination from the Compute on.
    fn lcm(&mut self, at: Stamp, r: &LcmRecord) {
        let robot = r.robot();
        match r {
            LcmRecord::Look { me, seen, .. } => {
                let seen: Vec<Point> = seen.iter().map(|s| s.at).collect();
                self.sight.insert(robot, (*me, seen));
                self.draw_sight(at, robot, "look");
            }
            LcmRecord::Compute { to, .. } => {
                self.canvas.destination(robot, *to);
                self.draw_sight(at, robot, "compute");
            }
            LcmRecord::Move { .. } => self.draw_sight(at, robot, "move"),
            LcmRecord::Wait { .. } => {
                self.sight.remove(&robot);
                self.canvas.destination(robot, None);
                self.canvas.look(at, robot, None);
            }
            LcmRecord::Activate { .. } => {}
        }
    }

    fn draw_sight(&mut self, at: Stamp, robot: RobotId, phase: &'static str) {
        if let Some((from, seen)) = self.sight.get(&robot) {
            self.canvas.look(
                at,
                robot,
                Some(Sight {
                    from: *from,
                    seen,
                    phase,
                }),
            );
        }
    }

    fn log_line(&mut self, at: Stamp, rec: &Record) {
        if let Some(line) = self.log.line(rec) {
            self.canvas.log(at, level_of(&rec.obs), &line);
        }
    }

    fn draw_messages(&mut self, at: Stamp, layer: &str) {
        let flights: Vec<Flight> = self.flights.flying(layer).cloned().collect();
        self.canvas
            .messages(at, layer, layer_colour(layer), &flights);
        self.draw_packets(at, layer);
    }

    fn draw_lost(&mut self, at: Stamp, layer: &str) {
        let lost: Vec<Flight> = self.flights.lost(layer).cloned().collect();
        self.canvas.lost(at, layer, layer_colour(layer), &lost);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::recording::canvas::Level;
    use crate::recording::colour::Rgb;
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
        fn lost(&mut self, at: Stamp, layer: &str, _: Rgb, lost: &[Flight]) {
            self.0
                .push(format!("{} lost {layer} {}", s(at), lost.len()));
        }
        fn exchange(&mut self, at: Stamp, layer: &str, _: Rgb, f: &Flight) {
            self.0.push(format!(
                "{} exchange {layer} p{} -> p{} sent {}",
                s(at),
                f.from,
                f.to,
                f.sent
            ));
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

    /// Robots `0..n` at rest on the x axis, 10 apart, spawned at 0.
    fn three_robots(r: &mut Recorder<Tape>) {
        for i in 0..3u32 {
            r.record(&rec(
                0.0,
                u64::from(i),
                Observation::Spawn {
                    robot: i,
                    pos: Point::new(10.0 * f64::from(i), 0.0),
                    angle: 0.0,
                    radius: 1.0,
                },
            ));
        }
    }

    fn hello() -> nekosim_protocols::Payload {
        nekosim_protocols::AppMsg::new("HELLO", nekosim_protocols::Content::None).payload()
    }

    fn send(t: f64, seq: u64, to: Vec<RobotId>, arrive: Vec<Option<f64>>) -> Record {
        rec(
            t,
            seq,
            Observation::Send {
                robot: 0,
                to,
                layer: "app".into(),
                msg: hello(),
                arrive,
            },
        )
    }

    fn receive(t: f64, seq: u64, robot: RobotId) -> Record {
        rec(
            t,
            seq,
            Observation::Receive {
                robot,
                from: 0,
                layer: "app".into(),
                msg: hello(),
            },
        )
    }

    /// The lines of `tape` about messages, lost copies, exchanges and the figures.
    fn traffic(tape: &[String]) -> Vec<&str> {
        tape.iter()
            .map(String::as_str)
            .filter(|l| {
                ["messages", "lost", "exchange", "metrics"]
                    .iter()
                    .any(|w| l.contains(w))
            })
            .collect()
    }

    #[test]
    fn lost_copies_never_fly_and_unreceived_copies_land_at_their_arrival() {
        let mut r = Recorder::new(Tape::default(), &WorldSize::Infinite, 0.0);
        three_robots(&mut r);
        // To p1, arriving at 1.5, which p1 never receives (it crashed, say); to p2, lost.
        r.record(&send(0.5, 3, vec![1, 2], vec![Some(1.5), None]));
        r.record(&rec(
            3.0,
            4,
            Observation::Log {
                robot: 0,
                text: "later".into(),
            },
        ));
        r.finish(3.0);
        let tape = r.into_canvas().0;
        assert_eq!(
            traffic(&tape),
            [
                "0.5#3 messages app 1",
                "0.5#3 lost app 1",
                // One copy in flight: the lost one never counts.
                "1 metrics c0 f1 d0 e1",
                // Its arrival time passed without a receive: it has landed.
                "1.5 messages app 0",
                "2 metrics c0 f0 d0 e0",
                // The lost copy is drawn for LOST_SECONDS after its send.
                "2.5 lost app 0",
                "3 metrics c0 f0 d0 e1",
            ]
        );
    }

    #[test]
    fn a_receive_ends_the_copy_that_arrives_then() {
        let mut r = Recorder::new(Tape::default(), &WorldSize::Infinite, 0.0);
        three_robots(&mut r);
        // Two copies of one message from p0 to p1; the second overtakes the first.
        r.record(&send(0.1, 3, vec![1], vec![Some(2.0)]));
        r.record(&send(0.2, 4, vec![1], vec![Some(1.0)]));
        r.record(&receive(1.0, 5, 1));
        r.record(&receive(2.0, 6, 1));
        r.finish(2.0);
        let tape = r.into_canvas().0;
        assert_eq!(
            traffic(&tape),
            [
                "0.1#3 messages app 1",
                "0.2#4 messages app 2",
                "1#5 messages app 1",
                "1#5 exchange app p0 -> p1 sent 0.2",
                "1 metrics c0 f1 d0 e3",
                "2#6 messages app 0",
                "2#6 exchange app p0 -> p1 sent 0.1",
                "2 metrics c0 f0 d0 e1",
            ]
        );
    }
}
