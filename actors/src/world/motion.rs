//! Motion modules and motion patterns (seed 3.1.1 and 4.2.1, eq. 3.1-3.2 and 4.1-4.6).
//!
//! A motion pattern answers the seed's two operations: the exact kinematic state of the robot
//! at any instant of the motion ([`MotionPattern::state_at`]) and the list of events the motion
//! produces ([`MotionPattern::events`]). For collision prediction it also describes its path as
//! [`Piece`]s: straight pieces are solved in closed form, curved ones by conservative
//! advancement against a speed bound, never by time slicing.
//!
//! The built-in module is the seed's wheel-based one: [`Turn`], [`Forward`] and [`MoveTo`].
//! Users add their own patterns by implementing [`MotionSpec`] (how a request starts from a
//! pose) and [`MotionPattern`] (the started motion).

use std::borrow::Cow;
use std::fmt;
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::geometry::{
    heading_vector, normalize_deg, rem_360, shortest_turn, vector_heading, Point, Vector,
};
use super::piece::{clip_start, Pieces};
pub use super::piece::{Piece, Shape};

/// Where a robot is and where it faces.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Centre of the robot [units].
    pub pos: Point,
    /// Heading [deg], anticlockwise from +x, in `[0, 360)`.
    pub angle: f64,
}

/// The exact kinematic state of a robot from an instant on (the seed's MotionVector).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Kinematics {
    /// Centre of the robot [units].
    pub pos: Point,
    /// Heading [deg] in `[0, 360)`.
    pub angle: f64,
    /// Velocity of the centre [units/s]; zero while turning or stopped.
    pub vel: Vector,
    /// Turn rate [deg/s]; zero when not turning.
    pub omega: f64,
}

impl Kinematics {
    /// A robot standing still at `pose`.
    pub fn at_rest(pose: Pose) -> Self {
        Self {
            pos: pose.pos,
            angle: pose.angle,
            vel: Vector::zeros(),
            omega: 0.0,
        }
    }

    /// The pose part of the state.
    pub fn pose(&self) -> Pose {
        Pose {
            pos: self.pos,
            angle: self.angle,
        }
    }
}

/// What a motion event marks (seed 4.3.1).
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum StepKind {
    StartTurn,
    FinishTurn,
    StartForward,
    FinishForward,
    /// An event of a user-defined pattern, by name (a constant name costs no allocation).
    Custom(Cow<'static, str>),
}

impl StepKind {
    /// The trace name of the step (`start_turn`, ...).
    pub fn name(&self) -> &str {
        match self {
            StepKind::StartTurn => "start_turn",
            StepKind::FinishTurn => "finish_turn",
            StepKind::StartForward => "start_forward",
            StepKind::FinishForward => "finish_forward",
            StepKind::Custom(s) => s,
        }
    }
}

/// One event a motion produces: at time `t` [s] the robot passes `kind`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MotionStep {
    pub t: f64,
    pub kind: StepKind,
}

/// Remaining work of a motion at an instant, as the seed's log shows it (fig. 4.12).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Progress {
    /// Where the motion ends [units].
    pub dest: Point,
    /// Angle still to turn [deg], unsigned.
    pub turn_left: f64,
    /// Distance still to move [units].
    pub distance_left: f64,
    /// Turn speed of the motion [deg/s].
    pub turn_speed: f64,
    /// Move speed of the motion [units/s].
    pub move_speed: f64,
}

