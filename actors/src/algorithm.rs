//! Built-in robot algorithms (seed chapter 5): [`Idle`], [`Script`], [`RandomMovement`]
//! (seed 5.1) and [`Gathering`] (seed 5.2), with the speed ranges of the seed's code.

use rand::Rng;
use serde::{Deserialize, Serialize};

use crate::robot::{Algorithm, AlgorithmFuture, Robot};
use crate::world::geometry::Point;
use crate::world::motion::Motion;
use crate::world::virtual_world::WorldSize;

/// Does nothing: the robot stands where it was born (an obstacle for the others).
#[derive(Clone, Debug, Default)]
pub struct Idle;

impl Algorithm for Idle {
    fn name(&self) -> &str {
        "Idle"
    }
    fn run(&self, _: Robot) -> AlgorithmFuture {
        Box::pin(async {})
    }
}

/// One step of a [`Script`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ScriptStep {
    /// Turn by a signed `angle` [deg] at `turn_speed` [deg/s].
    Turn { angle: f64, turn_speed: f64 },
    /// Move `distance` [units] forward at `move_speed` [units/s].
    Forward { distance: f64, move_speed: f64 },
    /// Go to `(x, y)`.
    MoveTo {
        x: f64,
        y: f64,
        move_speed: f64,
        turn_speed: f64,
    },
    /// Wait [s].
    Wait(f64),
}

/// Runs a list of steps once; each step starts when the previous one ends, however it ended.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Script(pub Vec<ScriptStep>);

impl Algorithm for Script {
    fn name(&self) -> &str {
        "Script"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let steps = self.0.clone();
        Box::pin(async move {
            for step in steps {
                match step {
                    ScriptStep::Turn { angle, turn_speed } => {
                        robot.turn(angle, turn_speed).await;
                    }
                    ScriptStep::Forward {
                        distance,
                        move_speed,
                    } => {
                        robot.forward(distance, move_speed).await;
                    }
                    ScriptStep::MoveTo {
                        x,
                        y,
                        move_speed,
                        turn_speed,
                    } => {
                        robot
                            .motion(Motion::MoveTo {
                                dest: Point::new(x, y),
                                move_speed,
                                turn_speed,
                            })
                            .await;
                    }
                    ScriptStep::Wait(d) => robot.sleep(d).await,
                }
            }
        })
    }
}

/// A speed range `[min, min + spread)`, as the seed's code draws speeds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpeedRange {
    pub min: f64,
    pub spread: f64,
}

impl SpeedRange {
    fn draw(&self, rng: &mut impl Rng) -> f64 {
        self.min + self.spread * rng.gen::<f64>()
    }
}

/// Side of the square, centred on the origin, where random destinations are drawn in an
/// infinite world (the seed's 800×800).
pub const DEFAULT_AREA: f64 = 800.0;

/// The rectangle where random destinations are drawn: the world if it is bounded, else the
/// [`DEFAULT_AREA`] square centred on the origin.
pub fn destination_area(world: WorldSize) -> (Point, Point) {
    match world {
        WorldSize::Bounded { min, max } => (min, max),
        WorldSize::Infinite => (
            Point::new(-DEFAULT_AREA / 2.0, -DEFAULT_AREA / 2.0),
            Point::new(DEFAULT_AREA / 2.0, DEFAULT_AREA / 2.0),
        ),
    }
}

/// How soon after its start a move that ends was blocked at its very start [s]. A robot
/// already in contact with another that moves towards it collides at once, but the contact
/// time is computed in floating point and may land a few ulps after the start rather than at
/// it; a robot that retried at once would then advance time by ulps forever, a run that never
/// reaches its end. Real moves last many orders of magnitude longer.
pub const BLOCKED_WITHIN: f64 = 1e-9;

/// Whether a move started at `started` and ended at `now` took no virtual time: it was
/// blocked at its very start (within [`BLOCKED_WITHIN`]) or the robot was already there.
pub fn took_no_time(started: f64, now: f64) -> bool {
    now - started < BLOCKED_WITHIN
}

/// Moves to `dest`; if the move took no virtual time ([`took_no_time`]: blocked at its very
/// start by a collision, or already there), waits `retry` seconds. The seed's loops
/// (`while (t <= limit) moveTo(..)`) would otherwise spin forever at one instant once a robot
/// is boxed in or has gathered.
pub async fn move_or_wait(
    robot: &Robot,
    dest: Point,
    move_speed: f64,
    turn_speed: f64,
    retry: f64,
) {
    let started = robot.now();
    robot.move_to(dest, move_speed, turn_speed).await;
    if took_no_time(started, robot.now()) {
        robot.sleep(retry).await;
    }
}

