//! Exact collision prediction (seed 3.3 and 4.4, eq. 4.8-4.11).
//!
//! Two circular robots collide when the distance between their centres reaches `r1 + r2` while
//! they approach each other. A robot's future path is its current motion's [`Piece`]s followed
//! by rest at the motion's end point. Pieces of two robots are aligned on common time windows;
//! on each window two straight pieces give the quadratic of eq. 4.11, solved in closed form by
//! [`first_contact_linear`]. A window with a curved piece is solved by conservative
//! advancement: the gap divided by a bound on the closing speed is a step that cannot jump over
//! a contact, so the first contact is found to within [`CONTACT_TOLERANCE`] without slicing time.
//!
//! The same machinery predicts when a robot touches the world boundary, when it leaves a cell of
//! the spatial index, and when another robot enters a push sensor's range (a "collision" with a
//! larger reach).

use super::geometry::{cell_exit_linear, first_contact_linear, first_wall_contact, Point, Vector};
use super::motion::MotionPattern;
pub use super::piece::Pieces;
use super::piece::{linear_at, Piece, Shape};

/// Gap [units] below which conservative advancement reports a contact on a curved piece.
pub const CONTACT_TOLERANCE: f64 = 1e-10;

/// The future of one robot's centre: its current motion, if any, then rest.
#[derive(Clone, Copy, Debug)]
pub struct Track<'a> {
    /// The motion in progress (it may already have ended).
    pub motion: Option<&'a dyn MotionPattern>,
    /// Where the robot rests when it has no motion [units]; ignored when `motion` is set.
    pub rest: Point,
}

impl Track<'_> {
    /// Position at `t` [units].
    pub fn pos_at(&self, t: f64) -> Point {
        match self.motion {
            Some(m) => m.state_at(t).pos,
            None => self.rest,
        }
    }

    /// Velocity at `t` [units/s].
    pub fn vel_at(&self, t: f64) -> Vector {
        match self.motion {
            Some(m) if t < m.end_time() => m.state_at(t).vel,
            _ => Vector::zeros(),
        }
    }

    /// The pieces of the path from `now` on, the last one resting until infinity (inline up
    /// to four: no allocation per prediction for the built-in motions).
    pub fn pieces_from(&self, now: f64) -> Pieces {
        let mut out = Pieces::new();
        self.pieces_into(now, &mut out);
        out
    }

    /// [`Track::pieces_from`] into `out` (emptied first): a caller's buffer, filled where it
    /// lies, so that a prediction copies no pieces out of a return.
    pub fn pieces_into(&self, now: f64, out: &mut Pieces) {
        out.clear();
        let mut rest_from = now;
        if let Some(m) = self.motion {
            let end = m.end_time();
            if now < end {
                let start = m.start_time();
                if start > now {
                    // Standing still until the motion starts.
                    out.push(Piece {
                        t0: now,
                        t1: start,
                        shape: Shape::Linear {
                            p0: m.state_at(start).pos,
                            v: Vector::zeros(),
                        },
                    });
                }
                m.pieces_after(now, out);
                rest_from = end;
            }
        }
        out.push(Piece {
            t0: rest_from,
            t1: f64::INFINITY,
            shape: Shape::Linear {
                p0: self.pos_at(rest_from),
                v: Vector::zeros(),
            },
        });
    }
}

fn speed_bound(shape: &Shape) -> f64 {
    match shape {
        Shape::Linear { v, .. } => v.norm(),
        Shape::Curve { max_speed } => *max_speed,
    }
}

/// Conservative advancement over `[s, e]`: `gap(t)` is a distance-like function whose rate of
/// change is bounded by `lipschitz`; `approaching(t)` says whether a contact at `t` counts.
pub(crate) fn advance(
    s: f64,
    e: f64,
    lipschitz: f64,
    gap: impl Fn(f64) -> f64,
    approaching: impl Fn(f64) -> bool,
) -> Option<f64> {
    // The smallest step that still moves `t` (a few ulps, never below 1e-12 s).
    let min_step = |t: f64| (t.abs() * 4.0 * f64::EPSILON).max(1e-12);
    let mut t = s;
    loop {
        let g = gap(t);
        if g <= CONTACT_TOLERANCE {
            if approaching(t) {
                return Some(t);
            }
            // Touching but separating: move on by a small step that makes progress.
            t += min_step(t).max((e - s).abs().min(1.0) * 1e-9);
        } else if lipschitz <= 0.0 {
            return None;
        } else {
            t += (g / lipschitz).max(min_step(t));
        }
        if t > e {
            return None;
        }
    }
}

