//! The virtual world (seed 3.2 and 4.2.4) and the motion and sensor managers' logic over it
//! (seed 4.2.3, fig. 4.4 and 4.5).
//!
//! The virtual world knows every robot's current motion, so any robot's exact state at any
//! instant comes from the motion formulas. It is reached only through the managers: the motion
//! manager turns requests into motion events and predicts collisions; the sensor manager turns
//! requests into sensor events and re-arms push sensors. Handlers write their consequences into
//! an [`Outbox`] (effects as data), which the scheduler carries out.
//!
//! Invalidation is cheap and local: each robot keeps the ids of its own conditional events
//! (motion steps, cell crossings, boundary contact) and, per partner robot, of the pair events
//! (collision, sensor entries) predicted under the current motions. A change of path cancels
//! exactly those and re-predicts against the 3×3 block of cells around the robot.

use std::collections::BTreeMap;

use super::collision::{predict_cell_exit, predict_contact, predict_entry, predict_wall, Track};
use super::event::{EventClass, EventId, Notice, Outbox, Payload, Target};
use super::geometry::Point;
use super::grid::{Cell, Grid};
use super::motion::{Kinematics, Motion, MotionPattern, MotionStep, Pose};
use super::observation::Observation;
use super::sensor::{SensorKind, SensorQuery, SensorValue, Sensors, WorldView};
use super::{MotionOutcome, Obstacle, RobotId};

/// The world's extent (seed 3.2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum WorldSize {
    /// The rectangle `[min, max]`; its boundary stops robots like a wall.
    Bounded {
        min: Point,
        max: Point,
    },
    Infinite,
}

impl WorldSize {
    /// A `width` × `height` world with its lower-left corner at the origin: `[0, w] × [0, h]`
    /// (the seed's coordinates).
    pub fn from_origin(width: f64, height: f64) -> Self {
        WorldSize::Bounded {
            min: Point::new(0.0, 0.0),
            max: Point::new(width, height),
        }
    }

    /// A `width` × `height` world centred on the origin.
    pub fn centred(width: f64, height: f64) -> Self {
        WorldSize::Bounded {
            min: Point::new(-width / 2.0, -height / 2.0),
            max: Point::new(width / 2.0, height / 2.0),
        }
    }
}

/// Settings of a world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldConfig {
    pub size: WorldSize,
    /// No robot-robot collisions at all (seed 6.1). The boundary still holds robots in.
    pub ghost_mode: bool,
    /// Width of the spatial index's cells [units]; by default four times the largest radius.
    /// Raised automatically to the largest interaction distance.
    pub cell_size: Option<f64>,
}

/// Why a world cannot be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum WorldError {
    #[error("robot {robot}: radius must be a finite number > 0, got {radius}")]
    BadRadius { robot: RobotId, radius: f64 },
    #[error("robot {robot}: position and angle must be finite")]
    NotFinite { robot: RobotId },
    #[error("robot {robot} at ({x}, {y}) with radius {radius} is not inside the world [{min_x}, {max_x}] x [{min_y}, {max_y}]")]
    OutOfWorld {
        robot: RobotId,
        x: f64,
        y: f64,
        radius: f64,
        min_x: f64,
        min_y: f64,
        max_x: f64,
        max_y: f64,
    },
    #[error("robots {a} and {b} overlap at their born points")]
    Overlap { a: RobotId, b: RobotId },
    #[error("world width and height must be finite numbers > 0")]
    BadSize,
}

/// A robot's initial settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RobotSpec {
    /// Radius [units].
    pub radius: f64,
    pub pose: Pose,
}

#[derive(Clone, Copy, Debug)]
struct PushProximity {
    /// Free distance that triggers [units].
    range: f64,
    /// Quiet period after an interrupt [s].
    interval: f64,
    quiet_until: f64,
    generation: u64,
    pending: bool,
}

#[derive(Debug)]
struct RobotState {
    radius: f64,
    /// Pose when there is no motion in progress.
    rest: Pose,
    motion: Option<Box<dyn MotionPattern>>,
    ticket: u64,
    steps: Vec<MotionStep>,
    /// Index of the next step event of the current motion.
    next_step: usize,
    /// Own conditional events: motion steps, cell crossings, boundary contact.
    own: Vec<EventId>,
    /// Partner -> pair events predicted under the current motions of both.
    pairs: BTreeMap<RobotId, Vec<EventId>>,
    cell: Cell,
    push: Option<PushProximity>,
    contact: bool,
    /// Active registered push sensors: query (RON) and activation generation.
    user_push: BTreeMap<&'static str, (String, u64)>,
    crashed: bool,
}