/// Seed 5.1: pick a random destination and random speeds, go there, repeat.
///
/// As in the seed's code: move speed uniform in `[3, 13)`; turn speed = `3 + move_speed × U`;
/// the destination uniform over the world (an 800×800 square centred on the origin in an
/// infinite world).
#[derive(Clone, Debug, PartialEq)]
pub struct RandomMovement {
    pub move_speed: SpeedRange,
    /// When set, turn speeds are drawn from this range instead of the seed's rule.
    pub turn_speed: Option<SpeedRange>,
    /// Wait after a move that took no time (boxed in by robots or walls) [s].
    pub retry: f64,
}

impl Default for RandomMovement {
    fn default() -> Self {
        Self {
            move_speed: SpeedRange {
                min: 3.0,
                spread: 10.0,
            },
            turn_speed: None,
            retry: 1.0,
        }
    }
}

fn draw_speeds(robot: &Robot, ms: SpeedRange, ts: Option<SpeedRange>) -> (f64, f64) {
    let mut rng = robot.rng();
    let move_speed = ms.draw(&mut *rng);
    let turn_speed = match ts {
        Some(r) => r.draw(&mut *rng),
        None => ms.min + move_speed * rng.gen::<f64>(),
    };
    (move_speed, turn_speed)
}

impl Algorithm for RandomMovement {
    fn name(&self) -> &str {
        "RandomMovement"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let cfg = self.clone();
        Box::pin(async move {
            let (lo, hi) = destination_area(robot.info().world);
            loop {
                let (move_speed, turn_speed) = draw_speeds(&robot, cfg.move_speed, cfg.turn_speed);
                let dest = {
                    let mut rng = robot.rng();
                    let (u, v): (f64, f64) = (rng.gen(), rng.gen());
                    Point::new(lo.x + (hi.x - lo.x) * u, lo.y + (hi.y - lo.y) * v)
                };
                move_or_wait(&robot, dest, move_speed, turn_speed, cfg.retry).await;
            }
        })
    }
}

/// Seed 5.2: ask the GPS for all positions, go to their centroid, repeat. As in the seed's
/// code: move speed uniform in `[3, 6)`, turn speed = `3 + move_speed × U`.
///
/// When a move takes no time at all (the robot already stands on the centroid, or its way is
/// blocked by a robot it touches), it waits `retry` seconds before sensing again, so that
/// virtual time advances (see [`move_or_wait`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Gathering {
    pub move_speed: SpeedRange,
    pub turn_speed: Option<SpeedRange>,
    /// GPS error factor.
    pub error: f64,
    /// Wait after a move that took no time [s].
    pub retry: f64,
}

impl Default for Gathering {
    fn default() -> Self {
        Self {
            move_speed: SpeedRange {
                min: 3.0,
                spread: 3.0,
            },
            turn_speed: None,
            error: 0.0,
            retry: 1.0,
        }
    }
}

/// The centroid of points (seed 5.2 `getCentroid`).
pub fn centroid(points: impl IntoIterator<Item = Point>) -> Option<Point> {
    let (mut sum, mut n) = (Point::origin().coords, 0usize);
    for p in points {
        sum += p.coords;
        n += 1;
    }
    (n > 0).then(|| Point::from(sum / n as f64))
}

impl Algorithm for Gathering {
    fn name(&self) -> &str {
        "Gathering"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let cfg = self.clone();
        Box::pin(async move {
            loop {
                let all = robot.gps().all_positions(cfg.error).await;
                let Some(c) = centroid(all.into_iter().map(|(_, p)| p)) else {
                    return;
                };
                let (move_speed, turn_speed) = draw_speeds(&robot, cfg.move_speed, cfg.turn_speed);
                move_or_wait(&robot, c, move_speed, turn_speed, cfg.retry).await;
            }
        })
    }
}

/// Seed 5.3, asking for help: each robot multicasts a random GOTO order to all others, then
/// obeys the first order it receives, and repeats. As in the seed's code: destinations uniform
/// in a 700×700 square (placed at the world's lower-left corner, or centred on the origin in
/// an infinite world), turn speed `6 + randint(30)`, move speed `3 + randint(10)`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AskForHelp;

