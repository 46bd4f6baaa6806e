//! Composable behaviours: reusable motion algorithms (seed 7.2, future work: "improvement of
//! reusability for motion algorithms ... to allow user to reuse the old motion algorithm
//! cooperating with new algorithm without having to re-write the code").
//!
//! A [`Behaviour`] is a tree of primitive behaviours ([`Behaviour::GoTo`],
//! [`Behaviour::Wander`], [`Behaviour::Wait`], [`Behaviour::WaitFor`], [`Behaviour::Avoid`],
//! [`Behaviour::Follow`]) combined by [`Behaviour::Sequence`], [`Behaviour::Repeat`],
//! [`Behaviour::Until`] and [`Behaviour::Race`]. The same value is a scenario's algorithm
//! (`algorithm: Behaviour(Repeat(Forever, Wander()))`, registered as `Behaviour`) and a Rust
//! value a user's algorithm runs on its robot (`behaviour.run(&robot).await`). The seed's random
//! movement (5.1) is `Repeat(Forever, Wander())` and its gathering (5.2) is
//! `Repeat(Forever, GoTo(to: Centroid))`: they draw the same random numbers in the same order
//! and issue the same requests as [`crate::algorithm::RandomMovement`] and
//! [`crate::algorithm::Gathering`], so their traces are byte-identical for the same seed.
//!
//! # Concurrency and cancellation
//!
//! The branches of a `Race` (and the body and condition of an `Until`) run at once on one robot:
//! one future polled branch by branch, in order, at each event, and only with the robot's seeded
//! random stream and virtual time, so a run stays deterministic. The first branch to finish wins
//! (ties go to the earlier branch); the others are cancelled at that same instant:
//!
//! - a motion a cancelled branch started and that is still running is stopped in the world by a
//!   replacing zero-length `Forward` (its `motion_finish` is `replaced` at the winner's instant);
//! - every push sensor a cancelled branch activated (the push proximity of `Avoid` and
//!   `Proximity`, the contact sensor of `Contact`) is deactivated, and its interrupts still
//!   queued are dropped.
//!
//! The robot has one body: when a branch starts a motion while another branch's motion runs, the
//! newer replaces the older (as [`Robot::start_motion`] does), and the branch whose motion was
//! replaced waits, doing nothing more, until its combinator ends and cancels it. Losing branches'
//! pending timers and sensor readings are simply ignored.
//!
//! A behaviour that moves and took no virtual time at all (blocked at its very start, or
//! already there) waits `retry` seconds, as [`crate::algorithm::move_or_wait`] does, so that a
//! `Repeat(Forever, ..)` never spins at one instant.

use std::cell::{Cell, RefCell};
use std::collections::VecDeque;
use std::future::{pending, poll_fn, Future};
use std::pin::{pin, Pin};
use std::rc::Rc;
use std::task::{Context, Poll};

use rand::Rng;
use serde::Deserialize;

use crate::algorithm::{centroid, destination_area};
use crate::registry::{finite, positive, speed, Configured, Setting};
use crate::robot::{Algorithm, AlgorithmFuture, MotionEnd, MotionTicket, Robot};
use crate::world::event::Notice;
use crate::world::geometry::{shortest_turn, vector_heading, Point};
use crate::world::motion::Motion;
use crate::world::sensor::builtins::Gap;
use crate::world::sensor::{SensorKind, SensorValue};
use crate::world::{MotionOutcome, RobotId};
use nekosim_protocols::FieldError;

