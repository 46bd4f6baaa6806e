//! The virtual world (seed 3.2 and 4.2.4): every robot's state, the spatial index, the queries
//! over them and the cheap invalidation of predictions. The motion manager's logic over it is
//! `motion_logic` (seed 4.2.3, fig. 4.4); the sensor manager's logic and its own state
//! ([`Sensing`], owned by the sensor manager actor) are `sensing` (seed 4.2.2-4.2.3, fig.
//! 4.5). Of the armed push sensors the world holds only what its predictions need: each entry
//! sensor's range and which sensors a contact triggers. A sensor, built-in or a user's, is a
//! [`super::sensor::SensorModel`] and touches none of these modules.
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
//! exactly those and re-predicts against the 3×3 blocks around the cells the robot is
//! registered in (its own and the next ones on its path, [`super::grid::Span`]).

use super::collision::{
    cell_walk, predict_contact_from, predict_entry, predict_reentry, predict_wall, Track,
    CONTACT_TOLERANCE,
};
use super::event::{EventClass, EventId, Handle, Notice, Payload, Target};
use super::geometry::Point;
use super::grid::{blocks, blocks_beyond, next_to, Cell, Grid, Span, SpanCells, SPAN};
use super::motion::{Kinematics, Motion, Path, Piece, Pose};
use super::observation::Observation;
use super::obstacle::{predict_obstacle, ObstacleIndex, Shape, ShapeError};
use super::outbox::Outbox;
use super::queue::Claims;
use super::sensor::{Datum, SensorKind, SensorQuery, SensorValue, Sensors, Trigger, WorldView};
use super::{MotionOutcome, Obstacle, RobotId};
use smallvec::SmallVec;

mod motion_logic;
mod robot_state;
mod sensing;

use robot_state::{OwnEvents, PairEvents, Pairs, RobotState};
pub use sensing::Sensing;

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
#[derive(Clone, Debug, PartialEq)]
pub struct WorldConfig {
    pub size: WorldSize,
    /// No robot-robot collisions at all (seed 6.1). The boundary still holds robots in unless
    /// `walls` is false.
    pub ghost_mode: bool,
    /// Whether a bounded world's boundary stops robots like a wall (`ghost_mode: true, walls:
    /// false` is the seed's ghost mode: no collisions at all).
    pub walls: bool,
    /// Which way MOVETO turns.
    pub turn: super::motion::TurnRule,
    /// Width of the spatial index's cells [units]; by default four times the largest radius.
    /// Raised automatically to the largest interaction distance.
    pub cell_size: Option<f64>,
    /// Static obstacles (seed 7.2), numbered by their place in the list.
    pub obstacles: std::sync::Arc<[Shape]>,
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
    #[error("obstacle {obstacle}: {error}")]
    BadObstacle { obstacle: usize, error: ShapeError },
    #[error("robot {robot} at ({x}, {y}) with radius {radius} overlaps obstacle {obstacle}")]
    InObstacle {
        robot: RobotId,
        x: f64,
        y: f64,
        radius: f64,
        obstacle: usize,
    },
}

/// A robot's initial settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RobotSpec {
    /// Radius [units].
    pub radius: f64,
    pub pose: Pose,
}

/// The robots a robot is to be predicted against, found around its cells.
type Fresh = SmallVec<[RobotId; 8]>;