/// [`AskForHelp`]'s message (seed 5.3's `GOTO` message type).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Help {
    /// Go to `(x, y)`.
    #[serde(rename = "GOTO")]
    Goto(f64, f64),
}

impl Algorithm for AskForHelp {
    fn name(&self) -> &str {
        "AskForHelp"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        Box::pin(async move {
            let info = robot.info();
            let lo = match info.world {
                WorldSize::Bounded { min, .. } => min,
                WorldSize::Infinite => Point::new(-350.0, -350.0),
            };
            let others: Vec<_> = (0..info.count as u32).filter(|&p| p != info.id).collect();
            loop {
                let (x, y): (f64, f64) = {
                    let mut rng = robot.rng();
                    (rng.gen(), rng.gen())
                };
                let dest = Point::new(lo.x + 700.0 * x, lo.y + 700.0 * y);
                robot.send(others.clone(), &Help::Goto(dest.x, dest.y));
                let (turn_speed, move_speed) = {
                    let mut rng = robot.rng();
                    (
                        6.0 + rng.gen_range(0..30) as f64,
                        3.0 + rng.gen_range(0..10) as f64,
                    )
                };
                // The first order that arrives.
                let (_, Help::Goto(x, y)) = robot.receive_msg::<Help>().await;
                let goto = Point::new(x, y);
                // As the seed's TestCommunication does (seed 5.3).
                robot.log(format!(
                    "Someone told me to go to: ({:.3}, {:.3})",
                    goto.x, goto.y
                ));
                move_or_wait(&robot, goto, move_speed, turn_speed, 1.0).await;
            }
        })
    }
}

/// [`BroadcastLoad`]'s message: its `n`-th broadcast.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename = "LOAD")]
pub struct Load(pub u32);

/// Neko's latency test: broadcasts `count` messages through `layer` at exponentially
/// distributed intervals of mean `mean_interval` [s], and keeps receiving (deliveries are in
/// the trace, from which latency and throughput are computed).
#[derive(Clone, Debug, PartialEq)]
pub struct BroadcastLoad {
    pub layer: String,
    pub count: u32,
    pub mean_interval: f64,
}

impl Algorithm for BroadcastLoad {
    fn name(&self) -> &str {
        "BroadcastLoad"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let cfg = self.clone();
        Box::pin(async move {
            let Some(layer) = robot.layer(&cfg.layer) else {
                tracing::warn!(layer = cfg.layer, "BroadcastLoad: no such layer");
                return;
            };
            for i in 0..cfg.count {
                let u: f64 = robot.rng().gen();
                robot.sleep(-cfg.mean_interval * (1.0 - u).ln()).await;
                layer.broadcast(&Load(i));
            }
            loop {
                robot.receive().await;
            }
        })
    }
}

/// The agreement example: every robot proposes its own position as the meeting point to a
/// consensus layer (instance 0), then goes to the decided point. Every correct robot goes to the
/// same point, even if some robots crash (as many as the consensus tolerates).
#[derive(Clone, Debug, PartialEq)]
pub struct MeetingPoint {
    /// Id of the consensus layer.
    pub layer: String,
    pub move_speed: f64,
    pub turn_speed: f64,
}

impl Algorithm for MeetingPoint {
    fn name(&self) -> &str {
        "MeetingPoint"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let cfg = self.clone();
        Box::pin(async move {
            let here = robot.gps().self_position(0.0).await;
            let Some(consensus) = robot.layer(&cfg.layer) else {
                tracing::warn!(layer = cfg.layer, "MeetingPoint: no such layer");
                return;
            };
            consensus.propose(0, &Meet(here.x, here.y));
            loop {
                let (r, Meet(x, y)) = robot.receive_msg::<Meet>().await;
                if let nekosim_protocols::Indication::Decide { k: 0, .. } = r.ind {
                    robot
                        .move_to(Point::new(x, y), cfg.move_speed, cfg.turn_speed)
                        .await;
                    return;
                }
            }
        })
    }
}

/// [`MeetingPoint`]'s proposal: a meeting point.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename = "MEET")]
pub struct Meet(pub f64, pub f64);

/// [`PathReservation`]'s messages.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Reserve {
    /// Robot `who` asks for the straight path from `from` to `to`.
    #[serde(rename = "REQ")]
    Request {
        who: u32,
        from: (f64, f64),
        to: (f64, f64),
    },
    /// Robot `who` has arrived and releases its path.
    #[serde(rename = "REL")]
    Release { who: u32 },
}