/// A behaviour: a primitive one, or a combination of behaviours. In a scenario:
/// `algorithm: Behaviour(B)` with `B` written as the variants below are (RON, every field with
/// a default optional).
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Behaviour {
    /// `GoTo(to: Point(x, y) | Centroid, move_speed: S, turn_speed: S, error: E, retry: R)`:
    /// one MOVETO to a point, or to the centroid of all robots' GPS positions (with GPS error
    /// factor `error`, as seed 5.2 does). Speeds as [`Speed`]; by default seed 5.2's: move speed
    /// uniform in [3, 6), turn speed `3 + move × U`. Finishes when the motion ends.
    GoTo {
        to: Target,
        #[serde(default = "gathering_speed")]
        move_speed: Speed,
        #[serde(default)]
        turn_speed: Option<Speed>,
        /// GPS error factor (for `to: Centroid`).
        #[serde(default)]
        error: f64,
        /// Wait after a move that took no time [s].
        #[serde(default = "one")]
        retry: f64,
    },
    /// `Wander(area: ((x0, y0), (x1, y1)), move_speed: S, turn_speed: S, retry: R)`: one MOVETO
    /// to a random point of `area` (by default the world, or an 800×800 square centred on the
    /// origin in an infinite world) at random speeds, drawn as seed 5.1 does (by default move
    /// speed uniform in [3, 13), turn speed `3 + move × U`). Finishes when the motion ends.
    Wander {
        /// Lower-left and upper-right corners.
        #[serde(default)]
        area: Option<((f64, f64), (f64, f64))>,
        #[serde(default = "random_movement_speed")]
        move_speed: Speed,
        #[serde(default)]
        turn_speed: Option<Speed>,
        /// Wait after a move that took no time [s].
        #[serde(default = "one")]
        retry: f64,
    },
    /// `Wait(t)`: waits `t` [s] (> 0).
    Wait(f64),
    /// `WaitFor(C)`: waits until the [`Condition`] holds.
    WaitFor(Condition),
    /// `Avoid(range: R, turn_speed: T, back_off: D, move_speed: M, retry: W)`: activates the push
    /// proximity sensor with `range` [units, border to border]; when another robot comes within
    /// it (or already is), deactivates it, stops, turns on the spot to face away from the
    /// nearest such robot at `turn_speed` [deg/s] (default 90), then backs off `back_off` units
    /// forward at `move_speed` (defaults: `range` and 5). Finishes then.
    Avoid {
        range: f64,
        #[serde(default = "ninety")]
        turn_speed: f64,
        #[serde(default)]
        back_off: Option<f64>,
        #[serde(default = "five")]
        move_speed: f64,
        /// Wait when the whole manoeuvre took no time [s].
        #[serde(default = "one")]
        retry: f64,
    },
    /// `Follow(robot: ID, distance: D, move_speed: M, turn_speed: T, period: P)`: every `period`
    /// [s] (default 1) reads the GPS; when robot `ID`'s centre is farther than `distance` from
    /// the own centre, moves (MOVETO at `move_speed`, default 5, and `turn_speed`, default 90) to
    /// the point at `distance` from it on the line between them, else stops. Never finishes.
    Follow {
        robot: RobotId,
        distance: f64,
        #[serde(default = "five")]
        move_speed: f64,
        #[serde(default = "ninety")]
        turn_speed: f64,
        #[serde(default = "one")]
        period: f64,
    },
    /// `Sequence([B, ...])`: runs each behaviour after the previous one finished.
    Sequence(Vec<Behaviour>),
    /// `Repeat(Times(n), B)` or `Repeat(Forever, B)`: runs `B` `n` times (>= 1), or forever.
    Repeat(Count, Box<Behaviour>),
    /// `Until(C, B)`: runs `B` until the [`Condition`] `C` holds, then cancels it; finishes when
    /// either happens first (a `Race` of `B` and `WaitFor(C)`).
    Until(Condition, Box<Behaviour>),
    /// `Race([B, ...])`: runs all at once; the first to finish cancels the others.
    Race(Vec<Behaviour>),
}

/// Where [`Behaviour::GoTo`] goes.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
pub enum Target {
    /// `Point(x, y)`.
    Point(f64, f64),
    /// The centroid of all robots' GPS positions, read when the behaviour starts (seed 5.2).
    Centroid,
}

/// What [`Behaviour::Until`] and [`Behaviour::WaitFor`] wait for.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
pub enum Condition {
    /// `Time(t)`: `t` [s] (> 0) have passed since the condition started.
    Time(f64),
    /// `Message`: a message or layer indication arrives (one already waiting counts); it is
    /// consumed.
    Message,
    /// `Proximity(r)`: another robot is within `r` [units, border to border] (push proximity
    /// sensor, active while waiting).
    Proximity(f64),
    /// `Contact`: the robot touches a robot or a wall (contact sensor, active while waiting).
    Contact,
}

/// How many times [`Behaviour::Repeat`] runs its behaviour: `Times(n)` or `Forever`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
pub enum Count {
    Times(u32),
    Forever,
}

/// A speed [units/s or deg/s]: `5.0` (fixed) or `(min, max)`, drawn uniformly in
/// `[min, max)` from the robot's random stream each time it is used (as the seed's code draws
/// `min + (max - min) × U`).
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(untagged, expecting = "a speed (a number) or a range (min, max)")]
pub enum Speed {
    Fixed(f64),
    Range(f64, f64),
}

impl Speed {
    fn min(self) -> f64 {
        match self {
            Speed::Fixed(v) | Speed::Range(v, _) => v,
        }
    }

    fn draw(self, rng: &mut impl Rng) -> f64 {
        match self {
            Speed::Fixed(v) => v,
            Speed::Range(lo, hi) => lo + (hi - lo) * rng.gen::<f64>(),
        }
    }

    fn check(self, path: &str, what: &str) -> Result<(), FieldError> {
        match self {
            Speed::Fixed(v) => speed(path, what, v).map(drop),
            Speed::Range(lo, hi) => {
                speed(&format!("{path}[0]"), what, lo)?;
                speed(&format!("{path}[1]"), what, hi)?;
                if hi < lo {
                    return Err(FieldError::new(
                        path,
                        format!("{what} range ({lo}, {hi}) is reversed"),
                        "(min, max) with min <= max",
                    ));
                }
                Ok(())
            }
        }
    }
}

fn one() -> f64 {
    1.0
}

fn five() -> f64 {
    5.0
}

fn ninety() -> f64 {
    90.0
}

fn gathering_speed() -> Speed {
    Speed::Range(3.0, 6.0)
}

fn random_movement_speed() -> Speed {
    Speed::Range(3.0, 13.0)
}