/// A started motion: the seed's two operations plus the path description used for exact
/// collision prediction. All times are absolute simulated seconds.
pub trait MotionPattern: fmt::Debug + Send + Sync {
    /// When the motion starts [s].
    fn start_time(&self) -> f64;
    /// When the motion ends [s]; afterwards the robot rests at `state_at(end_time())`.
    fn end_time(&self) -> f64;
    /// The exact state at `t`, clamped to `[start_time, end_time]` (seed 4.2.1, first
    /// operation). At `end_time` and after, velocity and turn rate are zero.
    fn state_at(&self, t: f64) -> Kinematics;
    /// The events the motion produces, in time order (seed 4.2.1, second operation).
    fn events(&self) -> Vec<MotionStep>;
    /// The `k`-th of [`MotionPattern::events`], and whether it is the last. The engine asks at
    /// every step; this default builds the whole list, the built-in patterns answer without
    /// allocating.
    fn step(&self, k: usize) -> Option<(MotionStep, bool)> {
        let mut steps = self.events();
        let last = k + 1 == steps.len();
        (k < steps.len()).then(|| (steps.swap_remove(k), last))
    }
    /// The path from start to end as consecutive pieces.
    fn pieces(&self) -> Vec<Piece>;
    /// Calls `f` with each of [`MotionPattern::pieces`], in order. The engine asks at every
    /// prediction; this default builds the list, the built-in patterns answer without
    /// allocating.
    fn for_each_piece(&self, f: &mut dyn FnMut(Piece)) {
        self.pieces().into_iter().for_each(f);
    }
    /// Appends to `out` those of [`MotionPattern::for_each_piece`]'s pieces that last and end
    /// after `now`, each cut to begin at `now` at the earliest
    /// ([`super::piece::clip_start`]). The engine asks for both robots of every pair it
    /// predicts; this default goes through `for_each_piece`, the built-in patterns answer
    /// directly, without the closure.
    fn pieces_after(&self, now: f64, out: &mut Pieces) {
        self.for_each_piece(&mut |p| {
            if p.t1 > now && p.t1 > p.t0 {
                out.push(clip_start(p, now));
            }
        });
    }
    /// What is left of the motion at `t`, for the Neko log.
    fn progress_at(&self, _t: f64) -> Progress {
        Progress {
            dest: self.state_at(self.end_time()).pos,
            ..Progress::default()
        }
    }
}

/// Why a motion request cannot start.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MotionError {
    /// A speed was not a finite positive number.
    #[error("{what} must be a finite number > 0, got {value}")]
    BadSpeed { what: &'static str, value: f64 },
    /// A distance, angle or coordinate was not finite (or negative where that is meaningless).
    #[error("{what} must be {expected}, got {value}")]
    BadValue {
        what: &'static str,
        expected: &'static str,
        value: f64,
    },
}

fn check_speed(what: &'static str, value: f64) -> Result<f64, MotionError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(MotionError::BadSpeed { what, value })
    }
}

fn check_finite(what: &'static str, value: f64) -> Result<f64, MotionError> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(MotionError::BadValue {
            what,
            expected: "finite",
            value,
        })
    }
}

/// A user-defined motion request: how it starts from a pose. Implement this (and
/// [`MotionPattern`]) to add a motion pattern to the simulator.
pub trait MotionSpec: fmt::Debug + Send + Sync {
    /// Name of the pattern, as it appears in traces and logs.
    fn name(&self) -> &str;
    /// Parameters as name/value pairs, for traces and logs.
    fn params(&self) -> Vec<(String, f64)>;
    /// Starts the motion at time `t0` from `from`.
    fn begin(&self, t0: f64, from: Pose) -> Result<Box<dyn MotionPattern>, MotionError>;
}

/// A motion request, as a robot's algorithm issues it.
#[derive(Clone, Debug)]
pub enum Motion {
    /// Turn on the spot by a signed `angle` [deg] at `turn_speed` [deg/s].
    Turn { angle: f64, turn_speed: f64 },
    /// Move `distance` [units] along the heading at `move_speed` [units/s].
    Forward { distance: f64, move_speed: f64 },
    /// Turn the shortest way towards `dest`, then move there.
    MoveTo {
        dest: Point,
        move_speed: f64,
        turn_speed: f64,
    },
    /// A user-defined pattern.
    Custom(Arc<dyn MotionSpec>),
}

/// Two requests are equal when they ask for the same pattern with the same parameters (a
/// custom pattern is known by its name and parameters).
impl PartialEq for Motion {
    fn eq(&self, other: &Self) -> bool {
        use Motion::*;
        match (self, other) {
            (
                Turn { angle, turn_speed },
                Turn {
                    angle: a,
                    turn_speed: s,
                },
            ) => angle == a && turn_speed == s,
            (
                Forward {
                    distance,
                    move_speed,
                },
                Forward {
                    distance: d,
                    move_speed: s,
                },
            ) => distance == d && move_speed == s,
            (
                MoveTo {
                    dest,
                    move_speed,
                    turn_speed,
                },
                MoveTo {
                    dest: d,
                    move_speed: m,
                    turn_speed: t,
                },
            ) => dest == d && move_speed == m && turn_speed == t,
            (Custom(a), Custom(b)) => a.name() == b.name() && a.params() == b.params(),
            _ => false,
        }
    }
}