/// The virtual world: all robots' states and the spatial index.
#[derive(Debug)]
pub struct VirtualWorld {
    cfg: WorldConfig,
    /// Registered sensors (beside the built-in ones).
    sensors: std::sync::Arc<Sensors>,
    /// Activations of registered push sensors so far (tells a stale re-sense apart).
    user_generation: u64,
    robots: Vec<RobotState>,
    grid: Grid,
    max_radius: f64,
}

impl VirtualWorld {
    /// Builds a world with robots `0..specs.len()` at their born points.
    pub fn new(cfg: WorldConfig, specs: &[RobotSpec]) -> Result<Self, WorldError> {
        if let WorldSize::Bounded { min, max } = cfg.size {
            let ok = [min.x, min.y, max.x, max.y].iter().all(|v| v.is_finite());
            if !(ok && max.x > min.x && max.y > min.y) {
                return Err(WorldError::BadSize);
            }
        }
        let mut max_radius: f64 = 0.0;
        for (i, s) in specs.iter().enumerate() {
            let robot = i as RobotId;
            if !(s.radius.is_finite() && s.radius > 0.0) {
                return Err(WorldError::BadRadius {
                    robot,
                    radius: s.radius,
                });
            }
            if !(s.pose.pos.x.is_finite() && s.pose.pos.y.is_finite() && s.pose.angle.is_finite()) {
                return Err(WorldError::NotFinite { robot });
            }
            if let WorldSize::Bounded { min, max } = cfg.size {
                let p = s.pose.pos;
                let r = s.radius;
                if p.x < min.x + r || p.y < min.y + r || p.x > max.x - r || p.y > max.y - r {
                    return Err(WorldError::OutOfWorld {
                        robot,
                        x: p.x,
                        y: p.y,
                        radius: r,
                        min_x: min.x,
                        min_y: min.y,
                        max_x: max.x,
                        max_y: max.y,
                    });
                }
            }
            max_radius = max_radius.max(s.radius);
        }
        let size = cfg
            .cell_size
            .unwrap_or(4.0 * max_radius)
            .max(2.0 * max_radius * (1.0 + 1e-9))
            .max(1e-9);
        let mut world = Self {
            cfg,
            sensors: Default::default(),
            user_generation: 0,
            robots: Vec::with_capacity(specs.len()),
            grid: Grid::new(size),
            max_radius,
        };
        for (i, s) in specs.iter().enumerate() {
            let id = i as RobotId;
            let cell = world.grid.cell_of(s.pose.pos);
            for other in world.grid.neighbours(cell) {
                let o = &world.robots[other as usize];
                if (o.rest.pos - s.pose.pos).norm() < o.radius + s.radius {
                    return Err(WorldError::Overlap { a: other, b: id });
                }
            }
            world.grid.insert(id, cell);
            world.robots.push(RobotState {
                radius: s.radius,
                rest: Pose {
                    pos: s.pose.pos,
                    angle: super::geometry::normalize_deg(s.pose.angle),
                },
                motion: None,
                ticket: 0,
                steps: Vec::new(),
                next_step: 0,
                own: Vec::new(),
                pairs: BTreeMap::new(),
                cell,
                push: None,
                contact: false,
                user_push: BTreeMap::new(),
                crashed: false,
            });
        }
        Ok(world)
    }

    /// Number of robots.
    pub fn len(&self) -> usize {
        self.robots.len()
    }

    /// Whether the world has no robot.
    pub fn is_empty(&self) -> bool {
        self.robots.is_empty()
    }

    /// The world's settings.
    pub fn config(&self) -> &WorldConfig {
        &self.cfg
    }

    /// A robot's radius [units].
    pub fn radius(&self, id: RobotId) -> f64 {
        self.robots[id as usize].radius
    }

    /// Width of the spatial index's cells [units].
    pub fn cell_size(&self) -> f64 {
        self.grid.cell_size()
    }