/// Path reservation through a total-order broadcast layer: before moving, a robot broadcasts
/// its intended straight path (from where it stands to a random destination). Every robot
/// applies reservations in delivery order, which is the same everywhere, so all agree: a path
/// is granted when the strip it sweeps (the segment widened by both radii) stays clear of
/// every earlier unreleased path and of every robot's resting spot. A robot moves only along
/// its granted path, broadcasts a release on arrival, and asks again (a new random path) when
/// denied, after the next delivery. With collisions on, robots never collide.
#[derive(Clone, Debug, PartialEq)]
pub struct PathReservation {
    /// Id of a total-order broadcast layer.
    pub layer: String,
    pub move_speed: f64,
    pub turn_speed: f64,
}

/// What every robot knows of the reservations, rebuilt identically from the delivered sequence.
#[derive(Debug, Default)]
struct Reservations {
    /// Where each robot rests when it holds no path.
    rest: std::collections::BTreeMap<u32, Point>,
    /// Granted, unreleased paths.
    held: std::collections::BTreeMap<u32, (Point, Point)>,
}

impl Reservations {
    /// Applies a request of `who` for `[from, to]`; true when granted.
    fn request(&mut self, who: u32, from: Point, to: Point, reach: f64) -> bool {
        use crate::world::geometry::{point_segment_distance, segment_distance};
        if self.held.contains_key(&who) {
            return false;
        }
        let clear_of_paths = self
            .held
            .iter()
            .all(|(o, (a, b))| *o == who || segment_distance(from, to, *a, *b) > reach);
        let clear_of_spots = self.rest.iter().all(|(o, p)| {
            *o == who || self.held.contains_key(o) || point_segment_distance(*p, from, to) > reach
        });
        let granted = clear_of_paths && clear_of_spots;
        if granted {
            self.held.insert(who, (from, to));
        }
        granted
    }

    fn release(&mut self, who: u32) {
        if let Some((_, to)) = self.held.remove(&who) {
            self.rest.insert(who, to);
        }
    }
}

/// What a delivered reservation message did: whose request or release, and whether a request
/// was granted.
enum Applied {
    Request { who: u32, granted: bool },
    Release { who: u32 },
    Other,
}

impl Reservations {
    /// Applies one delivered message (in delivery order, the same at every robot).
    fn apply(&mut self, r: &crate::robot::Received, reach: f64) -> Applied {
        match r.msg::<Reserve>() {
            Some(Reserve::Request { who, from, to }) => {
                let granted = self.request(
                    who,
                    Point::new(from.0, from.1),
                    Point::new(to.0, to.1),
                    reach,
                );
                Applied::Request { who, granted }
            }
            Some(Reserve::Release { who }) => {
                self.release(who);
                Applied::Release { who }
            }
            None => Applied::Other,
        }
    }
}

impl Algorithm for PathReservation {
    fn name(&self) -> &str {
        "PathReservation"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let cfg = self.clone();
        Box::pin(async move {
            let info = robot.info();
            let me = info.id;
            // Every robot has the same radius in a reservation group; keep a margin for rounding.
            let reach = 2.0 * info.radius + 1e-6;
            let (lo, hi) = destination_area(info.world);
            let mut book = Reservations::default();
            for (id, p) in robot.gps().all_positions(0.0).await {
                book.rest.insert(id, p);
            }
            let Some(layer) = robot.layer(&cfg.layer) else {
                tracing::warn!(layer = cfg.layer, "PathReservation: no such layer");
                return;
            };
            let mut here = book.rest[&me];
            loop {
                let dest = {
                    let mut rng = robot.rng();
                    let r = info.radius;
                    let (u, v): (f64, f64) = (rng.gen(), rng.gen());
                    Point::new(
                        lo.x + r + (hi.x - lo.x - 2.0 * r) * u,
                        lo.y + r + (hi.y - lo.y - 2.0 * r) * v,
                    )
                };
                layer.broadcast(&Reserve::Request {
                    who: me,
                    from: (here.x, here.y),
                    to: (dest.x, dest.y),
                });
                // Apply deliveries in order until our own request is decided.
                let granted = loop {
                    if let Applied::Request { who, granted } =
                        book.apply(&robot.receive().await, reach)
                    {
                        if who == me {
                            break granted;
                        }
                    }
                };
                if granted {
                    robot.move_to(dest, cfg.move_speed, cfg.turn_speed).await;
                    here = dest;
                    layer.broadcast(&Reserve::Release { who: me });
                    // Wait for our own release before asking again, so every robot sees them in
                    // this order.
                    while !matches!(book.apply(&robot.receive().await, reach), Applied::Release { who } if who == me)
                    {
                    }
                } else {
                    // Denied: try another path once something changes.
                    robot.sleep(1.0).await;
                }
            }
        })
    }
}