impl Motion {
    /// The pattern's name: `turn`, `forward`, `move_to` or the custom name.
    pub fn name(&self) -> &str {
        match self {
            Motion::Turn { .. } => "turn",
            Motion::Forward { .. } => "forward",
            Motion::MoveTo { .. } => "move_to",
            Motion::Custom(spec) => spec.name(),
        }
    }

    /// The request's parameters as name/value pairs.
    pub fn params(&self) -> Vec<(String, f64)> {
        let p = |pairs: &[(&str, f64)]| pairs.iter().map(|(k, v)| (k.to_string(), *v)).collect();
        match self {
            Motion::Turn { angle, turn_speed } => {
                p(&[("angle", *angle), ("turn_speed", *turn_speed)])
            }
            Motion::Forward {
                distance,
                move_speed,
            } => p(&[("distance", *distance), ("move_speed", *move_speed)]),
            Motion::MoveTo {
                dest,
                move_speed,
                turn_speed,
            } => p(&[
                ("x", dest.x),
                ("y", dest.y),
                ("move_speed", *move_speed),
                ("turn_speed", *turn_speed),
            ]),
            Motion::Custom(spec) => spec.params(),
        }
    }

    /// Starts the requested motion at `t0` from `from`.
    pub fn begin(&self, t0: f64, from: Pose) -> Result<Box<dyn MotionPattern>, MotionError> {
        self.begin_with(t0, from, TurnRule::Shortest)
    }

    /// [`Motion::begin`] with MOVETO turning as `rule` says.
    pub fn begin_with(
        &self,
        t0: f64,
        from: Pose,
        rule: TurnRule,
    ) -> Result<Box<dyn MotionPattern>, MotionError> {
        Ok(match self.path(t0, from, rule)? {
            Path::Builtin(m) => Box::new(m),
            Path::Custom(m) => m,
        })
    }

    /// [`Motion::begin_with`], with a built-in pattern kept inline.
    pub(crate) fn path(&self, t0: f64, from: Pose, rule: TurnRule) -> Result<Path, MotionError> {
        Ok(match self {
            Motion::Turn { angle, turn_speed } => Path::Builtin(TurnForward::new(
                t0,
                from,
                check_finite("turn angle", *angle)?,
                check_speed("turn speed", *turn_speed)?,
                0.0,
                1.0,
                (true, false),
            )),
            Motion::Forward {
                distance,
                move_speed,
            } => {
                let distance = check_finite("distance", *distance)?;
                if distance < 0.0 {
                    return Err(MotionError::BadValue {
                        what: "distance",
                        expected: ">= 0",
                        value: distance,
                    });
                }
                Path::Builtin(TurnForward::new(
                    t0,
                    from,
                    0.0,
                    1.0,
                    distance,
                    check_speed("move speed", *move_speed)?,
                    (false, true),
                ))
            }
            Motion::MoveTo {
                dest,
                move_speed,
                turn_speed,
            } => {
                check_finite("destination x", dest.x)?;
                check_finite("destination y", dest.y)?;
                let (ms, ts) = (
                    check_speed("move speed", *move_speed)?,
                    check_speed("turn speed", *turn_speed)?,
                );
                let delta = dest - from.pos;
                let distance = delta.norm();
                let turn = if distance > 0.0 {
                    rule.turn(from.angle, vector_heading(delta))
                } else {
                    0.0
                };
                Path::Builtin(TurnForward::new(
                    t0,
                    from,
                    turn,
                    ts,
                    distance,
                    ms,
                    (true, true),
                ))
            }
            Motion::Custom(spec) => Path::Custom(spec.begin(t0, from)?),
        })
    }
}

/// A motion in progress as the world keeps it: the built-in pattern inline (every prediction
/// reads the partner's motion, and a boxed one would cost a second memory access each time),
/// a user's boxed.
#[derive(Debug)]
pub(crate) enum Path {
    Builtin(TurnForward),
    Custom(Box<dyn MotionPattern>),
}