/// Move and turn speeds, drawn in the seed's order: move speed, then turn speed (from its own
/// range, else the seed's rule `min move speed + move speed × U`).
fn draw_speeds(robot: &Robot, ms: Speed, ts: Option<Speed>) -> (f64, f64) {
    let mut rng = robot.rng();
    let move_speed = ms.draw(&mut *rng);
    let turn_speed = match ts {
        Some(t) => t.draw(&mut *rng),
        None => ms.min() + move_speed * rng.gen::<f64>(),
    };
    (move_speed, turn_speed)
}

// Building behaviours in Rust.
impl Behaviour {
    /// `GoTo(to: Point(x, y), move_speed, turn_speed)` at fixed speeds.
    pub fn go_to(x: f64, y: f64, move_speed: f64, turn_speed: f64) -> Self {
        Behaviour::GoTo {
            to: Target::Point(x, y),
            move_speed: Speed::Fixed(move_speed),
            turn_speed: Some(Speed::Fixed(turn_speed)),
            error: 0.0,
            retry: 1.0,
        }
    }

    /// `GoTo(to: Centroid)` with seed 5.2's speeds.
    pub fn go_to_centroid() -> Self {
        Behaviour::GoTo {
            to: Target::Centroid,
            move_speed: gathering_speed(),
            turn_speed: None,
            error: 0.0,
            retry: 1.0,
        }
    }

    /// `Wander()` with seed 5.1's speeds over the world.
    pub fn wander() -> Self {
        Behaviour::Wander {
            area: None,
            move_speed: random_movement_speed(),
            turn_speed: None,
            retry: 1.0,
        }
    }

    /// `Avoid(range: range)` with the default speeds and back-off.
    pub fn avoid(range: f64) -> Self {
        Behaviour::Avoid {
            range,
            turn_speed: 90.0,
            back_off: None,
            move_speed: 5.0,
            retry: 1.0,
        }
    }

    /// `Follow(robot, distance)` with the default speeds and period.
    pub fn follow(robot: RobotId, distance: f64) -> Self {
        Behaviour::Follow {
            robot,
            distance,
            move_speed: 5.0,
            turn_speed: 90.0,
            period: 1.0,
        }
    }

    /// This behaviour, then `next`.
    pub fn then(self, next: Behaviour) -> Self {
        match self {
            Behaviour::Sequence(mut v) => {
                v.push(next);
                Behaviour::Sequence(v)
            }
            b => Behaviour::Sequence(vec![b, next]),
        }
    }

    /// `Repeat(n, self)`.
    pub fn times(self, n: u32) -> Self {
        Behaviour::Repeat(Count::Times(n), Box::new(self))
    }

    /// `Repeat(Forever, self)`.
    pub fn forever(self) -> Self {
        Behaviour::Repeat(Count::Forever, Box::new(self))
    }

    /// `Until(condition, self)`.
    pub fn until(self, condition: Condition) -> Self {
        Behaviour::Until(condition, Box::new(self))
    }

    /// `Race([self, other])` (or `other` added to this race).
    pub fn race(self, other: Behaviour) -> Self {
        match self {
            Behaviour::Race(mut v) => {
                v.push(other);
                Behaviour::Race(v)
            }
            b => Behaviour::Race(vec![b, other]),
        }
    }

    /// Runs the behaviour on `robot` until it finishes (see the module doc for how branches
    /// share the robot). Incoming messages the behaviour takes from the robot while it waits for
    /// a sensor and does not use (no `Message` condition claims them) are dropped when it
    /// finishes.
    pub async fn run(&self, robot: &Robot) {
        let rt = Runtime {
            robot: robot.clone(),
            held: RefCell::new(VecDeque::new()),
            moved: Cell::new(0),
            motion: RefCell::new(None),
            sensors: RefCell::new(Vec::new()),
            next_scope: Cell::new(0),
        };
        self.exec(&rt, Rc::new(Vec::new())).await;
    }