/// The virtual world: all robots' states and the spatial index.
#[derive(Debug)]
pub struct VirtualWorld {
    cfg: WorldConfig,
    robots: Vec<RobotState>,
    grid: Grid,
    max_radius: f64,
    obstacles: ObstacleIndex,
    /// The queue slots of the conditional events whose handles the robots keep.
    claims: Claims,
    /// The robots stopped at this instant whose predictions at rest wait for its end,
    unsettled: Vec<RobotId>,
    /// how many of them still wait,
    waiting: usize,
    /// and the event at the instant's end that predicts for them, until it is taken.
    settle: Option<EventId>,
    /// Whether a robot has armed an entry-triggered push sensor in this run: in ghost mode
    /// such entries are the only events two robots can have, so until one is armed there is
    /// no pair to predict ([`VirtualWorld::pairs_matter`]).
    entries_armed: bool,
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
        for (k, o) in cfg.obstacles.iter().enumerate() {
            o.check()
                .map_err(|error| WorldError::BadObstacle { obstacle: k, error })?;
        }
        let obstacles = ObstacleIndex::new(cfg.obstacles.to_vec(), size);
        for (i, s) in specs.iter().enumerate() {
            let p = s.pose.pos;
            if let Some(k) = cfg.obstacles.iter().position(|o| o.distance(p) < s.radius) {
                return Err(WorldError::InObstacle {
                    robot: i as RobotId,
                    x: p.x,
                    y: p.y,
                    radius: s.radius,
                    obstacle: k,
                });
            }
        }
        let grid = grid_for(size, &cfg.size, specs.len());
        let mut world = Self {
            cfg,
            robots: Vec::with_capacity(specs.len()),
            grid,
            max_radius,
            obstacles,
            claims: Claims::default(),
            unsettled: Vec::new(),
            waiting: 0,
            settle: None,
            entries_armed: false,
        };
        for (i, s) in specs.iter().enumerate() {
            let id = i as RobotId;
            let cell = world.grid.cell_of(s.pose.pos);
            // In ghost mode robots never collide, so they may be born on one point (as
            // Look-Compute-Move robots that start gathered are).
            for other in world
                .grid
                .neighbours(cell)
                .filter(|_| !world.cfg.ghost_mode)
            {
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
                next_step: 0,
                own: OwnEvents::new(),
                obstacle: None,
                pairs: Pairs::default(),
                cell,
                span: Span::default(),
                listening: None,
                crashed: false,
                unsettled: false,
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

    /// Asks for what the handlings of the next two events read in the world to be brought
    /// into cache ([`super::prefetch`]), in two stages ([`crate::world::queue::EventQueue::look_ahead`]):
    /// the state of the robots that the event `after` the next concerns, and the grid's cells
    /// around those of the `next` event, which needs their state, asked for one event ago
    /// (ids out of range are ignored).
    pub fn prefetch(&self, next: Option<[RobotId; 2]>, after: Option<[RobotId; 2]>) {
        for r in after.into_iter().flatten() {
            if let Some(state) = self.robots.get(r as usize) {
                super::prefetch::prefetch(state);
            }
        }
        for r in next.into_iter().flatten() {
            if let Some(state) = self.robots.get(r as usize) {
                // Asked for already unless the event came in between.
                super::prefetch::prefetch(state);
                // The last of its cells: where it crosses next.
                let last = state.span.cells(state.cell).last();
                self.grid.prefetch_around(last.unwrap_or(state.cell));
            }
        }
    }

    /// Width of the spatial index's cells [units].
    pub fn cell_size(&self) -> f64 {
        self.grid.cell_size()
    }

    fn track(&self, id: RobotId) -> Track<'_> {
        let r = &self.robots[id as usize];
        Track {
            motion: r.motion.as_ref().map(Path::pattern),
            rest: r.rest.pos,
        }
    }

    /// The exact kinematic state of a robot at `t` (not before its current motion started).
    pub fn state_at(&self, id: RobotId, t: f64) -> Kinematics {
        let r = &self.robots[id as usize];
        match &r.motion {
            Some(m) => m.pattern().state_at(t),
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
        // A moving robot is registered in several cells.
        let mut candidates = candidates;
        candidates.sort_unstable();
        candidates.dedup();
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
        out.reserve(2 * self.robots.len());
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
        let mut pairs = std::mem::take(&mut self.robots[id as usize].pairs);
        // The partners' tables, asked for together rather than one miss after the other.
        for &(p, _) in &pairs.0 {
            super::prefetch::prefetch(&self.robots[p as usize].pairs);
        }
        for (p, ids) in pairs.drain() {
            ids.into_iter().for_each(|h| self.drop_handle(h, out));
            self.robots[p as usize].pairs.remove(&id);
        }
        if !pairs.0.spilled() {
            self.robots[id as usize].pairs = pairs;
        }
    }

    /// Cancels every conditional event that depends on `id`'s path.
    fn invalidate(&mut self, id: RobotId, out: &mut Outbox) {
        let own = std::mem::take(&mut self.robots[id as usize].own);
        own.into_iter().for_each(|h| self.drop_handle(h, out));
        if let Some(h) = self.robots[id as usize].obstacle.take() {
            self.drop_handle(h, out);
        }
        self.cancel_pairs(id, out);
    }

    /// Cancels the event of a handle that is dropped (a no-op if it fired) and releases its
    /// slot. Each handle is dropped once: a pair's handles, kept by both robots, when the
    /// pair's entries go.
    fn drop_handle(&mut self, h: Handle, out: &mut Outbox) {
        out.cancel(h);
        self.claims.release(h);
    }

    fn predict_pair(&mut self, a: RobotId, b: RobotId, out: &mut Outbox) {
        let pa = self.track(a).pieces_from(out.now());
        self.predict_pair_from(a, &pa, b, out);
    }

    /// [`Self::predict_pair`] given `a`'s pieces from now (`pa`).
    fn predict_pair_from(&mut self, a: RobotId, pa: &[Piece], b: RobotId, out: &mut Outbox) {
        let mut ids = PairEvents::new();
        // The tracks borrow the world: the claims are taken out meanwhile.
        let mut claims = std::mem::take(&mut self.claims);
        self.pair_events(a, pa, b, out.now(), |t, target, concerns, payload| {
            let class = EventClass::Conditional;
            ids.push(out.schedule_in(&mut claims, t, target, class, concerns, payload));
        });
        self.claims = claims;
        // A pair for which nothing is predicted is not kept: most pairs predicted are, and a
        // kept one is a write into the partner's state now and again when either path
        // changes, a cache miss each at a million robots. Such a pair may be predicted again
        // when a scan finds it again, which predicts nothing again.
        if !ids.is_empty() {
            self.robots[a as usize]
                .pairs
                .insert(b, PairEvents::from_slice(&ids));
            self.robots[b as usize].pairs.insert(a, ids);
        }
    }

    /// Calls `found(time, target, robots, payload)` with each event that predicting `a` (its
    /// pieces from `now`: `pa`) against `b` finds, in the order they are to be scheduled: their
    /// collision (but in ghost mode), then each entry of one into the range of the other's
    /// entry-triggered push sensors, `a`'s sensors first.
    fn pair_events(
        &self,
        a: RobotId,
        pa: &[Piece],
        b: RobotId,
        now: f64,
        mut found: impl FnMut(f64, Target, [Option<RobotId>; 2], Payload),
    ) {
        let (ta, tb) = (self.track(a), self.track(b));
        let (ra, rb) = (self.radius(a), self.radius(b));
        if !self.cfg.ghost_mode {
            if let Some(t) = predict_contact_from(&ta, pa, &tb, ra + rb, now) {
                found(
                    t,
                    Target::MotionManager,
                    [Some(a), Some(b)],
                    Payload::Collision { a, b },
                );
            }
        }
        for (s, o, ts, to) in [(a, b, &ta, &tb), (b, a, &tb, &ta)] {
            for &(sensor, range) in self.robots[s as usize].entry() {
                if let Some(t) = predict_entry(ts, to, range + ra + rb, now) {
                    let payload = Payload::ProximityEntry {
                        robot: s,
                        other: o,
                        sensor,
                    };
                    found(t, Target::SensorManager, [Some(s), Some(o)], payload);
                }
            }
        }
    }

    /// The cells `id` is registered in, in order along its path.
    fn span_cells(&self, id: RobotId) -> SpanCells {
        let r = &self.robots[id as usize];
        r.span.cell_list(r.cell)
    }

    /// Registers `id` in the cells its centre passes through from `first` on, from now: up to
    /// [`SPAN`] of them, ending where it stops, instead of the cells `old` it was registered in.
    /// Returns when and into which neighbour it leaves the last one, if it does.
    fn seat(
        &mut self,
        id: RobotId,
        old: &[Cell],
        first: Cell,
        now: f64,
        until: f64,
    ) -> Option<(f64, [i64; 2])> {
        let (span, exit) = self.walk(id, first, now, until);
        self.register(id, old, first, span);
        exit
    }

    /// The cells `id`'s centre passes through from `first` on, from now until `until`, as the
    /// steps of a span of up to [`SPAN`] cells; and when and into which neighbour it leaves
    /// the last one, if it does.
    fn walk(
        &self,
        id: RobotId,
        first: Cell,
        now: f64,
        until: f64,
    ) -> (Span, Option<(f64, [i64; 2])>) {
        let (track, size) = (self.track(id), self.grid.cell_size());
        let mut span = Span::default();
        let exit = cell_walk(&track, first, size, now, until, SPAN - 1, |offset| {
            span.push(offset)
        });
        (span, exit)
    }

    /// Registers `id` in the cells of `span` from `first` instead of the cells `old`.
    fn register(&mut self, id: RobotId, old: &[Cell], first: Cell, span: Span) {
        for &c in old {
            self.grid.remove(id, c);
        }
        let r = &mut self.robots[id as usize];
        r.cell = first;
        r.span = span;
        for c in span.cells(first) {
            self.grid.insert(id, c);
        }
    }

    /// Schedules `id`'s crossing out of the last cell it is registered in.
    fn schedule_crossing(&mut self, id: RobotId, exit: Option<(f64, [i64; 2])>, out: &mut Outbox) {
        if let Some((t, offset)) = exit {
            let e = out.schedule_in(
                &mut self.claims,
                t,
                Target::MotionManager,
                EventClass::Conditional,
                [Some(id), None],
                Payload::CellCrossing { robot: id, offset },
            );
            self.robots[id as usize].own.push(e);
        }
    }

    /// Predicts `id` against the robots next to `cells` (the cells it is registered in) that
    /// it has no pair events with yet, each once, leaving out the cells next to `skip`, in the
    /// order of [`blocks`] ([`blocks_beyond`]).
    fn predict_around(&mut self, id: RobotId, cells: &[Cell], skip: &[Cell], out: &mut Outbox) {
        let fresh = self.fresh_around(id, cells, skip);
        self.predict_fresh(id, fresh, out);
    }

    /// The robots next to `cells` but not to `skip` that `id` has no pair events with yet,
    /// each once, in the order of [`blocks`] ([`blocks_beyond`]); their states, which predicting
    /// against them reads, are asked for together rather than one miss after the other.
    fn fresh_around(&self, id: RobotId, cells: &[Cell], skip: &[Cell]) -> Fresh {
        let mut fresh = Fresh::new();
        if !self.pairs_matter() {
            return fresh;
        }
        let pairs = &self.robots[id as usize].pairs;
        blocks_beyond(cells, skip, |b| {
            for &o in self.grid.robots_in(b) {
                if o != id && !fresh.contains(&o) && !pairs.contains_key(&o) {
                    fresh.push(o);
                }
            }
        });
        for &o in &fresh {
            super::prefetch::prefetch(&self.robots[o as usize]);
        }
        fresh
    }

    /// Whether two robots can have events together: a collision, unless in ghost mode, or an
    /// entry into an armed entry-triggered push sensor's range. Until then a scan for the
    /// robots around one would only predict nothing for each. Arming the first entry sensor
    /// predicts its robot against the robots around it, and every later scan finds the
    /// robots that come next to it.
    fn pairs_matter(&self) -> bool {
        !self.cfg.ghost_mode || self.entries_armed
    }

    /// Predicts `id` against each of `fresh`, in order.
    fn predict_fresh(&mut self, id: RobotId, fresh: Fresh, out: &mut Outbox) {
        if fresh.is_empty() {
            return;
        }
        let pieces = self.track(id).pieces_from(out.now());
        for o in fresh {
            self.predict_pair_from(id, &pieces, o, out);
        }
    }

    /// Predicts `id` against every robot next to the cells it is registered in that it has no
    /// prediction with yet.
    fn predict_neighbours(&mut self, id: RobotId, out: &mut Outbox) {
        let cells = self.span_cells(id);
        self.predict_around(id, &cells, &[], out);
    }

    /// A crossing out of the last cell `robot` is registered in, by `offset`: it is registered
    /// anew from the cell it enters, and predicted against the robots it comes next to: those
    /// of the cells next to its new cells that were not next to its old ones. The robots of
    /// the others already have predictions with a moving robot (made when its motion began,
    /// when either came next to the other, or when either's path changed), so a crossing reads
    /// only the cells ahead. Those robots are found, and their states asked for,
    /// before the robot is registered anew, so that the states come in meanwhile: the cells
    /// ahead are none of the cells it leaves nor next to them, and it is not in them yet, so
    /// they hold the same robots in the same order before and after.
    fn cross(&mut self, robot: RobotId, offset: [i64; 2], out: &mut Outbox) {
        let old = self.span_cells(robot);
        let last = old[old.len() - 1];
        let first = [last[0] + offset[0], last[1] + offset[1]];
        let (span, exit) = self.walk(robot, first, out.now(), f64::INFINITY);
        let fresh = self.fresh_around(robot, &span.cell_list(first), &old);
        self.register(robot, &old, first, span);
        debug_assert!(
            self.neighbours_left_are_predicted(robot, &old, out.now()),
            "a robot next to a moving robot without the prediction due with it"
        );
        debug_assert_eq!(
            fresh,
            self.fresh_around(robot, &self.span_cells(robot), &old),
            "the robots ahead are the same once registered"
        );
        self.predict_fresh(robot, fresh, out);
        self.predict_obstacles(robot, out);
        self.schedule_crossing(robot, exit, out);
    }

    /// Whether `robot`, registered anew after it was in the cells `old`, has the predictions
    /// due with every robot of the cells next to both its old and its new cells, which a
    /// crossing does not predict for again (a debug check of [`Self::cross`]).
    fn neighbours_left_are_predicted(&self, robot: RobotId, old: &[Cell], now: f64) -> bool {
        let cells = self.span_cells(robot);
        blocks(&cells)
            .into_iter()
            .filter(|&c| old.iter().any(|&o| next_to(o, c)))
            .flat_map(|c| self.grid.robots_in(c).to_vec())
            .all(|o| {
                o == robot
                    || self.is_unsettled(o)
                    || self.robots[robot as usize].pairs.contains_key(&o)
                    || {
                        // A pair not kept: predicting it from now finds nothing.
                        let mut none = true;
                        let pieces = self.track(robot).pieces_from(now);
                        self.pair_events(robot, &pieces, o, now, |_, _, _, _| none = false);
                        none
                    }
            })
    }

    /// Registers a robot whose motion ended in the one cell it stopped in, the last of its
    /// cells (the cells behind it are no longer its).
    fn settle(&mut self, id: RobotId, now: f64) {
        if !self.robots[id as usize].span.is_single() {
            let old = self.span_cells(id);
            self.seat(id, &old, old[old.len() - 1], now, now);
        }
    }

    /// All predictions of a robot whose path just changed.
    fn predict_all(&mut self, id: RobotId, out: &mut Outbox) {
        let r = &mut self.robots[id as usize];
        if r.unsettled {
            r.unsettled = false;
            self.waiting -= 1;
            if self.waiting == 0 {
                // Every robot stopped at this instant has been predicted for: no settling.
                if let Some(e) = self.settle.take() {
                    out.withdraw_at_instant_end(e);
                }
                self.unsettled.clear();
            }
        }
        let now = out.now();
        if let (WorldSize::Bounded { min, max }, true) = (self.cfg.size, self.cfg.walls) {
            let r = self.radius(id);
            let wall = predict_wall(&self.track(id), r, min, max, now);
            if let Some((t, contact)) = wall {
                let e = schedule_contact(out, &mut self.claims, id, t, Obstacle::Boundary, contact);
                self.robots[id as usize].own.push(e);
            }
        }
        let here = self.grid.cell_of(self.state_at(id, now).pos);
        // Its own cell only (the cells it is in now): a new motion mostly begins with a turn
        // on the spot, and the robots around the cells it would reach after the turn are
        // mostly gone by then, each a prediction for nothing (docs/performance.md lists the
        // gain). Its first crossing registers it ahead.
        let old = self.span_cells(id);
        let exit = self.seat(id, &old, here, now, now);
        self.predict_neighbours(id, out);
        self.predict_obstacles(id, out);
        self.schedule_crossing(id, exit, out);
    }

    /// Leaves the predictions of `id`, which stopped, to the end of this instant: a robot that
    /// a collision stops mostly starts its next motion at the same instant (its algorithm
    /// runs at once), which predicts anew, so the predictions at rest would be made for
    /// nothing. Until then it has none with the robots around it; it is still registered in
    /// the cells it was, which hold the one it stopped in.
    fn unsettle(&mut self, id: RobotId, out: &mut Outbox) {
        let r = &mut self.robots[id as usize];
        if r.unsettled {
            return;
        }
        r.unsettled = true;
        if self.unsettled.is_empty() {
            let e = out.at_instant_end(Target::MotionManager, [None, None], Payload::Settle);
            self.settle = Some(e);
        }
        self.unsettled.push(id);
        self.waiting += 1;
    }

    /// Whether `id` stopped at this instant and waits for its predictions at rest.
    fn is_unsettled(&self, id: RobotId) -> bool {
        self.robots[id as usize].unsettled
    }

    /// The end of an instant at which robots stopped: predicts for each one still at rest
    /// (those that started a motion since were predicted for then), in the order they
    /// stopped.
    fn settle_all(&mut self, out: &mut Outbox) {
        self.settle = None;
        let ids = std::mem::take(&mut self.unsettled);
        for &id in &ids {
            if self.robots[id as usize].unsettled {
                self.predict_all(id, out);
            }
        }
        self.unsettled = ids;
        self.unsettled.clear();
    }

    /// Predicts `id`'s first contact with the obstacles around the cells it is registered in
    /// (replacing the earlier prediction): a contact farther away happens after a cell
    /// crossing, which predicts again.
    fn predict_obstacles(&mut self, id: RobotId, out: &mut Outbox) {
        if let Some(h) = self.robots[id as usize].obstacle.take() {
            self.drop_handle(h, out);
        }
        if self.obstacles.is_empty() || self.robots[id as usize].motion.is_none() {
            return;
        }
        let now = out.now();
        let (track, r) = (self.track(id), self.radius(id));
        let mut first: Option<(f64, Point, u32)> = None;
        let around: Vec<u32> = self
            .span_cells(id)
            .iter()
            .flat_map(|&c| self.obstacles.around(c))
            .collect();
        for i in around {
            let (k, prim) = self.obstacles.get(i);
            if let Some((t, c)) = predict_obstacle(&track, r, &prim, now) {
                if first.is_none_or(|f| t < f.0) {
                    first = Some((t, c, k));
                }
            }
        }
        if let Some((t, contact, k)) = first {
            let e = schedule_contact(out, &mut self.claims, id, t, Obstacle::Object(k), contact);
            self.robots[id as usize].obstacle = Some(e);
        }
    }

    /// The world's obstacles with their index.
    pub fn obstacles(&self) -> &ObstacleIndex {
        &self.obstacles
    }

    /// Widens the grid's cells to at least `reach` (re-registering every robot and redoing every
    /// prediction) so neighbour blocks still cover every interaction.
    fn ensure_cell_size(&mut self, reach: f64, out: &mut Outbox) {
        if reach <= self.grid.cell_size() {
            return;
        }
        let now = out.now();
        tracing::debug!(reach, "widening the spatial index's cells");
        self.grid = grid_for(reach * (1.0 + 1e-9), &self.cfg.size, self.robots.len());
        self.obstacles.reindex(self.grid.cell_size());
        for id in 0..self.robots.len() as RobotId {
            self.invalidate(id, out);
            // Motion steps were cancelled with the other own events: schedule them again.
            let r = &self.robots[id as usize];
            let pending = match &r.motion {
                Some(m) => motion_logic::step_events(&m.pattern().events(), r.next_step as usize),
                None => SmallVec::new(),
            };
            for (k, through, t) in pending {
                let e = out.schedule_in(
                    &mut self.claims,
                    t,
                    Target::MotionManager,
                    EventClass::Conditional,
                    [Some(id), None],
                    Payload::MotionStep {
                        robot: id,
                        step: k,
                        through,
                    },
                );
                self.robots[id as usize].own.push(e);
            }
            let cell = self.grid.cell_of(self.state_at(id, now).pos);
            self.robots[id as usize].cell = cell;
            self.robots[id as usize].span = Span::default();
            self.grid.insert(id, cell);
        }
        for id in 0..self.robots.len() as RobotId {
            self.predict_all(id, out);
        }
    }
}

/// The spatial index of a world of `robots` robots, with cells `size` wide: over a bounded
/// world's area, a dense one.
fn grid_for(size: f64, world: &WorldSize, robots: usize) -> Grid {
    match *world {
        WorldSize::Bounded { min, max } => Grid::for_area(size, min, max, robots),
        WorldSize::Infinite => Grid::new(size),
    }
}

/// Schedules robot `id`'s predicted contact at `t` with a wall or an obstacle, touched at
/// `contact`: a conditional collision event on the motion manager.
fn schedule_contact(
    out: &mut Outbox,
    claims: &mut Claims,
    id: RobotId,
    t: f64,
    with: Obstacle,
    contact: Point,
) -> Handle {
    out.schedule_in(
        claims,
        t,
        Target::MotionManager,
        EventClass::Conditional,
        [Some(id), None],
        Payload::Contact {
            robot: id,
            with,
            at: contact,
        },
    )
}