/// Walks the common time windows of two tracks' pieces from one instant on (`pa` and `pb`, each
/// [`Track::pieces_from`] that instant), in time order, and returns the first instant
/// `on_window` finds. `on_window(s, e, x, y)` sees the window `[s, e]` and the pieces of `a`
/// and `b` that cover it.
fn first_in_windows(
    pa: &[Piece],
    pb: &[Piece],
    mut on_window: impl FnMut(f64, f64, &Piece, &Piece) -> Option<f64>,
) -> Option<f64> {
    let (mut i, mut j) = (0, 0);
    while i < pa.len() && j < pb.len() {
        let (x, y) = (&pa[i], &pb[j]);
        let (s, e) = (x.t0.max(y.t0), x.t1.min(y.t1));
        if e >= s {
            if let Some(t) = on_window(s, e, x, y) {
                return Some(t);
            }
        }
        if x.t1 <= y.t1 {
            i += 1;
        } else {
            j += 1;
        }
    }
    None
}

/// First instant `>= now` at which the centres of `a` and `b` come within `reach` of each other
/// while approaching; `None` if they never do.
pub fn predict_contact(a: &Track, b: &Track, reach: f64, now: f64) -> Option<f64> {
    predict_contact_from(a, &a.pieces_from(now), b, reach, now)
}

/// [`predict_contact`] given `a`'s pieces from `now` (`pa`, [`Track::pieces_from`]), for a
/// robot predicted against each of its neighbours in turn: its pieces are built once.
pub fn predict_contact_from(
    a: &Track,
    pa: &[Piece],
    b: &Track,
    reach: f64,
    now: f64,
) -> Option<f64> {
    let mut pb = Pieces::new();
    b.pieces_into(now, &mut pb);
    first_in_windows(pa, &pb, |s, e, x, y| match (x.shape, y.shape) {
        (Shape::Linear { p0: p, v: u }, Shape::Linear { p0: q, v: w }) => {
            let d0 = linear_at(p, u, x.t0, s) - linear_at(q, w, y.t0, s);
            first_contact_linear(d0, u - w, reach, e - s).map(|tau| s + tau)
        }
        _ => advance(
            s,
            e,
            speed_bound(&x.shape) + speed_bound(&y.shape),
            |t| (a.pos_at(t) - b.pos_at(t)).norm() - reach,
            |t| (a.pos_at(t) - b.pos_at(t)).dot(&(a.vel_at(t) - b.vel_at(t))) < 0.0,
        ),
    })
}

/// First instant `>= now` at which the centres of `a` and `b`, within `reach` of each other at
/// `now` (or on that circle and approaching: entering it), get farther apart than `reach`;
/// `None` if they never do.
fn predict_exit(a: &Track, b: &Track, reach: f64, now: f64) -> Option<f64> {
    let (pa, pb) = (a.pieces_from(now), b.pieces_from(now));
    first_in_windows(&pa, &pb, |s, e, x, y| match (x.shape, y.shape) {
        (Shape::Linear { p0: p, v: u }, Shape::Linear { p0: q, v: w }) => {
            let d0 = linear_at(p, u, x.t0, s) - linear_at(q, w, y.t0, s);
            let dv = u - w;
            let (qa, qb, qc) = (
                dv.norm_squared(),
                2.0 * d0.dot(&dv),
                d0.norm_squared() - reach * reach,
            );
            // Outside at a window's start: out already, unless this is the entry instant
            // itself (`now`, on the circle and approaching, outside by a rounding error):
            // then the exit is the later root.
            if qc > 0.0 && (qb >= 0.0 || s > now) {
                Some(s)
            } else if qa == 0.0 {
                None
            } else {
                let tau = (-qb + (qb * qb - 4.0 * qa * qc).max(0.0).sqrt()) / (2.0 * qa);
                (tau <= e - s).then_some(s + tau)
            }
        }
        _ => advance(
            s,
            e,
            speed_bound(&x.shape) + speed_bound(&y.shape),
            |t| reach - (a.pos_at(t) - b.pos_at(t)).norm(),
            |t| (a.pos_at(t) - b.pos_at(t)).dot(&(a.vel_at(t) - b.vel_at(t))) > 0.0,
        ),
    })
}