// How scenarios configure the built-ins (`algorithm: Name(field: value, ...)`), through the
// same registry a user's algorithm is registered in (crate::registry).

use crate::config::{finite, positive, speed, Configured, Setting};
use nekosim_protocols::{FieldError, NoConfig, Service};

impl Configured for Idle {
    type Config = NoConfig;
    fn configure(_: NoConfig, _: &Setting) -> Result<Self, FieldError> {
        Ok(Idle)
    }
}

impl Configured for AskForHelp {
    type Config = NoConfig;
    fn configure(_: NoConfig, _: &Setting) -> Result<Self, FieldError> {
        Ok(AskForHelp)
    }
}

/// `Script([Turn(angle: 90.0, turn_speed: 30.0), Forward(..), MoveTo(..), Wait(2.0)])`.
#[derive(Debug, Deserialize)]
pub struct ScriptConfig(pub Vec<ScriptStep>);

impl Configured for Script {
    type Config = ScriptConfig;
    fn configure(ScriptConfig(steps): ScriptConfig, _: &Setting) -> Result<Self, FieldError> {
        for (k, step) in steps.iter().enumerate() {
            let p = |f: &str| format!("[0][{k}]{f}");
            match *step {
                ScriptStep::Turn { angle, turn_speed } => {
                    finite(&p(".angle"), "turn angle", angle)?;
                    speed(&p(".turn_speed"), "turn speed", turn_speed)?;
                }
                ScriptStep::Forward {
                    distance,
                    move_speed,
                } => {
                    finite(&p(".distance"), "distance", distance)?;
                    if distance < 0.0 {
                        return Err(FieldError::new(
                            &p(".distance"),
                            format!("distance is {distance}"),
                            "a number >= 0",
                        ));
                    }
                    speed(&p(".move_speed"), "move speed", move_speed)?;
                }
                ScriptStep::MoveTo {
                    x,
                    y,
                    move_speed,
                    turn_speed,
                } => {
                    finite(&p(".x"), "x", x)?;
                    finite(&p(".y"), "y", y)?;
                    speed(&p(".move_speed"), "move speed", move_speed)?;
                    speed(&p(".turn_speed"), "turn speed", turn_speed)?;
                }
                ScriptStep::Wait(d) => {
                    finite(&p("[0]"), "wait", d)?;
                    if d < 0.0 {
                        return Err(FieldError::new(
                            &p("[0]"),
                            format!("wait is {d}"),
                            "a duration >= 0",
                        ));
                    }
                }
            }
        }
        Ok(Script(steps))
    }
}

/// A `(min, max)` range read from a scenario, checked and turned into a [`SpeedRange`].
fn range(field: &str, what: &str, r: Option<(f64, f64)>) -> Result<Option<SpeedRange>, FieldError> {
    let Some((lo, hi)) = r else { return Ok(None) };
    speed(&format!("{field}[0]"), what, lo)?;
    speed(&format!("{field}[1]"), what, hi)?;
    if hi < lo {
        return Err(FieldError::new(
            field,
            format!("{what} range ({lo}, {hi}) is reversed"),
            "(min, max) with min <= max",
        ));
    }
    Ok(Some(SpeedRange {
        min: lo,
        spread: hi - lo,
    }))
}

/// `RandomMovement(move_speed: (3.0, 13.0), turn_speed: (10.0, 30.0), retry: 1.0)`, every
/// field optional (seed 5.1's speeds by default).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RandomMovementConfig {
    #[serde(default)]
    pub move_speed: Option<(f64, f64)>,
    #[serde(default)]
    pub turn_speed: Option<(f64, f64)>,
    /// Wait after a move that took no time (boxed in) [s]; default 1.
    #[serde(default)]
    pub retry: Option<f64>,
}

