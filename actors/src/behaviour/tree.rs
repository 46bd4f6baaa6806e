//! The behaviour language (seed 7.2): the primitive behaviours, their combinators and the
//! values they take, as a scenario writes them (RON, read by serde) and as Rust code builds
//! them ([`Behaviour::go_to`], [`Behaviour::then`], ...).

use rand::Rng;
use serde::Deserialize;

use crate::world::RobotId;

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
    pub(super) fn min(self) -> f64 {
        match self {
            Speed::Fixed(v) | Speed::Range(v, _) => v,
        }
    }

    pub(super) fn draw(self, rng: &mut impl Rng) -> f64 {
        match self {
            Speed::Fixed(v) => v,
            Speed::Range(lo, hi) => lo + (hi - lo) * rng.gen::<f64>(),
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
}