    /// Checks every number of the tree; `path` is where this behaviour is in the scenario's
    /// configuration (fields `.name`, positional elements `[k]`).
    pub fn check(&self, path: &str) -> Result<(), FieldError> {
        let at = |f: &str| format!("{path}{f}");
        let nonneg = |p: &str, what: &str, v: f64| -> Result<(), FieldError> {
            finite(p, what, v)?;
            if v < 0.0 {
                return Err(FieldError::value(p, what, v, "a number >= 0"));
            }
            Ok(())
        };
        match self {
            Behaviour::GoTo {
                to,
                move_speed,
                turn_speed,
                error,
                retry,
            } => {
                if let Target::Point(x, y) = *to {
                    finite(&at(".to[0]"), "x", x)?;
                    finite(&at(".to[1]"), "y", y)?;
                }
                move_speed.check(&at(".move_speed"), "move speed")?;
                if let Some(t) = turn_speed {
                    t.check(&at(".turn_speed"), "turn speed")?;
                }
                nonneg(&at(".error"), "error factor", *error)?;
                positive(&at(".retry"), "retry", *retry)?;
            }
            Behaviour::Wander {
                area,
                move_speed,
                turn_speed,
                retry,
            } => {
                if let Some(((x0, y0), (x1, y1))) = *area {
                    for (k, v) in [x0, y0, x1, y1].into_iter().enumerate() {
                        finite(&at(&format!(".area[{}][{}]", k / 2, k % 2)), "corner", v)?;
                    }
                    if x1 < x0 || y1 < y0 {
                        return Err(FieldError::new(
                            &at(".area"),
                            format!("area (({x0}, {y0}), ({x1}, {y1})) is reversed"),
                            "((min x, min y), (max x, max y))",
                        ));
                    }
                }
                move_speed.check(&at(".move_speed"), "move speed")?;
                if let Some(t) = turn_speed {
                    t.check(&at(".turn_speed"), "turn speed")?;
                }
                positive(&at(".retry"), "retry", *retry)?;
            }
            Behaviour::Wait(t) => {
                positive(&at("[0]"), "wait", *t)?;
            }
            Behaviour::WaitFor(c) => c.check(&at("[0]"))?,
            Behaviour::Avoid {
                range,
                turn_speed,
                back_off,
                move_speed,
                retry,
            } => {
                nonneg(&at(".range"), "range", *range)?;
                speed(&at(".turn_speed"), "turn speed", *turn_speed)?;
                if let Some(d) = back_off {
                    nonneg(&at(".back_off"), "back-off distance", *d)?;
                }
                positive(&at(".move_speed"), "move speed", *move_speed)?;
                positive(&at(".retry"), "retry", *retry)?;
            }
            Behaviour::Follow {
                distance,
                move_speed,
                turn_speed,
                period,
                ..
            } => {
                nonneg(&at(".distance"), "distance", *distance)?;
                positive(&at(".move_speed"), "move speed", *move_speed)?;
                speed(&at(".turn_speed"), "turn speed", *turn_speed)?;
                positive(&at(".period"), "period", *period)?;
            }
            Behaviour::Sequence(v) | Behaviour::Race(v) => {
                if v.is_empty() {
                    return Err(FieldError::new(
                        &at("[0]"),
                        "an empty list",
                        "at least one behaviour",
                    ));
                }
                for (k, b) in v.iter().enumerate() {
                    b.check(&at(&format!("[0][{k}]")))?;
                }
            }
            Behaviour::Repeat(n, b) => {
                if *n == Count::Times(0) {
                    return Err(FieldError::new(
                        &at("[0][0]"),
                        "repeat count is 0",
                        "a count >= 1 or `Forever`",
                    ));
                }
                b.check(&at("[1]"))?;
            }
            Behaviour::Until(c, b) => {
                c.check(&at("[0]"))?;
                b.check(&at("[1]"))?;
            }
        }
        Ok(())
    }
}

impl Condition {
    fn check(&self, path: &str) -> Result<(), FieldError> {
        match *self {
            Condition::Time(t) => positive(&format!("{path}[0]"), "time", t).map(drop),
            Condition::Proximity(r) => {
                let p = format!("{path}[0]");
                finite(&p, "range", r)?;
                if r < 0.0 {
                    return Err(FieldError::value(&p, "range", r, "a number >= 0"));
                }
                Ok(())
            }
            Condition::Message | Condition::Contact => Ok(()),
        }
    }
}

/// Who owns a motion or a sensor: a branch, by its path of scope numbers from the root (a
/// branch owns what its sub-branches own).
type Scope = Rc<Vec<u32>>;

fn within(owner: &Scope, scope: &Scope) -> bool {
    owner.starts_with(scope)
}

/// What the branches of one running behaviour share: the robot, the notices taken from the
/// robot's inbox that no branch has claimed yet, and who owns the running motion and the
/// active push sensors.
struct Runtime {
    robot: Robot,
    /// Notices taken from the robot (while draining for an interrupt) and not yet claimed.
    held: RefCell<VecDeque<Notice>>,
    /// How many notices were ever moved into `held`: a race polls its branches again while
    /// this grows, so that a branch polled before the move still sees its notice at this
    /// instant.
    moved: Cell<u64>,
    /// The motion the behaviour started last, while it runs, and its owner.
    motion: RefCell<Option<(u64, Scope)>>,
    /// The push sensors the behaviour activated and their owners.
    sensors: RefCell<Vec<(SensorKind, Scope)>>,
    next_scope: Cell<u32>,
}

type Local<'a> = Pin<Box<dyn Future<Output = ()> + 'a>>;

/// A branch of a race: builds its future given its scope.
type Branch<'a> = Box<dyn FnOnce(Scope) -> Local<'a> + 'a>;

/// Polls `f` once, now: for the robot's own waits, which are ready as soon as their notice is
/// in the inbox.
fn poll_now<T>(f: impl Future<Output = T>, cx: &mut Context<'_>) -> Option<T> {
    match pin!(f).poll(cx) {
        Poll::Ready(v) => Some(v),
        Poll::Pending => None,
    }
}

impl Runtime {
    fn child(&self, scope: &Scope) -> Scope {
        let k = self.next_scope.get();
        self.next_scope.set(k + 1);
        let mut s = (**scope).clone();
        s.push(k);
        Rc::new(s)
    }

    /// Removes and returns the first held notice `pick` accepts.
    fn claim<T>(&self, pick: impl Fn(&Notice) -> Option<T>) -> Option<T> {
        let mut held = self.held.borrow_mut();
        let (i, v) = held
            .iter()
            .enumerate()
            .find_map(|(i, n)| pick(n).map(|v| (i, v)))?;
        held.remove(i);
        Some(v)
    }