/// First instant `>= now` at which `b` *enters* the disc of radius `reach` around `a`: if they
/// are already within reach at `now`, the first entry after they have left.
pub fn predict_entry(a: &Track, b: &Track, reach: f64, now: f64) -> Option<f64> {
    if (a.pos_at(now) - b.pos_at(now)).norm() > reach {
        return predict_contact(a, b, reach, now);
    }
    predict_reentry(a, b, reach, now)
}

/// `b` enters the disc of radius `reach` around `a` at `now`: the next entry, after they have
/// left each other's reach. At the entry instant the computed distance may exceed `reach` by a
/// rounding error, so this never asks [`predict_contact`] from `now` (which would find `now`
/// again).
pub fn predict_reentry(a: &Track, b: &Track, reach: f64, now: f64) -> Option<f64> {
    let exit = predict_exit(a, b, reach, now)?;
    predict_contact(a, b, reach, exit)
}

/// First instant `>= now` at which a robot of `radius` following `a` touches a wall of the box
/// `[lo, hi]` while moving towards it, with the contact point on the wall.
pub fn predict_wall(
    a: &Track,
    radius: f64,
    lo: Point,
    hi: Point,
    now: f64,
) -> Option<(f64, Point)> {
    for x in a.pieces_from(now) {
        let hit = match x.shape {
            Shape::Linear { p0, v } => {
                let start = linear_at(p0, v, x.t0, x.t0);
                first_wall_contact(start, v, radius, lo, hi, x.t1 - x.t0)
                    .map(|(tau, c)| (x.t0 + tau, c))
            }
            Shape::Curve { max_speed } => {
                let gap = |t: f64| {
                    let p = a.pos_at(t);
                    (p.x - lo.x - radius)
                        .min(hi.x - radius - p.x)
                        .min(p.y - lo.y - radius)
                        .min(hi.y - radius - p.y)
                };
                advance(x.t0, x.t1, max_speed, gap, |t| {
                    let (p, v) = (a.pos_at(t), a.vel_at(t));
                    first_wall_contact(p, v, radius, lo, hi, CONTACT_TOLERANCE).is_some()
                })
                .map(|t| {
                    let (p, v) = (a.pos_at(t), a.vel_at(t));
                    let c = first_wall_contact(p, v, radius, lo, hi, 1.0).map_or(p, |(_, c)| c);
                    (t, c)
                })
            }
        };
        if hit.is_some() {
            return hit;
        }
    }
    None
}

/// First instant `>= now` at which a robot following `a` leaves the grid cell
/// `[lo, lo + size)`, with the offset of the cell it enters.
pub fn predict_cell_exit(a: &Track, lo: Point, size: f64, now: f64) -> Option<(f64, [i64; 2])> {
    for x in a.pieces_from(now) {
        let hit = match x.shape {
            Shape::Linear { p0, v } => {
                let start = linear_at(p0, v, x.t0, x.t0);
                cell_exit_linear(start, v, lo, size)
                    .filter(|(tau, _)| *tau <= x.t1 - x.t0)
                    .map(|(tau, off)| (x.t0 + tau, off))
            }
            Shape::Curve { max_speed } => {
                let gap = |t: f64| {
                    let p = a.pos_at(t);
                    (p.x - lo.x)
                        .min(lo.x + size - p.x)
                        .min(p.y - lo.y)
                        .min(lo.y + size - p.y)
                };
                advance(x.t0, x.t1, max_speed, gap, |t| {
                    let (p, v) = (a.pos_at(t), a.vel_at(t));
                    cell_exit_linear(p, v, lo, size).is_some_and(|(tau, _)| {
                        tau <= 2.0 * CONTACT_TOLERANCE / v.norm().max(1e-300)
                    })
                })
                .and_then(|t| {
                    let (p, v) = (a.pos_at(t), a.vel_at(t));
                    cell_exit_linear(p, v, lo, size).map(|(_, off)| (t, off))
                })
            }
        };
        if hit.is_some() {
            return hit;
        }
    }
    None
}