impl Path {
    /// The pattern.
    pub(crate) fn pattern(&self) -> &dyn MotionPattern {
        match self {
            Path::Builtin(m) => m,
            Path::Custom(m) => m.as_ref(),
        }
    }
}

/// Which way MOVETO turns towards its destination (a world setting, `turn:` in scenarios).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum TurnRule {
    /// The shorter way, by at most 180 degrees either way (nekosim's default).
    #[default]
    Shortest,
    /// Always anticlockwise, by `[0, 360)` degrees: the seed's MOVETO (eq. 4.1; its logs show
    /// turns of 317.529 and 196.105 degrees).
    Anticlockwise,
}

impl TurnRule {
    /// The signed turn [deg] from heading `from` to heading `to`.
    pub fn turn(self, from: f64, to: f64) -> f64 {
        match self {
            TurnRule::Shortest => shortest_turn(from, to),
            TurnRule::Anticlockwise => {
                let t = rem_360(to - from);
                // A heading already reached up to rounding is not a full turn.
                if 360.0 - t < 1e-9 {
                    0.0
                } else {
                    t
                }
            }
        }
    }
}

/// Type names for the built-in patterns, so users can name them.
pub type Turn = TurnForward;
/// See [`TurnForward`].
pub type Forward = TurnForward;
/// See [`TurnForward`].
pub type MoveTo = TurnForward;

/// The built-in wheel-based motion: an optional turn on the spot (eq. 4.1-4.2) followed by an
/// optional straight move along the new heading (eq. 4.3-4.6). TURN is a pure turn, FORWARD a
/// pure move, MOVETO both, with the four events start-turn, finish-turn, start-forward and
/// finish-forward.
#[derive(Clone, Debug, PartialEq)]
pub struct TurnForward {
    t0: f64,
    from: Pose,
    /// Signed turn [deg].
    turn: f64,
    /// [deg/s].
    turn_speed: f64,
    /// [units].
    distance: f64,
    /// [units/s].
    move_speed: f64,
    has_turn: bool,
    has_forward: bool,
    /// Heading after the turn [deg].
    heading: f64,
    /// Unit vector of `heading`, worked out once rather than as a sine and a cosine at every
    /// position and prediction, which ask for it on the hot path.
    u: Vector,
    /// Instant the turn ends and the forward part starts [s].
    t_turned: f64,
    t_end: f64,
}

impl TurnForward {
    fn new(
        t0: f64,
        from: Pose,
        turn: f64,
        turn_speed: f64,
        distance: f64,
        move_speed: f64,
        (has_turn, has_forward): (bool, bool),
    ) -> Self {
        let t_turned = t0 + turn.abs() / turn_speed;
        let heading = normalize_deg(from.angle + turn);
        Self {
            t0,
            from,
            turn,
            turn_speed,
            distance,
            move_speed,
            has_turn,
            has_forward,
            heading,
            u: heading_vector(heading),
            t_turned,
            t_end: t_turned + distance / move_speed,
        }
    }

    fn end_pos(&self) -> Point {
        self.from.pos + self.u * self.distance
    }

    /// The path's pieces: the turn on the spot, then the straight move.
    fn two_pieces(&self) -> (Piece, Piece) {
        (
            Piece {
                t0: self.t0,
                t1: self.t_turned,
                shape: Shape::Linear {
                    p0: self.from.pos,
                    v: Vector::zeros(),
                },
            },
            Piece {
                t0: self.t_turned,
                t1: self.t_end,
                shape: Shape::Linear {
                    p0: self.from.pos,
                    v: self.u * self.move_speed,
                },
            },
        )
    }
}

impl MotionPattern for TurnForward {
    fn start_time(&self) -> f64 {
        self.t0
    }

    fn end_time(&self) -> f64 {
        self.t_end
    }