    /// Moves every interrupt, motion end and message waiting in the robot's inbox into `held`
    /// (the robot offers no wait for interrupts alone).
    fn drain(&self, cx: &mut Context<'_>) {
        while let Some(n) = poll_now(self.robot.next_notice(), cx) {
            self.held.borrow_mut().push_back(n);
            self.moved.set(self.moved.get() + 1);
        }
    }

    fn ended(&self, ticket: u64, end: MotionEnd) -> MotionEnd {
        let mut m = self.motion.borrow_mut();
        if m.as_ref().is_some_and(|(t, _)| *t == ticket) {
            *m = None;
        }
        end
    }

    /// The end of motion `ticket`, if it has ended.
    fn try_motion_end(&self, ticket: u64, cx: &mut Context<'_>) -> Option<MotionEnd> {
        let end = self
            .claim(|n| match n {
                Notice::MotionEnded {
                    ticket: t,
                    outcome,
                    state,
                } if *t == ticket => Some(MotionEnd {
                    outcome: outcome.clone(),
                    state: *state,
                }),
                _ => None,
            })
            .or_else(|| poll_now(self.robot.wait_motion(MotionTicket(ticket)), cx))?;
        Some(self.ended(ticket, end))
    }

    /// Waits for the end of motion `ticket`, however it ends.
    async fn motion_end(&self, ticket: u64) -> MotionEnd {
        poll_fn(|cx| match self.try_motion_end(ticket, cx) {
            Some(e) => Poll::Ready(e),
            None => Poll::Pending,
        })
        .await
    }

    /// Starts `motion` for `scope`, replacing any running one.
    fn start_motion(&self, scope: &Scope, motion: Motion) -> u64 {
        let t = self.robot.start_motion(motion).0;
        *self.motion.borrow_mut() = Some((t, scope.clone()));
        t
    }

    /// Performs `motion` for `scope`. If another branch replaces it, the branch waits until it
    /// is cancelled.
    async fn motion(&self, scope: &Scope, motion: Motion) -> MotionEnd {
        let t = self.start_motion(scope, motion);
        let end = self.motion_end(t).await;
        if end.outcome == MotionOutcome::Replaced {
            pending::<()>().await;
        }
        end
    }

    /// MOVETO, or a wait of `retry` if it took no time (as [`crate::algorithm::move_or_wait`]).
    async fn move_or_wait(&self, scope: &Scope, dest: Point, ms: f64, ts: f64, retry: f64) {
        let started = self.robot.now();
        self.motion(
            scope,
            Motion::MoveTo {
                dest,
                move_speed: ms,
                turn_speed: ts,
            },
        )
        .await;
        if self.robot.now() == started {
            self.robot.sleep(retry).await;
        }
    }

    /// Waits for an interrupt of `sensor`: its value.
    async fn interrupt(&self, sensor: SensorKind) -> SensorValue {
        let pick = |n: &Notice| match n {
            Notice::Interrupt { sensor: s, value } if *s == sensor => Some(value.clone()),
            _ => None,
        };
        poll_fn(|cx| {
            if let Some(v) = self.claim(pick) {
                return Poll::Ready(v);
            }
            self.drain(cx);
            match self.claim(pick) {
                Some(v) => Poll::Ready(v),
                None => Poll::Pending,
            }
        })
        .await
    }

    /// Waits for a message or indication and consumes it.
    async fn message(&self) {
        poll_fn(|cx| {
            if self
                .claim(|n| matches!(n, Notice::Incoming { .. }).then_some(()))
                .is_some()
                || poll_now(self.robot.receive(), cx).is_some()
            {
                Poll::Ready(())
            } else {
                Poll::Pending
            }
        })
        .await
    }

    /// Drops the queued interrupts of `sensor` (from an earlier activation).
    async fn purge(&self, sensor: SensorKind) {
        poll_fn(|cx| {
            self.drain(cx);
            Poll::Ready(())
        })
        .await;
        self.held
            .borrow_mut()
            .retain(|n| !matches!(n, Notice::Interrupt { sensor: s, .. } if *s == sensor));
    }

    /// Activates push proximity (`Some(range)`) or contact (`None`) for `scope`.
    async fn activate(&self, scope: &Scope, proximity: Option<f64>) -> SensorKind {
        let kind = match proximity {
            Some(_) => SensorKind::PUSH_PROXIMITY,
            None => SensorKind::CONTACT,
        };
        self.purge(kind).await;
        // Owned before the request is answered, so a branch cancelled meanwhile still has it
        // deactivated.
        self.sensors.borrow_mut().push((kind, scope.clone()));
        match proximity {
            Some(range) => {
                self.robot.activate_proximity(range, 0.0).await;
            }
            None => self.robot.activate_contact().await,
        }
        kind
    }

    async fn deactivate(&self, sensor: SensorKind) {
        self.sensors.borrow_mut().retain(|(k, _)| *k != sensor);
        if sensor == SensorKind::CONTACT {
            self.robot.deactivate_contact().await;
        } else {
            self.robot.deactivate_proximity().await;
        }
        self.purge(sensor).await;
    }

