//! A robot's path over time as consecutive pieces (seed eq. 3.2): straight pieces, solved in
//! closed form, and curved ones with a bound on their speed, solved by conservative
//! advancement. Motion patterns describe their paths in these terms
//! ([`super::motion::MotionPattern::pieces`]) and collision prediction reads them
//! ([`super::collision`]), so neither needs the other's internals.

use super::geometry::{Point, Vector};

/// Shape of a piece of a path, over `[t0, t1]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// `pos(t) = p0 + v (t - t0)` (seed eq. 3.2).
    Linear { p0: Point, v: Vector },
    /// Any other curve; positions come from [`super::motion::MotionPattern::state_at`] and
    /// the speed of the centre never exceeds `max_speed` [units/s].
    Curve { max_speed: f64 },
}

/// A piece of a robot's path between two instants [s].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Piece {
    pub t0: f64,
    pub t1: f64,
    pub shape: Shape,
}

/// A track's pieces ([`super::collision::Track::pieces_from`]).
pub type Pieces = smallvec::SmallVec<[Piece; 4]>;

/// The part of `p` from `t` on (a linear piece's origin moves to `t`).
pub(crate) fn clip_start(p: Piece, t: f64) -> Piece {
    if p.t0 >= t {
        return p;
    }
    let shape = match p.shape {
        Shape::Linear { p0, v } => Shape::Linear {
            p0: linear_at(p0, v, p.t0, t),
            v,
        },
        curve => curve,
    };
    Piece {
        t0: t,
        t1: p.t1,
        shape,
    }
}

/// Position of a linear piece at `t`.
pub(crate) fn linear_at(p0: Point, v: Vector, t0: f64, t: f64) -> Point {
    p0 + v * (t - t0)
}