    fn state_at(&self, t: f64) -> Kinematics {
        if t >= self.t_end {
            return Kinematics::at_rest(Pose {
                pos: self.end_pos(),
                angle: self.heading,
            });
        }
        if t < self.t_turned {
            let dt = (t - self.t0).max(0.0);
            let omega = self.turn_speed * self.turn.signum();
            return Kinematics {
                pos: self.from.pos,
                angle: normalize_deg(self.from.angle + omega * dt),
                vel: Vector::zeros(),
                omega,
            };
        }
        let u = self.u;
        let s = self.move_speed * (t - self.t_turned);
        Kinematics {
            pos: self.from.pos + u * s,
            angle: self.heading,
            vel: u * self.move_speed,
            omega: 0.0,
        }
    }

    fn events(&self) -> Vec<MotionStep> {
        let mut out = Vec::with_capacity(4);
        if self.has_turn {
            out.push(MotionStep {
                t: self.t0,
                kind: StepKind::StartTurn,
            });
            out.push(MotionStep {
                t: self.t_turned,
                kind: StepKind::FinishTurn,
            });
        }
        if self.has_forward {
            out.push(MotionStep {
                t: self.t_turned,
                kind: StepKind::StartForward,
            });
            out.push(MotionStep {
                t: self.t_end,
                kind: StepKind::FinishForward,
            });
        }
        out
    }

    fn step(&self, k: usize) -> Option<(MotionStep, bool)> {
        let n = 2 * (usize::from(self.has_turn) + usize::from(self.has_forward));
        if k >= n {
            return None;
        }
        // The place among the four steps a motion with both a turn and a move has.
        let step = match if self.has_turn { k } else { k + 2 } {
            0 => MotionStep {
                t: self.t0,
                kind: StepKind::StartTurn,
            },
            1 => MotionStep {
                t: self.t_turned,
                kind: StepKind::FinishTurn,
            },
            2 => MotionStep {
                t: self.t_turned,
                kind: StepKind::StartForward,
            },
            _ => MotionStep {
                t: self.t_end,
                kind: StepKind::FinishForward,
            },
        };
        Some((step, k + 1 == n))
    }

    fn pieces(&self) -> Vec<Piece> {
        let mut out = Vec::with_capacity(2);
        self.for_each_piece(&mut |p| out.push(p));
        out
    }

    fn for_each_piece(&self, f: &mut dyn FnMut(Piece)) {
        let (turn, forward) = self.two_pieces();
        f(turn);
        f(forward);
    }

    fn pieces_after(&self, now: f64, out: &mut Pieces) {
        // `for_each_piece`'s two pieces, kept and cut as the default keeps and cuts them.
        let (turn, forward) = self.two_pieces();
        for p in [turn, forward] {
            if p.t1 > now && p.t1 > p.t0 {
                out.push(clip_start(p, now));
            }
        }
    }