impl Configured for RandomMovement {
    type Config = RandomMovementConfig;
    fn configure(c: RandomMovementConfig, _: &Setting) -> Result<Self, FieldError> {
        let d = RandomMovement::default();
        Ok(RandomMovement {
            move_speed: range("move_speed", "move speed", c.move_speed)?.unwrap_or(d.move_speed),
            turn_speed: range("turn_speed", "turn speed", c.turn_speed)?,
            retry: match c.retry {
                Some(r) => positive("retry", "retry", r)?,
                None => d.retry,
            },
        })
    }
}

/// `Gathering(move_speed: (3.0, 6.0), turn_speed: .., error: 0.0, retry: 1.0)`, every field
/// optional (seed 5.2's speeds by default).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GatheringConfig {
    #[serde(default)]
    pub move_speed: Option<(f64, f64)>,
    #[serde(default)]
    pub turn_speed: Option<(f64, f64)>,
    /// GPS error factor.
    #[serde(default)]
    pub error: f64,
    /// Wait after a move that took no time (gathered, or blocked) [s]; default 1.
    #[serde(default)]
    pub retry: Option<f64>,
}

impl Configured for Gathering {
    type Config = GatheringConfig;
    fn configure(c: GatheringConfig, _: &Setting) -> Result<Self, FieldError> {
        let d = Gathering::default();
        finite("error", "error factor", c.error)?;
        if c.error < 0.0 {
            return Err(FieldError::new(
                "error",
                format!("error factor is {}", c.error),
                "a number >= 0",
            ));
        }
        Ok(Gathering {
            move_speed: range("move_speed", "move speed", c.move_speed)?.unwrap_or(d.move_speed),
            turn_speed: range("turn_speed", "turn speed", c.turn_speed)?,
            error: c.error,
            retry: match c.retry {
                Some(r) => positive("retry", "retry", r)?,
                None => d.retry,
            },
        })
    }
}

fn five() -> f64 {
    5.0
}

fn ninety() -> f64 {
    90.0
}

/// `MeetingPoint(layer: "consensus", move_speed: 5.0, turn_speed: 90.0)` and
/// `PathReservation(layer: "abcast", ..)`: a layer of the stack and speeds.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LayerMoveConfig {
    pub layer: String,
    #[serde(default = "five")]
    pub move_speed: f64,
    #[serde(default = "ninety")]
    pub turn_speed: f64,
}

impl Configured for MeetingPoint {
    type Config = LayerMoveConfig;
    fn configure(c: LayerMoveConfig, setting: &Setting) -> Result<Self, FieldError> {
        speed("move_speed", "move speed", c.move_speed)?;
        speed("turn_speed", "turn speed", c.turn_speed)?;
        if setting.layer(&c.layer).is_none() {
            return Err(FieldError::new(
                "layer",
                format!("no layer {:?} in the stack", c.layer),
                "the id of a consensus layer",
            ));
        }
        Ok(MeetingPoint {
            layer: c.layer,
            move_speed: c.move_speed,
            turn_speed: c.turn_speed,
        })
    }
}

impl Configured for PathReservation {
    type Config = LayerMoveConfig;
    fn configure(c: LayerMoveConfig, setting: &Setting) -> Result<Self, FieldError> {
        speed("move_speed", "move speed", c.move_speed)?;
        speed("turn_speed", "turn speed", c.turn_speed)?;
        if !setting
            .layer(&c.layer)
            .is_some_and(|s| s.serves(Service::TOTAL_ORDER))
        {
            return Err(FieldError::new(
                "layer",
                format!(
                    "{:?} is not a total-order broadcast layer of the stack",
                    c.layer
                ),
                "the id of one",
            ));
        }
        Ok(PathReservation {
            layer: c.layer,
            move_speed: c.move_speed,
            turn_speed: c.turn_speed,
        })
    }
}

/// `BroadcastLoad(layer: "abcast", count: 20, mean_interval: 1.0)`.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BroadcastLoadConfig {
    pub layer: String,
    pub count: u32,
    pub mean_interval: f64,
}

impl Configured for BroadcastLoad {
    type Config = BroadcastLoadConfig;
    fn configure(c: BroadcastLoadConfig, setting: &Setting) -> Result<Self, FieldError> {
        positive("mean_interval", "mean interval", c.mean_interval)?;
        if setting.layer(&c.layer).is_none() {
            return Err(FieldError::new(
                "layer",
                format!("no layer {:?} in the stack", c.layer),
                "the id of a broadcast layer",
            ));
        }
        Ok(BroadcastLoad {
            layer: c.layer,
            count: c.count,
            mean_interval: c.mean_interval,
        })
    }
}