    /// Stops what the cancelled branch `scope` left running: its motion and its sensors.
    async fn cancel(&self, scope: &Scope) {
        let owned = self
            .motion
            .borrow()
            .as_ref()
            .filter(|(_, owner)| within(owner, scope))
            .map(|(t, _)| *t);
        if let Some(t) = owned {
            let done = poll_fn(|cx| Poll::Ready(self.try_motion_end(t, cx))).await;
            if done.is_none() {
                let stop = self.start_motion(
                    scope,
                    Motion::Forward {
                        distance: 0.0,
                        move_speed: 1.0,
                    },
                );
                self.motion_end(t).await;
                self.motion_end(stop).await;
            }
        }
        let sensors: Vec<SensorKind> = self
            .sensors
            .borrow()
            .iter()
            .filter(|(_, owner)| within(owner, scope))
            .map(|(k, _)| *k)
            .collect();
        for k in sensors {
            self.deactivate(k).await;
        }
    }

    /// Runs `branches` at once; the first to finish wins and the others are cancelled.
    async fn race<'a>(&'a self, scope: &Scope, branches: Vec<Branch<'a>>) {
        let scopes: Vec<Scope> = branches.iter().map(|_| self.child(scope)).collect();
        let mut futures: Vec<Local<'a>> = branches
            .into_iter()
            .zip(&scopes)
            .map(|(b, s)| b(s.clone()))
            .collect();
        let winner = poll_fn(|cx| loop {
            let moved = self.moved.get();
            for (i, f) in futures.iter_mut().enumerate() {
                if f.as_mut().poll(cx).is_ready() {
                    return Poll::Ready(i);
                }
            }
            if self.moved.get() == moved {
                return Poll::Pending;
            }
        })
        .await;
        drop(futures);
        for (i, s) in scopes.iter().enumerate() {
            if i != winner {
                self.cancel(s).await;
            }
        }
    }

    async fn condition(&self, scope: &Scope, c: Condition) {
        match c {
            Condition::Time(t) => self.robot.sleep(t).await,
            Condition::Message => self.message().await,
            Condition::Proximity(range) => {
                let k = self.activate(scope, Some(range)).await;
                self.interrupt(k).await;
                self.deactivate(k).await;
            }
            Condition::Contact => {
                let k = self.activate(scope, None).await;
                self.interrupt(k).await;
                self.deactivate(k).await;
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    async fn avoid(
        &self,
        scope: &Scope,
        range: f64,
        turn_speed: f64,
        back_off: f64,
        move_speed: f64,
        retry: f64,
    ) {
        let k = self.activate(scope, Some(range)).await;
        let gaps = self
            .interrupt(k)
            .await
            .decode::<Vec<Gap>>()
            .unwrap_or_default();
        self.deactivate(k).await;
        let started = self.robot.now();
        // Stop where we are (replacing any motion) and learn the heading.
        let here = self
            .motion(
                scope,
                Motion::Forward {
                    distance: 0.0,
                    move_speed: 1.0,
                },
            )
            .await
            .state;
        let nearest = gaps
            .iter()
            .min_by(|a, b| {
                a.distance
                    .total_cmp(&b.distance)
                    .then(a.robot.cmp(&b.robot))
            })
            .map(|g| g.robot);
        let other = match nearest {
            Some(id) => self
                .robot
                .gps()
                .all_positions(0.0)
                .await
                .into_iter()
                .find(|(r, _)| *r == id)
                .map(|(_, p)| p),
            None => None,
        };
        if let Some(p) = other.filter(|p| *p != here.pos) {
            let angle = shortest_turn(here.angle, vector_heading(here.pos - p));
            self.motion(scope, Motion::Turn { angle, turn_speed }).await;
            if back_off > 0.0 {
                self.motion(
                    scope,
                    Motion::Forward {
                        distance: back_off,
                        move_speed,
                    },
                )
                .await;
            }
        }
        if self.robot.now() == started {
            self.robot.sleep(retry).await;
        }
    }

    async fn follow(
        &self,
        scope: &Scope,
        target: RobotId,
        distance: f64,
        move_speed: f64,
        turn_speed: f64,
        period: f64,
    ) {
        let me = self.robot.id();
        if target == me || target as usize >= self.robot.info().count {
            self.robot
                .log(format!("Follow: there is no other robot {target}"));
            return pending().await;
        }
        let mut running: Option<u64> = None;
        loop {
            if let Some(t) = running {
                let end = poll_fn(|cx| Poll::Ready(self.try_motion_end(t, cx))).await;
                match end.map(|e| e.outcome) {
                    // Another branch took the body over.
                    Some(MotionOutcome::Replaced) => return pending().await,
                    Some(_) => running = None,
                    None => {}
                }
            }
            let all = self.robot.gps().all_positions(0.0).await;
            let find = |id| all.iter().find(|(r, _)| *r == id).map(|(_, p)| *p);
            let next = match (find(me), find(target)) {
                (Some(mine), Some(theirs)) if (theirs - mine).norm() > distance => {
                    let gap = (theirs - mine).norm();
                    Some(Motion::MoveTo {
                        dest: theirs + (mine - theirs) * (distance / gap),
                        move_speed,
                        turn_speed,
                    })
                }
                _ if running.is_some() => Some(Motion::Forward {
                    distance: 0.0,
                    move_speed: 1.0,
                }),
                _ => None,
            };
            if let Some(m) = next {
                let t = self.start_motion(scope, m);
                if let Some(old) = running.replace(t) {
                    self.motion_end(old).await;
                }
            }
            self.robot.sleep(period).await;
        }
    }
}

impl Behaviour {
    fn exec<'a>(&'a self, rt: &'a Runtime, scope: Scope) -> Local<'a> {
        Box::pin(async move {
            let robot = &rt.robot;
            match self {
                Behaviour::GoTo {
                    to,
                    move_speed,
                    turn_speed,
                    error,
                    retry,
                } => {
                    let dest = match *to {
                        Target::Point(x, y) => Point::new(x, y),
                        Target::Centroid => {
                            let all = robot.gps().all_positions(*error).await;
                            match centroid(all.into_iter().map(|(_, p)| p)) {
                                Some(c) => c,
                                None => return robot.sleep(*retry).await,
                            }
                        }
                    };
                    let (ms, ts) = draw_speeds(robot, *move_speed, *turn_speed);
                    rt.move_or_wait(&scope, dest, ms, ts, *retry).await;
                }
                Behaviour::Wander {
                    area,
                    move_speed,
                    turn_speed,
                    retry,
                } => {
                    let (lo, hi) = match *area {
                        Some(((x0, y0), (x1, y1))) => (Point::new(x0, y0), Point::new(x1, y1)),
                        None => destination_area(robot.info().world),
                    };
                    let (ms, ts) = draw_speeds(robot, *move_speed, *turn_speed);
                    let dest = {
                        let mut rng = robot.rng();
                        let (u, v): (f64, f64) = (rng.gen(), rng.gen());
                        Point::new(lo.x + (hi.x - lo.x) * u, lo.y + (hi.y - lo.y) * v)
                    };
                    rt.move_or_wait(&scope, dest, ms, ts, *retry).await;
                }
                Behaviour::Wait(t) => robot.sleep(*t).await,
                Behaviour::WaitFor(c) => rt.condition(&scope, *c).await,
                Behaviour::Avoid {
                    range,
                    turn_speed,
                    back_off,
                    move_speed,
                    retry,
                } => {
                    rt.avoid(
                        &scope,
                        *range,
                        *turn_speed,
                        back_off.unwrap_or(*range),
                        *move_speed,
                        *retry,
                    )
                    .await
                }
                Behaviour::Follow {
                    robot: target,
                    distance,
                    move_speed,
                    turn_speed,
                    period,
                } => {
                    rt.follow(
                        &scope,
                        *target,
                        *distance,
                        *move_speed,
                        *turn_speed,
                        *period,
                    )
                    .await
                }
                Behaviour::Sequence(v) => {
                    for b in v {
                        b.exec(rt, scope.clone()).await;
                    }
                }
                Behaviour::Repeat(Count::Times(n), b) => {
                    for _ in 0..*n {
                        b.exec(rt, scope.clone()).await;
                    }
                }
                Behaviour::Repeat(Count::Forever, b) => loop {
                    b.exec(rt, scope.clone()).await;
                },
                Behaviour::Until(c, b) => {
                    let c = *c;
                    rt.race(
                        &scope,
                        vec![
                            Box::new(move |s| b.exec(rt, s)) as Branch<'a>,
                            Box::new(move |s: Scope| {
                                Box::pin(async move { rt.condition(&s, c).await }) as Local<'a>
                            }),
                        ],
                    )
                    .await
                }
                Behaviour::Race(v) => {
                    rt.race(
                        &scope,
                        v.iter()
                            .map(|b| Box::new(move |s| b.exec(rt, s)) as Branch<'a>)
                            .collect(),
                    )
                    .await
                }
            }
        })
    }
}

impl Algorithm for Behaviour {
    fn name(&self) -> &str {
        "Behaviour"
    }
    fn run(&self, robot: Robot) -> AlgorithmFuture {
        let b = self.clone();
        Box::pin(async move { b.run(&robot).await })
    }
}

/// `Behaviour(B)`: the configuration of the `Behaviour` algorithm, one behaviour tree.
#[derive(Debug, Deserialize)]
pub struct BehaviourConfig(pub Behaviour);

impl Configured for Behaviour {
    type Config = BehaviourConfig;
    fn configure(BehaviourConfig(b): BehaviourConfig, _: &Setting) -> Result<Self, FieldError> {
        b.check("[0]")?;
        Ok(b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nekosim_protocols::{Spec, SpecError};

    /// Reads `Behaviour(..)` as a scenario's algorithm is read.
    fn read(text: &str) -> Result<Behaviour, SpecError> {
        Spec::new(text).configure(|c| Behaviour::configure(c, &Setting::default()))
    }

    fn err(text: &str) -> SpecError {
        read(text).expect_err(text)
    }

    #[test]
    fn the_seed_examples_read_as_short_compositions() {
        assert_eq!(
            read("Behaviour(Repeat(Forever, Wander()))").unwrap(),
            Behaviour::wander().forever()
        );
        assert_eq!(
            read("Behaviour(Repeat(Forever, GoTo(to: Centroid)))").unwrap(),
            Behaviour::go_to_centroid().forever()
        );
        // The registry knows the name.
        let spec = Spec::new("Behaviour(Repeat(Times(3), Wait(1.0)))");
        crate::registry::Algorithms::with_builtins()
            .build(&spec, &Setting::default())
            .unwrap();
    }

    #[test]
    fn every_behaviour_and_combinator_reads() {
        let b = read(
            "Behaviour(Sequence([
                GoTo(to: Point(1.0, 2.0), move_speed: 5, turn_speed: (10.0, 30.0)),
                Repeat(Times(3), Wait(1.5)),
                Until(Message, Follow(robot: 1, distance: 5.0, period: 0.5)),
                Race([Avoid(range: 3.0, back_off: 0.0), WaitFor(Time(2.0))]),
                Until(Proximity(2.0), Wander(area: ((0.0, 0.0), (10.0, 20.0)))),
                Until(Contact, Wait(1.0)),
            ]))",
        )
        .unwrap();
        let want = Behaviour::Sequence(vec![
            Behaviour::GoTo {
                to: Target::Point(1.0, 2.0),
                move_speed: Speed::Fixed(5.0),
                turn_speed: Some(Speed::Range(10.0, 30.0)),
                error: 0.0,
                retry: 1.0,
            },
            Behaviour::Wait(1.5).times(3),
            Behaviour::Follow {
                robot: 1,
                distance: 5.0,
                move_speed: 5.0,
                turn_speed: 90.0,
                period: 0.5,
            }
            .until(Condition::Message),
            Behaviour::Avoid {
                range: 3.0,
                turn_speed: 90.0,
                back_off: Some(0.0),
                move_speed: 5.0,
                retry: 1.0,
            }
            .race(Behaviour::WaitFor(Condition::Time(2.0))),
            Behaviour::Wander {
                area: Some(((0.0, 0.0), (10.0, 20.0))),
                move_speed: Speed::Range(3.0, 13.0),
                turn_speed: None,
                retry: 1.0,
            }
            .until(Condition::Proximity(2.0)),
            Behaviour::Wait(1.0).until(Condition::Contact),
        ]);
        assert_eq!(b, want);
    }

    #[test]
    fn refused_values_name_their_field() {
        let cases = [
            (
                "Behaviour(Repeat(Forever, Sequence([Wander(), Wait(-1.0)])))",
                "[0][1][0][1][0]",
                "Behaviour: wait is -1; expected a number > 0",
            ),
            (
                "Behaviour(Repeat(Times(0), Wander()))",
                "[0][0][0]",
                "Behaviour: repeat count is 0; expected a count >= 1 or `Forever`",
            ),
            (
                "Behaviour(Wander(move_speed: (13.0, 3.0)))",
                "[0].move_speed",
                "Behaviour: move speed range (13, 3) is reversed; expected (min, max) with min <= max",
            ),
            (
                "Behaviour(Race([GoTo(to: Point(1.0, 2.0), turn_speed: 0.0), Wait(1.0)]))",
                "[0][0][0].turn_speed",
                "Behaviour: turn speed is 0; expected a number > 0",
            ),
            (
                "Behaviour(Until(Time(0.0), Wait(1.0)))",
                "[0][0][0]",
                "Behaviour: time is 0; expected a number > 0",
            ),
            (
                "Behaviour(Sequence([]))",
                "[0][0]",
                "Behaviour: an empty list; expected at least one behaviour",
            ),
            (
                "Behaviour(Follow(robot: 2, distance: -1.0))",
                "[0].distance",
                "Behaviour: distance is -1; expected a number >= 0",
            ),
            (
                "Behaviour(Until(Proximity(inf), Wait(1.0)))",
                "[0][0][0]",
                "Behaviour: range is inf; expected a finite number",
            ),
        ];
        for (text, field, message) in cases {
            let e = err(text);
            assert_eq!(e.field.as_deref(), Some(field), "{text}: {e:?}");
            assert_eq!(e.message, message, "{text}");
        }
    }

    #[test]
    fn misspelt_names_are_errors_at_their_place() {
        let e = err("Behaviour(Repeat(Forever, Wander(speed: 3.0)))");
        assert!(e.message.contains("unknown field `speed`"), "{e:?}");
        assert_eq!(e.at.map(|(l, _)| l), Some(1), "{e:?}");
        let e = err("Behaviour(Repeat(Forevr, Wander()))");
        assert!(e.message.contains("Forevr"), "{e:?}");
        let e = err("Behaviour(Until(Mesage, Wait(1.0)))");
        assert!(e.message.contains("Mesage"), "{e:?}");
        let e = err("Behaviour(GoTo(to: Centroid, move_speed: \"fast\"))");
        assert!(e.message.contains("a speed (a number) or a range"), "{e:?}");
    }

    #[test]
    fn speeds_draw_as_the_built_ins() {
        use rand::SeedableRng;
        let mut a = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut b = a.clone();
        assert_eq!(Speed::Fixed(4.0).draw(&mut a), 4.0);
        // A fixed speed draws nothing.
        assert_eq!(a.gen::<f64>(), b.gen::<f64>());
        let r = Speed::Range(3.0, 13.0).draw(&mut a);
        assert_eq!(r, 3.0 + 10.0 * b.gen::<f64>());
    }
}