    fn progress_at(&self, t: f64) -> Progress {
        let t = t.clamp(self.t0, self.t_end);
        let turn_left = (self.turn.abs() - self.turn_speed * (t - self.t0)).max(0.0);
        let moving = (t - self.t_turned).max(0.0);
        Progress {
            dest: self.end_pos(),
            turn_left: if self.has_turn { turn_left } else { 0.0 },
            distance_left: (self.distance - self.move_speed * moving).max(0.0),
            turn_speed: if self.has_turn { self.turn_speed } else { 0.0 },
            move_speed: if self.has_forward {
                self.move_speed
            } else {
                0.0
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A custom pattern known by its name and one parameter.
    #[derive(Debug)]
    struct Named(&'static str, f64);

    impl MotionSpec for Named {
        fn name(&self) -> &str {
            self.0
        }
        fn params(&self) -> Vec<(String, f64)> {
            vec![("p".into(), self.1)]
        }
        fn begin(&self, _: f64, _: Pose) -> Result<Box<dyn MotionPattern>, MotionError> {
            unreachable!("only compared")
        }
    }

    /// Requests (kept whole in the trace's observations) are equal when they ask for the same
    /// pattern with the same parameters, and only then.
    #[test]
    fn requests_are_equal_when_pattern_and_parameters_are() {
        let move_to = |x| Motion::MoveTo {
            dest: Point::new(x, 2.0),
            move_speed: 3.0,
            turn_speed: 4.0,
        };
        let custom = |name, p| Motion::Custom(std::sync::Arc::new(Named(name, p)));
        let turn = Motion::Turn {
            angle: 1.0,
            turn_speed: 2.0,
        };
        let forward = Motion::Forward {
            distance: 1.0,
            move_speed: 2.0,
        };
        assert_eq!(move_to(1.0), move_to(1.0));
        assert_ne!(move_to(1.0), move_to(1.5));
        assert_eq!(turn, turn.clone());
        assert_ne!(turn, forward);
        assert_eq!(forward, forward.clone());
        assert_eq!(custom("arc", 1.0), custom("arc", 1.0));
        assert_ne!(custom("arc", 1.0), custom("arc", 2.0));
        assert_ne!(custom("arc", 1.0), custom("spiral", 1.0));
        assert_ne!(custom("turn", 1.0), turn);
    }

    fn pose(x: f64, y: f64, angle: f64) -> Pose {
        Pose {
            pos: Point::new(x, y),
            angle,
        }
    }

    #[test]
    fn the_seeds_anticlockwise_turn_is_the_positive_remainder() {
        // The seed's logged turns (eq. 4.1): always anticlockwise, in [0, 360).
        for (from, to, want) in [
            (90.0, 45.0, 315.0),
            (0.0, 317.529, 317.529),
            (350.0, 10.0, 20.0),
            (-30.0, 166.105, 196.105),
            (45.0, 45.0, 0.0),
            (10.0, 10.0 - 1e-12, 0.0),
        ] {
            let got = TurnRule::Anticlockwise.turn(from, to);
            assert!(
                (got - want).abs() < 1e-9,
                "{from} -> {to}: {got}, expected {want}"
            );
            assert!((0.0..360.0).contains(&got));
            // Shortest: the same heading reached, by at most 180 degrees.
            let s = TurnRule::Shortest.turn(from, to);
            assert!(s.abs() <= 180.0);
            assert!(((got - s).rem_euclid(360.0)).min(360.0 - (got - s).rem_euclid(360.0)) < 1e-9);
        }
    }

    #[test]
    fn a_step_is_the_events_own() {
        let motions = [
            Motion::MoveTo {
                dest: Point::new(0.0, 10.0),
                move_speed: 2.0,
                turn_speed: 45.0,
            },
            Motion::MoveTo {
                dest: Point::new(10.0, 0.0),
                move_speed: 2.0,
                turn_speed: 45.0,
            },
            Motion::Turn {
                angle: -90.0,
                turn_speed: 30.0,
            },
            Motion::Forward {
                distance: 4.0,
                move_speed: 1.0,
            },
            Motion::Forward {
                distance: 0.0,
                move_speed: 1.0,
            },
        ];
        for motion in motions {
            let m = motion.begin(1.0, pose(0.0, 0.0, 0.0)).unwrap();
            let events = m.events();
            for k in 0..events.len() + 2 {
                let want = events.get(k).map(|e| (e.clone(), k + 1 == events.len()));
                assert_eq!(m.step(k), want, "{motion:?} step {k}");
            }
        }
    }

    #[test]
    fn move_to_turns_shortest_way_then_arrives() {
        let m = Motion::MoveTo {
            dest: Point::new(0.0, 10.0),
            move_speed: 2.0,
            turn_speed: 45.0,
        }
        .begin(1.0, pose(0.0, 0.0, 0.0))
        .unwrap();
        // 90 degrees at 45 deg/s, then 10 units at 2 units/s.
        assert_eq!(m.end_time(), 1.0 + 2.0 + 5.0);
        let kinds: Vec<_> = m.events().into_iter().map(|e| (e.t, e.kind)).collect();
        assert_eq!(
            kinds,
            vec![
                (1.0, StepKind::StartTurn),
                (3.0, StepKind::FinishTurn),
                (3.0, StepKind::StartForward),
                (8.0, StepKind::FinishForward)
            ]
        );
        let mid = m.state_at(2.0);
        assert!((mid.angle - 45.0).abs() < 1e-12 && mid.omega == 45.0);
        let end = m.state_at(8.0);
        assert!((end.pos - Point::new(0.0, 10.0)).norm() < 1e-12);
        assert_eq!(end.vel, Vector::zeros());
    }

    #[test]
    fn turn_is_clockwise_for_negative_angles() {
        let m = Motion::Turn {
            angle: -90.0,
            turn_speed: 30.0,
        }
        .begin(0.0, pose(5.0, 5.0, 10.0))
        .unwrap();
        assert_eq!(m.end_time(), 3.0);
        assert!((m.state_at(3.0).angle - 280.0).abs() < 1e-12);
        assert_eq!(m.events().len(), 2);
        assert_eq!(m.state_at(1.5).pos, Point::new(5.0, 5.0));
    }

    #[test]
    fn bad_requests_are_rejected() {
        let from = pose(0.0, 0.0, 0.0);
        assert!(Motion::Forward {
            distance: 1.0,
            move_speed: 0.0
        }
        .begin(0.0, from)
        .is_err());
        assert!(Motion::Forward {
            distance: -1.0,
            move_speed: 1.0
        }
        .begin(0.0, from)
        .is_err());
        assert!(Motion::MoveTo {
            dest: Point::new(f64::NAN, 0.0),
            move_speed: 1.0,
            turn_speed: 1.0
        }
        .begin(0.0, from)
        .is_err());
    }

    proptest! {
        /// The pieces describe the same positions as `state_at` (eq. 3.2 vs eq. 4.4-4.6).
        #[test]
        fn pieces_agree_with_state_at(x in -100.0f64..100.0, y in -100.0f64..100.0, a in 0.0f64..360.0,
                                      dx in -100.0f64..100.0, dy in -100.0f64..100.0,
                                      ms in 0.5f64..20.0, ts in 1.0f64..90.0, f in 0.0f64..1.0) {
            let m = Motion::MoveTo { dest: Point::new(dx, dy), move_speed: ms, turn_speed: ts }
                .begin(3.0, pose(x, y, a)).unwrap();
            let t = 3.0 + f * (m.end_time() - 3.0);
            let piece = m.pieces().into_iter().find(|p| p.t0 <= t && t <= p.t1).unwrap();
            let Shape::Linear { p0, v } = piece.shape else { unreachable!() };
            let from_piece = p0 + v * (t - piece.t0);
            prop_assert!((from_piece - m.state_at(t).pos).norm() < 1e-9);
            prop_assert!((m.state_at(m.end_time()).pos - Point::new(dx, dy)).norm() < 1e-9);
        }

        /// The built-in motions' own `pieces_after` gives exactly the pieces the trait's
        /// default gives from `for_each_piece`, for a turn, a move and both, at any instant.
        #[test]
        fn builtin_pieces_after_is_the_default(x in -100.0f64..100.0, y in -100.0f64..100.0,
                                               a in 0.0f64..360.0, dx in -100.0f64..100.0,
                                               dy in -100.0f64..100.0, ms in 0.5f64..20.0,
                                               ts in 1.0f64..90.0, kind in 0usize..4,
                                               f in -0.2f64..1.2) {
            /// A pattern that answers as `.0` does, but with the default `pieces_after`.
            #[derive(Debug)]
            struct Plain<'a>(&'a dyn MotionPattern);
            impl MotionPattern for Plain<'_> {
                fn start_time(&self) -> f64 { self.0.start_time() }
                fn end_time(&self) -> f64 { self.0.end_time() }
                fn state_at(&self, t: f64) -> Kinematics { self.0.state_at(t) }
                fn events(&self) -> Vec<MotionStep> { self.0.events() }
                fn pieces(&self) -> Vec<Piece> { self.0.pieces() }
                fn for_each_piece(&self, f: &mut dyn FnMut(Piece)) { self.0.for_each_piece(f) }
            }
            let motion = match kind {
                0 => Motion::Turn { angle: dx, turn_speed: ts },
                1 => Motion::Forward { distance: dy.abs(), move_speed: ms },
                2 => Motion::MoveTo { dest: Point::new(x, y), move_speed: ms, turn_speed: ts },
                _ => Motion::MoveTo { dest: Point::new(dx, dy), move_speed: ms, turn_speed: ts },
            };
            let m = motion.begin(3.0, pose(x, y, a)).unwrap();
            let now = 3.0 + f * (m.end_time() - 3.0);
            let mut own = super::super::piece::Pieces::new();
            let mut default = own.clone();
            m.pieces_after(now, &mut own);
            Plain(&*m).pieces_after(now, &mut default);
            prop_assert_eq!(own, default);
        }
    }
}