/// The cells a robot following `a` passes through from `now` on, from the grid cell `cell`
/// of cells `size` wide: [`predict_cell_exit`] again and again, from each cell it enters at the
/// instant it enters it. `step` is given the offset into each next cell, at most `max` times
/// and only for cells entered by `until`; returns when it leaves the last cell, and by which
/// offset, if it does. A track of linear
/// pieces is cut into pieces once for the whole walk.
pub fn cell_walk(
    a: &Track,
    cell: [i64; 2],
    size: f64,
    now: f64,
    until: f64,
    max: usize,
    mut step: impl FnMut([i64; 2]),
) -> Option<(f64, [i64; 2])> {
    // The pieces as they are, not cut at `now`: positions later on are worked out from
    // their own starts, as a prediction from then would.
    let pieces = a.pieces_from(a.motion.map_or(now, |m| m.start_time().min(now)));
    let linear = pieces
        .iter()
        .all(|x| matches!(x.shape, Shape::Linear { .. }));
    let mut cell = cell;
    let corner = |c: [i64; 2]| Point::new(c[0] as f64 * size, c[1] as f64 * size);
    let mut lo = corner(cell);
    let mut taken = 0;
    if !linear {
        let mut exit = predict_cell_exit(a, lo, size, now);
        while taken < max {
            let Some((t, offset)) = exit.filter(|(t, _)| *t <= until) else {
                break;
            };
            step(offset);
            taken += 1;
            cell = [cell[0] + offset[0], cell[1] + offset[1]];
            lo = corner(cell);
            exit = predict_cell_exit(a, lo, size, t);
        }
        return exit;
    }
    let mut t = now;
    for x in &pieces {
        let Shape::Linear { p0, v } = x.shape else {
            unreachable!("linear pieces only")
        };
        loop {
            let s = t.max(x.t0);
            if x.t1 <= s {
                // Over by then: a prediction from then does not see it.
                break;
            }
            let start = if s > x.t0 {
                linear_at(p0, v, x.t0, s)
            } else {
                p0
            };
            let Some((tau, offset)) =
                cell_exit_linear(start, v, lo, size).filter(|(tau, _)| *tau <= x.t1 - s)
            else {
                break;
            };
            if taken == max || s + tau > until {
                return Some((s + tau, offset));
            }
            step(offset);
            taken += 1;
            cell = [cell[0] + offset[0], cell[1] + offset[1]];
            lo = corner(cell);
            t = s + tau;
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::geometry::closest_approach;
    use crate::world::motion::{Motion, Pose};
    use proptest::prelude::*;

    /// Independent oracle: on each common window the minimum distance is found by minimising
    /// the squared distance (not by solving eq. 4.11), then the first entry is bracketed and
    /// refined by bisection on the sign of `distance - reach`.
    fn oracle(a: &Track, b: &Track, reach: f64, now: f64, horizon: f64) -> Option<(f64, f64)> {
        let mut cuts: Vec<f64> = a
            .pieces_from(now)
            .iter()
            .chain(b.pieces_from(now).iter())
            .flat_map(|p| [p.t0, p.t1])
            .filter(|t| t.is_finite() && *t >= now)
            .collect();
        cuts.push(now);
        cuts.push(horizon);
        cuts.sort_by(f64::total_cmp);
        cuts.dedup();
        for w in cuts.windows(2) {
            let (s, e) = (w[0], w[1]);
            if e <= s || s >= horizon {
                continue;
            }
            let d0 = a.pos_at(s) - b.pos_at(s);
            let dv = a.vel_at((s + e) / 2.0) - b.vel_at((s + e) / 2.0);
            let (dmin, tau) = closest_approach(d0, dv, e - s);
            if dmin < reach {
                let (mut lo, mut hi) = (s, s + tau);
                if (a.pos_at(lo) - b.pos_at(lo)).norm() <= reach {
                    return Some((s, dmin));
                }
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if (a.pos_at(mid) - b.pos_at(mid)).norm() <= reach {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                return Some((hi, dmin));
            }
        }
        None
    }

    fn seg() -> impl Strategy<Value = Option<Motion>> {
        prop_oneof![
            Just(None),
            (-50.0f64..50.0, -50.0f64..50.0, 0.5f64..10.0, 5.0f64..180.0).prop_map(
                |(x, y, ms, ts)| Some(Motion::MoveTo {
                    dest: Point::new(x, y),
                    move_speed: ms,
                    turn_speed: ts
                })
            ),
            (0.0f64..60.0, 0.5f64..10.0).prop_map(|(d, ms)| Some(Motion::Forward {
                distance: d,
                move_speed: ms
            })),
            (-270.0f64..270.0, 5.0f64..90.0).prop_map(|(a, ts)| Some(Motion::Turn {
                angle: a,
                turn_speed: ts
            })),
        ]
    }

    fn pose() -> impl Strategy<Value = Pose> {
        (-40.0f64..40.0, -40.0f64..40.0, 0.0f64..360.0).prop_map(|(x, y, a)| Pose {
            pos: Point::new(x, y),
            angle: a,
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        /// Predicted collision times equal the oracle's for random pairs of motions, including
        /// turn segments, idle robots and near misses.
        #[test]
        fn prediction_matches_oracle(pa in pose(), pb in pose(), ma in seg(), mb in seg(),
                                     ra in 1.0f64..6.0, rb in 1.0f64..6.0, t0 in 0.0f64..5.0,
                                     now_frac in 0.0f64..1.0) {
            let reach = ra + rb;
            prop_assume!((pa.pos - pb.pos).norm() > reach + 1e-6);
            let a_m = ma.map(|m| m.begin(t0, pa).unwrap());
            let b_m = mb.map(|m| m.begin(t0 + 0.5, pb).unwrap());
            let a = Track { motion: a_m.as_deref(), rest: pa.pos };
            let b = Track { motion: b_m.as_deref(), rest: pb.pos };
            let now = t0 + now_frac;
            prop_assume!((a.pos_at(now) - b.pos_at(now)).norm() > reach + 1e-6);
            let horizon = 1e4;
            let got = predict_contact(&a, &b, reach, now);
            match oracle(&a, &b, reach, now, horizon) {
                Some((t, dmin)) => {
                    if dmin < reach - 1e-7 {
                        let g = got.expect("oracle found a contact the engine missed");
                        prop_assert!((g - t).abs() < 1e-6, "engine {g} oracle {t}");
                        let d = (a.pos_at(g) - b.pos_at(g)).norm();
                        prop_assert!((d - reach).abs() < 1e-7, "distance at contact {d}");
                    }
                }
                None => prop_assert!(got.is_none(), "engine reported a contact at {got:?} the oracle says never happens"),
            }
        }

        /// The next entry after an entry is strictly later, also when rounding puts the pair a
        /// hair outside reach at the entry instant (a push proximity sensor would otherwise fire
        /// again and again at the same instant); it is a real entry, at distance `reach`.
        #[test]
        fn reentry_is_strictly_after_the_entry(pa in pose(), pb in pose(), ma in seg(), mb in seg(),
                                               reach in 2.0f64..20.0, t0 in 0.0f64..5.0) {
            prop_assume!((pa.pos - pb.pos).norm() > reach + 1e-6);
            let a_m = ma.map(|m| m.begin(t0, pa).unwrap());
            let b_m = mb.map(|m| m.begin(t0 + 0.5, pb).unwrap());
            let a = Track { motion: a_m.as_deref(), rest: pa.pos };
            let b = Track { motion: b_m.as_deref(), rest: pb.pos };
            let Some(entry) = predict_contact(&a, &b, reach, t0) else { return Ok(()) };
            if let Some(next) = predict_reentry(&a, &b, reach, entry) {
                prop_assert!(next > entry, "entry {entry} and again at {next}");
                let d = (a.pos_at(next) - b.pos_at(next)).norm();
                prop_assert!((d - reach).abs() < 1e-6, "distance at re-entry {d}");
            }
        }

        /// Near misses: a straight pass whose closest distance is just above the sum of radii
        /// is not a collision; just below it is.
        #[test]
        fn near_misses_are_not_collisions(offset in 1e-6f64..1e-2, speed in 0.5f64..10.0, angle in 0.0f64..360.0) {
            let reach = 4.0;
            let dir = crate::world::geometry::heading_vector(angle);
            let normal = Vector::new(-dir.y, dir.x);
            let start = Point::new(0.0, 0.0) - dir * 50.0 + normal * (reach + offset);
            let a_m = Motion::Forward { distance: 100.0, move_speed: speed }
                .begin(0.0, Pose { pos: start, angle }).unwrap();
            let a = Track { motion: Some(&*a_m), rest: start };
            let b = Track { motion: None, rest: Point::new(0.0, 0.0) };
            prop_assert_eq!(predict_contact(&a, &b, reach, 0.0), None);
            let start_in = Point::new(0.0, 0.0) - dir * 50.0 + normal * (reach - offset);
            let a_in = Motion::Forward { distance: 100.0, move_speed: speed }
                .begin(0.0, Pose { pos: start_in, angle }).unwrap();
            let a2 = Track { motion: Some(&*a_in), rest: start_in };
            prop_assert!(predict_contact(&a2, &b, reach, 0.0).is_some());
        }
    }

    /// A circular arc around `centre`, a user-defined curved pattern.
    #[derive(Debug)]
    struct Arc {
        t0: f64,
        centre: Point,
        radius: f64,
        phase: f64,
        /// [rad/s], signed.
        rate: f64,
        duration: f64,
    }

    impl MotionPattern for Arc {
        fn start_time(&self) -> f64 {
            self.t0
        }
        fn end_time(&self) -> f64 {
            self.t0 + self.duration
        }
        fn state_at(&self, t: f64) -> crate::world::motion::Kinematics {
            let moving = t < self.end_time();
            let dt = (t.min(self.end_time()) - self.t0).max(0.0);
            let phi = self.phase + self.rate * dt;
            let pos = self.centre + Vector::new(phi.cos(), phi.sin()) * self.radius;
            let vel = Vector::new(-phi.sin(), phi.cos()) * self.radius * self.rate;
            crate::world::motion::Kinematics {
                pos,
                angle: crate::world::geometry::vector_heading(vel),
                vel: if moving { vel } else { Vector::zeros() },
                omega: 0.0,
            }
        }
        fn events(&self) -> Vec<crate::world::motion::MotionStep> {
            Vec::new()
        }
        fn pieces(&self) -> Vec<Piece> {
            vec![Piece {
                t0: self.t0,
                t1: self.end_time(),
                shape: Shape::Curve {
                    max_speed: self.radius * self.rate.abs(),
                },
            }]
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(120))]
        /// Curved pieces (conservative advancement) agree with a dense-sampling and bisection
        /// oracle, against idle and straight-moving robots.
        #[test]
        fn curved_motion_matches_sampling_oracle(phase in 0.0f64..std::f64::consts::TAU, rate in -1.0f64..1.0,
                                                 bx in -30.0f64..30.0, by in -30.0f64..30.0,
                                                 mb in seg(), rb in 0.5f64..3.0) {
            prop_assume!(rate.abs() > 0.05);
            let arc = Arc { t0: 0.0, centre: Point::new(0.0, 0.0), radius: 20.0, phase, rate, duration: 8.0 };
            let bp = Pose { pos: Point::new(bx, by), angle: 0.0 };
            let b_m = mb.map(|m| m.begin(0.0, bp).unwrap());
            let a = Track { motion: Some(&arc), rest: arc.state_at(0.0).pos };
            let b = Track { motion: b_m.as_deref(), rest: bp.pos };
            let reach = 1.0 + rb;
            prop_assume!((a.pos_at(0.0) - b.pos_at(0.0)).norm() > reach + 1e-3);
            let got = predict_contact(&a, &b, reach, 0.0);
            // Oracle: the first of 50,000 samples over the arc's duration inside reach,
            // refined by bisection; a miss if no sample gets within reach - 1e-3.
            let n = 50_000;
            let dist = |t: f64| (a.pos_at(t) - b.pos_at(t)).norm();
            let (mut first, mut min_gap) = (None, f64::INFINITY);
            for k in 0..=n {
                let t = 8.0 * k as f64 / n as f64;
                let gap = dist(t) - reach;
                min_gap = min_gap.min(gap);
                if gap <= 0.0 && first.is_none() {
                    first = Some(t);
                }
            }
            match first {
                Some(hi) if min_gap < -1e-3 => {
                    let (mut lo, mut hi) = ((hi - 8.0 / n as f64).max(0.0), hi);
                    for _ in 0..100 {
                        let mid = 0.5 * (lo + hi);
                        if dist(mid) <= reach { hi = mid } else { lo = mid }
                    }
                    let g = got.expect("engine missed a contact on a curve");
                    prop_assert!((g - hi).abs() < 1e-6, "engine {g} oracle {hi}");
                }
                None if min_gap > 1e-3 => {
                    // After the arc both rest or b moves straight on: contacts then are linear.
                    if let Some(g) = got {
                        prop_assert!(g >= 8.0, "engine reported {g} during the arc, oracle none");
                    }
                }
                _ => {}
            }
        }
    }

    #[test]
    fn advancement_terminates_on_windows_narrower_than_an_ulp_step() {
        // A window of a few ulps late in a run, touching but never approaching: the step must
        // still move time forward (this once looped forever).
        let s = 10.0 * std::f64::consts::PI;
        let e = s + 3.0 * f64::EPSILON * s;
        assert_eq!(advance(s, e, 5.0, |_| 0.0, |_| false), None);
        assert_eq!(advance(s, e, 5.0, |_| 1e-3, |_| true), None);
        assert_eq!(
            advance(1e9, 1e9 + 1.0, 1.0, |t| 1e9 + 0.5 - t, |_| true)
                .map(|t| (t - (1e9 + 0.5)).abs() < 1e-6),
            Some(true)
        );
    }

    #[test]
    fn a_robot_that_stops_before_contact_does_not_collide() {
        let from = Pose {
            pos: Point::new(0.0, 0.0),
            angle: 0.0,
        };
        let m = Motion::Forward {
            distance: 5.0,
            move_speed: 1.0,
        }
        .begin(0.0, from)
        .unwrap();
        let a = Track {
            motion: Some(&*m),
            rest: from.pos,
        };
        let b = Track {
            motion: None,
            rest: Point::new(10.0, 0.0),
        };
        assert_eq!(predict_contact(&a, &b, 4.0, 0.0), None);
        assert_eq!(predict_contact(&a, &b, 5.0, 0.0), Some(5.0));
    }

    proptest! {
        /// The walk is the cell exit predicted again and again from each cell it enters, at
        /// the instant it enters it.
        #[test]
        fn cell_walk_is_the_cell_exit_again_and_again(
            x in 0.0f64..100.0, y in 0.0f64..100.0, a in 0.0f64..360.0,
            dx in -300.0f64..300.0, dy in -300.0f64..300.0, ms in 0.5f64..20.0,
            ts in 1.0f64..90.0, late in 0.0f64..30.0, max in 0usize..12,
        ) {
            let m = Motion::MoveTo { dest: Point::new(x + dx, y + dy), move_speed: ms, turn_speed: ts }
                .begin(0.0, Pose { pos: Point::new(x, y), angle: a })
                .unwrap();
            let track = Track { motion: Some(&*m), rest: Point::new(x, y) };
            let size = 20.0;
            let now = late.min(m.end_time());
            let p = track.pos_at(now);
            let first = [(p.x / size).floor() as i64, (p.y / size).floor() as i64];
            let mut steps = Vec::new();
            let exit = cell_walk(&track, first, size, now, f64::INFINITY, max, |o| steps.push(o));
            // Again and again.
            let (mut cell, mut t, mut want) = (first, now, Vec::new());
            let corner = |c: [i64; 2]| Point::new(c[0] as f64 * size, c[1] as f64 * size);
            let mut next = predict_cell_exit(&track, corner(cell), size, t);
            while want.len() < max {
                let Some((te, o)) = next else { break };
                want.push(o);
                cell = [cell[0] + o[0], cell[1] + o[1]];
                t = te;
                next = predict_cell_exit(&track, corner(cell), size, t);
            }
            prop_assert_eq!(steps, want);
            prop_assert_eq!(exit, next);
        }
    }
}