    fn track(&self, id: RobotId) -> Track<'_> {
        let r = &self.robots[id as usize];
        Track {
            motion: r.motion.as_deref(),
            rest: r.rest.pos,
        }
    }

    /// The exact kinematic state of a robot at `t` (not before its current motion started).
    pub fn state_at(&self, id: RobotId, t: f64) -> Kinematics {
        let r = &self.robots[id as usize];
        match &r.motion {
            Some(m) => m.state_at(t),
            None => Kinematics::at_rest(r.rest),
        }
    }

    /// Every robot's position at `t`, by id.
    pub fn positions_at(&self, t: f64) -> Vec<(RobotId, Point)> {
        (0..self.robots.len() as RobotId)
            .map(|id| (id, self.state_at(id, t).pos))
            .collect()
    }

    /// Robots other than `me` whose centres are within `reach` of `centre` at `t`, by id, with
    /// their positions and centre distances.
    pub fn within(
        &self,
        me: RobotId,
        centre: Point,
        reach: f64,
        t: f64,
    ) -> Vec<(RobotId, Point, f64)> {
        let m = Point::new(reach, reach).coords;
        let candidates = self
            .grid
            .in_box(centre - m, centre + m, self.robots.len().max(9))
            .unwrap_or_else(|| (0..self.robots.len() as RobotId).collect());
        let mut out: Vec<_> = candidates
            .into_iter()
            .filter(|&id| id != me)
            .filter_map(|id| {
                let p = self.state_at(id, t).pos;
                let d = (p - centre).norm();
                (d <= reach).then_some((id, p, d))
            })
            .collect();
        out.sort_by_key(|x| x.0);
        out
    }

    /// Setup at t = 0: records the spawns and starts every algorithm.
    pub fn start(&self, out: &mut Outbox) {
        for (i, r) in self.robots.iter().enumerate() {
            out.record(Observation::Spawn {
                robot: i as RobotId,
                pos: r.rest.pos,
                angle: r.rest.angle,
                radius: r.radius,
            });
        }
        for i in 0..self.robots.len() {
            out.notify(i as RobotId, Notice::Start);
        }
    }

    // ----- invalidation and prediction -------------------------------------------------

    fn cancel_pairs(&mut self, id: RobotId, out: &mut Outbox) {
        let pairs = std::mem::take(&mut self.robots[id as usize].pairs);
        for (p, ids) in pairs {
            ids.into_iter().for_each(|e| out.cancel(e));
            self.robots[p as usize].pairs.remove(&id);
        }
    }

    /// Cancels every conditional event that depends on `id`'s path.
    fn invalidate(&mut self, id: RobotId, out: &mut Outbox) {
        let own = std::mem::take(&mut self.robots[id as usize].own);
        own.into_iter().for_each(|e| out.cancel(e));
        self.cancel_pairs(id, out);
    }

    fn predict_pair(&mut self, a: RobotId, b: RobotId, out: &mut Outbox) {
        let now = out.now();
        let (ta, tb) = (self.track(a), self.track(b));
        let (ra, rb) = (self.radius(a), self.radius(b));
        let mut ids = Vec::new();
        if !self.cfg.ghost_mode {
            if let Some(t) = predict_contact(&ta, &tb, ra + rb, now) {
                ids.push(out.schedule(
                    t,
                    Target::MotionManager,
                    EventClass::Conditional,
                    [Some(a), Some(b)],
                    Payload::Collision {
                        a,
                        b: Obstacle::Robot(b),
                        contact: None,
                    },
                ));
            }
        }
        for (s, o, ts, to) in [(a, b, &ta, &tb), (b, a, &tb, &ta)] {
            if let Some(push) = self.robots[s as usize].push {
                if let Some(t) = predict_entry(ts, to, push.range + ra + rb, now) {
                    ids.push(out.schedule(
                        t,
                        Target::SensorManager,
                        EventClass::Conditional,
                        [Some(s), Some(o)],
                        Payload::ProximityEntry { robot: s, other: o },
                    ));
                }
            }
        }
        self.robots[a as usize].pairs.insert(b, ids.clone());
        self.robots[b as usize].pairs.insert(a, ids);
    }

    /// Predicts `id` against every neighbour it has no prediction with yet.
    fn predict_neighbours(&mut self, id: RobotId, out: &mut Outbox) {
        let cell = self.robots[id as usize].cell;
        let fresh: Vec<RobotId> = self
            .grid
            .neighbours(cell)
            .filter(|&o| o != id && !self.robots[id as usize].pairs.contains_key(&o))
            .collect();
        for o in fresh {
            self.predict_pair(id, o, out);
        }
    }

    fn predict_crossing(&mut self, id: RobotId, out: &mut Outbox) {
        let now = out.now();
        let cell = self.robots[id as usize].cell;
        let lo = self.grid.lower_corner(cell);
        if let Some((t, offset)) =
            predict_cell_exit(&self.track(id), lo, self.grid.cell_size(), now)
        {
            let e = out.schedule(
                t,
                Target::MotionManager,
                EventClass::Conditional,
                [Some(id), None],
                Payload::CellCrossing { robot: id, offset },
            );
            self.robots[id as usize].own.push(e);
        }
    }

    /// All predictions of a robot whose path just changed.
    fn predict_all(&mut self, id: RobotId, out: &mut Outbox) {
        let now = out.now();
        if let WorldSize::Bounded { min, max } = self.cfg.size {
            let r = self.radius(id);
            let wall = predict_wall(&self.track(id), r, min, max, now);
            if let Some((t, contact)) = wall {
                let e = out.schedule(
                    t,
                    Target::MotionManager,
                    EventClass::Conditional,
                    [Some(id), None],
                    Payload::Collision {
                        a: id,
                        b: Obstacle::Boundary,
                        contact: Some(contact),
                    },
                );
                self.robots[id as usize].own.push(e);
            }
        }
        self.predict_neighbours(id, out);
        self.predict_crossing(id, out);
    }

    /// Ends `id`'s motion in progress, if any, with `outcome`; the robot rests where it is.
    /// Returns whether there was a motion to end.
    fn end_motion(&mut self, id: RobotId, outcome: MotionOutcome, out: &mut Outbox) -> bool {
        let now = out.now();
        let state = self.state_at(id, now);
        let r = &mut self.robots[id as usize];
        if r.motion.take().is_none() {
            return false;
        }
        r.rest = state.pose();
        let state = Kinematics::at_rest(r.rest);
        out.record(Observation::MotionFinish {
            robot: id,
            state,
            outcome: outcome.clone(),
        });
        out.notify(
            id,
            Notice::MotionEnded {
                ticket: r.ticket,
                outcome,
                state,
            },
        );
        true
    }

    // ----- motion manager ------------------------------------------------------------

    /// Handles an event addressed to the motion manager (seed fig. 4.4 and 4.6-4.8).
    pub fn handle_motion(&mut self, payload: Payload, out: &mut Outbox) {
        match payload {
            Payload::MotionRequest { robot, .. } if self.robots[robot as usize].crashed => {}
            Payload::MotionRequest {
                robot,
                ticket,
                motion,
            } => self.motion_request(robot, ticket, &motion, out),
            Payload::Crash { robot } => {
                let now = out.now();
                self.end_motion(robot, MotionOutcome::Crashed, out);
                self.invalidate(robot, out);
                self.robots[robot as usize].crashed = true;
                self.robots[robot as usize].push = None;
                self.robots[robot as usize].contact = false;
                out.record(Observation::Crash {
                    robot,
                    state: self.state_at(robot, now),
                });
                self.predict_all(robot, out);
            }
            Payload::MotionStep { robot, step } => self.motion_step(robot, step, out),
            Payload::Collision { a, b, contact } => self.collision(a, b, contact, out),
            Payload::CellCrossing { robot, offset } => {
                let r = &mut self.robots[robot as usize];
                let old = r.cell;
                r.cell = [old[0] + offset[0], old[1] + offset[1]];
                let new = r.cell;
                self.grid.remove(robot, old);
                self.grid.insert(robot, new);
                self.predict_neighbours(robot, out);
                self.predict_crossing(robot, out);
            }
            other => tracing::warn!(?other, "motion manager ignores an event it does not serve"),
        }
    }

    fn motion_request(&mut self, robot: RobotId, ticket: u64, motion: &Motion, out: &mut Outbox) {
        let now = out.now();
        self.end_motion(robot, MotionOutcome::Replaced, out);
        self.invalidate(robot, out);
        let from = self.robots[robot as usize].rest;
        out.record(Observation::MotionRequest {
            robot,
            ticket,
            motion: motion.name().to_string(),
            params: motion.params(),
        });
        match motion.begin(now, from) {
            Err(e) => {
                let outcome = MotionOutcome::Rejected(e.to_string());
                out.record(Observation::MotionFinish {
                    robot,
                    state: Kinematics::at_rest(from),
                    outcome: outcome.clone(),
                });
                out.notify(
                    robot,
                    Notice::MotionEnded {
                        ticket,
                        outcome,
                        state: Kinematics::at_rest(from),
                    },
                );
            }
            Ok(pattern) => {
                let steps = pattern.events();
                let r = &mut self.robots[robot as usize];
                r.motion = Some(pattern);
                r.ticket = ticket;
                for (k, s) in steps.iter().enumerate() {
                    let class = if k == 0 {
                        EventClass::Eventual
                    } else {
                        EventClass::Conditional
                    };
                    let e = out.schedule(
                        s.t,
                        Target::MotionManager,
                        class,
                        [Some(robot), None],
                        Payload::MotionStep { robot, step: k },
                    );
                    r.own.push(e);
                }
                r.steps = steps;
                r.next_step = 0;
            }
        }
        self.predict_all(robot, out);
    }

    fn motion_step(&mut self, robot: RobotId, step: usize, out: &mut Outbox) {
        let now = out.now();
        let r = &mut self.robots[robot as usize];
        if r.motion.is_none() {
            return;
        }
        r.next_step = step + 1;
        let kind = r.steps[step].kind.clone();
        let r = &self.robots[robot as usize];
        let m = r.motion.as_deref().expect("checked above");
        out.record(Observation::MotionStep {
            robot,
            step: kind,
            state: m.state_at(now),
            progress: m.progress_at(now),
        });
        if step + 1 == r.steps.len() {
            let state = m.state_at(m.end_time());
            let ticket = r.ticket;
            let r = &mut self.robots[robot as usize];
            r.rest = state.pose();
            r.motion = None;
            out.record(Observation::MotionFinish {
                robot,
                state,
                outcome: MotionOutcome::Arrived,
            });
            out.notify(
                robot,
                Notice::MotionEnded {
                    ticket,
                    outcome: MotionOutcome::Arrived,
                    state,
                },
            );
        }
    }

    /// Robots and walls that `x` touches at `now` while moving towards them, other than those
    /// in `known`: contacts at the same instant as a collision that stops `x`.
    fn simultaneous_contacts(
        &self,
        x: RobotId,
        now: f64,
        known: &[(RobotId, Obstacle)],
    ) -> Vec<(Obstacle, Option<Point>)> {
        const TOUCH: f64 = 1e-9;
        let kx = self.state_at(x, now);
        let rx = self.radius(x);
        let mut out = Vec::new();
        let listed = |o: Obstacle| {
            known.iter().any(|&(p, q)| {
                (p == x && q == o) || (q == Obstacle::Robot(x) && Obstacle::Robot(p) == o)
            })
        };
        if !self.cfg.ghost_mode {
            for o in self.grid.neighbours(self.robots[x as usize].cell) {
                if o == x || listed(Obstacle::Robot(o)) {
                    continue;
                }
                let ko = self.state_at(o, now);
                let d = kx.pos - ko.pos;
                if d.norm() - rx - self.radius(o) <= TOUCH && d.dot(&(kx.vel - ko.vel)) < 0.0 {
                    out.push((Obstacle::Robot(o), None));
                }
            }
        }
        if let WorldSize::Bounded { min, max } = self.cfg.size {
            if !listed(Obstacle::Boundary) {
                let hit = super::geometry::first_wall_contact(
                    kx.pos,
                    kx.vel,
                    rx,
                    min,
                    max,
                    TOUCH / kx.vel.norm().max(1e-300),
                );
                if let Some((_, c)) = hit {
                    out.push((Obstacle::Boundary, Some(c)));
                }
            }
        }
        out
    }

    /// A collision stops both robots (seed 3.3); every other contact either of them makes at
    /// the same instant is a collision too.
    fn collision(&mut self, a: RobotId, b: Obstacle, contact: Option<Point>, out: &mut Outbox) {
        let now = out.now();
        let mut contacts = vec![(a, b, contact)];
        let mut stopped = Vec::new();
        let mut k = 0;
        while k < contacts.len() {
            let (x, y, c) = contacts[k];
            k += 1;
            let kx = self.state_at(x, now);
            let other_pos = match y {
                Obstacle::Robot(y) => self.state_at(y, now).pos,
                Obstacle::Boundary => c.unwrap_or(kx.pos),
            };
            out.record(Observation::Collision {
                robot: x,
                other: y,
                pos: kx.pos,
                angle: kx.angle,
                other_pos,
            });
            let mut sides = vec![(x, y)];
            if let Obstacle::Robot(y) = y {
                sides.push((y, Obstacle::Robot(x)));
            }
            for (r, with) in sides {
                let known: Vec<(RobotId, Obstacle)> =
                    contacts.iter().map(|&(p, q, _)| (p, q)).collect();
                for (o, c) in self.simultaneous_contacts(r, now, &known) {
                    contacts.push((r, o, c));
                }
                if self.end_motion(r, MotionOutcome::Collided { with }, out) {
                    stopped.push(r);
                }
            }
        }
        for &x in &stopped {
            self.invalidate(x, out);
        }
        // A pair's collision has been consumed even if neither path changed: drop the pair's
        // remaining predictions and make them again from the new state.
        let pairs: Vec<(RobotId, RobotId)> = contacts
            .iter()
            .filter_map(|&(x, y, _)| match y {
                Obstacle::Robot(y) => Some((x, y)),
                Obstacle::Boundary => None,
            })
            .collect();
        for &(x, y) in &pairs {
            if let Some(ids) = self.robots[x as usize].pairs.remove(&y) {
                ids.into_iter().for_each(|e| out.cancel(e));
                self.robots[y as usize].pairs.remove(&x);
            }
        }
        for &x in &stopped {
            self.predict_all(x, out);
        }
        for &(x, y) in &pairs {
            if !self.robots[x as usize].pairs.contains_key(&y) {
                self.predict_pair(x, y, out);
            }
        }
        for &(x, y, _) in &contacts {
            let mut sides = vec![(x, y)];
            if let Obstacle::Robot(y) = y {
                sides.push((y, Obstacle::Robot(x)));
            }
            for (r, with) in sides {
                if self.robots[r as usize].contact {
                    self.push_interrupt(r, SensorKind::Contact, SensorValue::Contact(with), out);
                }
            }
        }
    }

    // ----- sensor manager ------------------------------------------------------------

    fn push_interrupt(
        &self,
        robot: RobotId,
        sensor: SensorKind,
        value: SensorValue,
        out: &mut Outbox,
    ) {
        self.push_interrupt_of(robot, sensor, SensorQuery::DeactivateContact, value, out)
    }

    /// An interrupt of `sensor`, whose reply the sensor computes for `query`.
    fn push_interrupt_of(
        &self,
        robot: RobotId,
        sensor: SensorKind,
        query: SensorQuery,
        value: SensorValue,
        out: &mut Outbox,
    ) {
        out.schedule(
            out.now(),
            Target::Sensor(robot, sensor),
            EventClass::Eventual,
            [Some(robot), None],
            Payload::SensorCompute {
                robot,
                ticket: None,
                query,
                snapshot: value,
            },
        );
    }

    /// Uses the registered sensors `sensors` (beside the built-in ones).
    pub fn with_sensors(mut self, sensors: std::sync::Arc<Sensors>) -> Self {
        self.sensors = sensors;
        self
    }

    fn free_distances(&self, robot: RobotId, range: f64, t: f64) -> Vec<(RobotId, f64)> {
        let me = self.state_at(robot, t).pos;
        let r = self.radius(robot);
        self.within(robot, me, range + r + self.max_radius, t)
            .into_iter()
            .map(|(id, _, d)| (id, d - r - self.radius(id)))
            .filter(|&(_, gap)| gap <= range)
            .collect()
    }

    /// Handles an event addressed to the sensor manager (seed fig. 4.5 and 4.7).
    pub fn handle_sensor(&mut self, payload: Payload, out: &mut Outbox) {
        let now = out.now();
        match payload {
            Payload::SensorRequest { robot, .. } if self.robots[robot as usize].crashed => {}
            Payload::SensorRequest {
                robot,
                ticket,
                query,
            } => {
                out.record(Observation::SensorRequest {
                    robot,
                    query: query.clone(),
                });
                out.schedule(
                    now,
                    Target::SensorManager,
                    EventClass::Eventual,
                    [Some(robot), None],
                    Payload::SensorTrigger {
                        robot,
                        ticket,
                        query,
                    },
                );
            }
            Payload::SensorTrigger {
                robot,
                ticket,
                query,
            } => {
                let snapshot = match query.validate() {
                    Err(e) => SensorValue::Rejected(e),
                    Ok(()) => self.sense(robot, &query, out),
                };
                out.schedule(
                    now,
                    Target::Sensor(robot, query.kind()),
                    EventClass::Eventual,
                    [Some(robot), None],
                    Payload::SensorCompute {
                        robot,
                        ticket: Some(ticket),
                        query,
                        snapshot,
                    },
                );
            }
            Payload::ProximityEntry { robot, other } => {
                let Some(push) = self.robots[robot as usize].push else {
                    return;
                };
                // Look for this pair's next entry, after the robots have left each other's range.
                let reach = push.range + self.radius(robot) + self.radius(other);
                if let Some(t) = predict_entry(&self.track(robot), &self.track(other), reach, now) {
                    let e = out.schedule(
                        t,
                        Target::SensorManager,
                        EventClass::Conditional,
                        [Some(robot), Some(other)],
                        Payload::ProximityEntry { robot, other },
                    );
                    for (x, y) in [(robot, other), (other, robot)] {
                        self.robots[x as usize].pairs.entry(y).or_default().push(e);
                    }
                }
                if now < push.quiet_until {
                    if let Some(p) = self.robots[robot as usize].push.as_mut() {
                        p.pending = true;
                    }
                } else {
                    self.fire_proximity(robot, out);
                }
            }
            Payload::UserSense {
                robot,
                sensor,
                interval,
                generation,
            } => {
                let SensorKind::User(name) = sensor else {
                    return;
                };
                let r = &self.robots[robot as usize];
                let Some((q, g)) = r.user_push.get(name).cloned() else {
                    return;
                };
                if g != generation || r.crashed {
                    return;
                }
                match self.sensors.sense(name, &q, &View::new(self, robot, now)) {
                    Ok(reading) => {
                        if self.sensors.fires(name, &q, &reading) {
                            self.push_interrupt_of(
                                robot,
                                sensor,
                                SensorQuery::User {
                                    sensor: name.to_string(),
                                    query: q,
                                },
                                SensorValue::User(reading),
                                out,
                            );
                        }
                    }
                    Err(e) => tracing::warn!(robot, sensor = name, "push sensor: {e}"),
                }
                out.schedule(
                    now + interval.0,
                    Target::SensorManager,
                    EventClass::Eventual,
                    [Some(robot), None],
                    Payload::UserSense {
                        robot,
                        sensor,
                        interval,
                        generation,
                    },
                );
            }
            Payload::ProximityRearm { robot, generation } => {
                let Some(push) = self.robots[robot as usize].push else {
                    return;
                };
                if push.generation == generation && push.pending {
                    self.fire_proximity(robot, out);
                }
            }
            other => tracing::warn!(?other, "sensor manager ignores an event it does not serve"),
        }
    }

    /// Reports the robots in range now, then starts the quiet interval.
    fn fire_proximity(&mut self, robot: RobotId, out: &mut Outbox) {
        let now = out.now();
        let Some(mut push) = self.robots[robot as usize].push else {
            return;
        };
        let near = self.free_distances(robot, push.range, now);
        push.pending = false;
        if !near.is_empty() {
            self.push_interrupt(
                robot,
                SensorKind::PushProximity,
                SensorValue::Distances(near),
                out,
            );
            if push.interval > 0.0 {
                push.quiet_until = now + push.interval;
                push.generation += 1;
                out.schedule(
                    push.quiet_until,
                    Target::SensorManager,
                    EventClass::Eventual,
                    [Some(robot), None],
                    Payload::ProximityRearm {
                        robot,
                        generation: push.generation,
                    },
                );
            }
        }
        self.robots[robot as usize].push = Some(push);
    }

    /// The exact data for a request at its trigger time (and (de)activation of push sensors).
    fn sense(&mut self, robot: RobotId, query: &SensorQuery, out: &mut Outbox) -> SensorValue {
        let now = out.now();
        let me = self.state_at(robot, now).pos;
        match *query {
            SensorQuery::User {
                ref sensor,
                query: ref q,
            } => match self.sensors.push_interval(sensor, q) {
                Err(e) => SensorValue::Rejected(e),
                Ok(None) => match self.sensors.sense(sensor, q, &View::new(self, robot, now)) {
                    Ok(reading) => SensorValue::User(reading),
                    Err(e) => SensorValue::Rejected(e),
                },
                Ok(Some(interval)) => {
                    let SensorKind::User(name) = query.kind() else {
                        unreachable!("a user query names a user sensor")
                    };
                    self.user_generation += 1;
                    let generation = self.user_generation;
                    self.robots[robot as usize]
                        .user_push
                        .insert(name, (q.clone(), generation));
                    out.schedule(
                        now,
                        Target::SensorManager,
                        EventClass::Eventual,
                        [Some(robot), None],
                        Payload::UserSense {
                            robot,
                            sensor: query.kind(),
                            interval: crate::world::sensor::Interval(interval),
                            generation,
                        },
                    );
                    SensorValue::Done
                }
            },
            SensorQuery::UserOff { .. } => {
                if let SensorKind::User(name) = query.kind() {
                    self.robots[robot as usize].user_push.remove(name);
                }
                SensorValue::Done
            }
            SensorQuery::SelfPosition { .. } => SensorValue::Position(me),
            SensorQuery::AllPositions { .. } => SensorValue::Positions(self.positions_at(now)),
            SensorQuery::View { range } => SensorValue::Positions(
                self.within(robot, me, range, now)
                    .into_iter()
                    .map(|(id, p, _)| (id, p))
                    .collect(),
            ),
            SensorQuery::Proximity { range } => {
                SensorValue::Distances(self.free_distances(robot, range, now))
            }
            SensorQuery::ActivateProximity { range, interval } => {
                self.robots[robot as usize].push = Some(PushProximity {
                    range,
                    interval,
                    quiet_until: now,
                    generation: 0,
                    pending: false,
                });
                self.ensure_cell_size(range + 2.0 * self.max_radius, out);
                self.cancel_pairs(robot, out);
                self.predict_neighbours(robot, out);
                self.fire_proximity(robot, out);
                SensorValue::Done
            }
            SensorQuery::DeactivateProximity => {
                if self.robots[robot as usize].push.take().is_some() {
                    self.cancel_pairs(robot, out);
                    self.predict_neighbours(robot, out);
                }
                SensorValue::Done
            }
            SensorQuery::ActivateContact => {
                self.robots[robot as usize].contact = true;
                SensorValue::Done
            }
            SensorQuery::DeactivateContact => {
                self.robots[robot as usize].contact = false;
                SensorValue::Done
            }
        }
    }

    /// Widens the grid's cells to at least `reach` (re-registering every robot and redoing every
    /// prediction) so neighbour blocks still cover every interaction.
    fn ensure_cell_size(&mut self, reach: f64, out: &mut Outbox) {
        if reach <= self.grid.cell_size() {
            return;
        }
        let now = out.now();
        tracing::debug!(reach, "widening the spatial index's cells");
        self.grid = Grid::new(reach * (1.0 + 1e-9));
        for id in 0..self.robots.len() as RobotId {
            self.invalidate(id, out);
            // Motion steps were cancelled with the other own events: schedule them again.
            let r = &self.robots[id as usize];
            let pending: Vec<(usize, f64)> = match &r.motion {
                Some(_) => r
                    .steps
                    .iter()
                    .enumerate()
                    .skip(r.next_step)
                    .map(|(k, s)| (k, s.t))
                    .collect(),
                None => Vec::new(),
            };
            for (k, t) in pending {
                let e = out.schedule(
                    t,
                    Target::MotionManager,
                    EventClass::Conditional,
                    [Some(id), None],
                    Payload::MotionStep { robot: id, step: k },
                );
                self.robots[id as usize].own.push(e);
            }
            let cell = self.grid.cell_of(self.state_at(id, now).pos);
            self.robots[id as usize].cell = cell;
            self.grid.insert(id, cell);
        }
        for id in 0..self.robots.len() as RobotId {
            self.predict_all(id, out);
        }
    }
}

/// A robot's view of the world at an instant, for registered sensors.
struct View<'a> {
    world: &'a VirtualWorld,
    robot: RobotId,
    now: f64,
}

impl<'a> View<'a> {
    fn new(world: &'a VirtualWorld, robot: RobotId, now: f64) -> Self {
        Self { world, robot, now }
    }
}

impl WorldView for View<'_> {
    fn now(&self) -> f64 {
        self.now
    }
    fn robot(&self) -> RobotId {
        self.robot
    }
    fn count(&self) -> usize {
        self.world.robots.len()
    }
    fn position(&self, robot: RobotId) -> Point {
        self.world.state_at(robot, self.now).pos
    }
    fn radius(&self, robot: RobotId) -> f64 {
        self.world.radius(robot)
    }
    fn within(&self, range: f64) -> Vec<(RobotId, Point, f64)> {
        let me = self.position(self.robot);
        self.world.within(self.robot, me, range, self.now)
    }
}
