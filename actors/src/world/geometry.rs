//! Plain geometry and kinematics functions over nalgebra types (seed 3.1.1 eq. 3.1-3.2,
//! 4.4 eq. 4.8-4.11).
//!
//! Everything here is a pure function of its arguments so it can be property-tested
//! directly. Angles are degrees, anticlockwise from +x, as in the seed.

use nalgebra::{Point2, Vector2};

/// The largest coordinate and world extent a scenario may use [units]. f64 has 53 bits of
/// mantissa, so positions up to 1e9 (just under 2^30) are exact to 2^-23, about 1.2e-7 units:
/// well below any radius a scenario may give ([`MIN_RADIUS`]).
pub const MAX_COORDINATE: f64 = 1e9;

/// The smallest robot radius [units]: at least ten thousand times the position resolution at
/// [`MAX_COORDINATE`] (1.2e-7), so a contact is resolved to 1e-4 of a radius anywhere in the
/// world. The spatial index's cells are at least two radii wide, so a smaller radius would
/// also make a robot cross a cell every few nanoseconds of virtual time.
pub const MIN_RADIUS: f64 = 1e-3;

/// The largest speed an algorithm's configuration may give [units/s, or deg/s for turns]. A
/// position at time `t` is computed from a time rounded to `t * 2^-52`, so its error is
/// `v * t * 2^-52`; at 1e4 units/s that stays within the position resolution at
/// [`MAX_COORDINATE`] (2^-23) for `t` up to 2^29 / 1e4, about 15 hours of virtual time. Faster
/// robots also cross a world in microseconds, a run of events that never lets time advance.
pub const MAX_SPEED: f64 = 1e4;

/// A point in the world plane [units].
pub type Point = Point2<f64>;
/// A displacement or velocity in the world plane [units] or [units/s].
pub type Vector = Vector2<f64>;

/// `angle.rem_euclid(360.0)`, bit for bit, without the division of `fmod` for the angles a
/// motion mostly has, within one turn of `[0, 360)`: there the remainder is the angle itself,
/// or the angle plus or minus 360 (exact when the angle is in `[360, 720)`; rounded as
/// `rem_euclid` rounds it when in `(-360, 0)`). `fmod` would be a noticeable share of an
/// event's instructions.
pub fn rem_360(angle: f64) -> f64 {
    if (0.0..360.0).contains(&angle) {
        angle
    } else if angle > -360.0 && angle < 0.0 {
        angle + 360.0
    } else if (360.0..720.0).contains(&angle) {
        angle - 360.0
    } else {
        angle.rem_euclid(360.0)
    }
}

/// Normalises an angle to `[0, 360)` degrees (seed eq. 4.1 `% 2π`).
pub fn normalize_deg(angle: f64) -> f64 {
    let a = rem_360(angle);
    // rem_euclid can return exactly 360.0 for tiny negative inputs.
    if a >= 360.0 {
        0.0
    } else {
        a
    }
}

/// The signed shortest rotation from `from` to `to`, in `(-180, 180]` degrees.
pub fn shortest_turn(from: f64, to: f64) -> f64 {
    let d = normalize_deg(to - from);
    if d > 180.0 {
        d - 360.0
    } else {
        d
    }
}

/// Unit vector of a heading (seed eq. 4.5-4.6 without the speed factor).
pub fn heading_vector(angle_deg: f64) -> Vector {
    let r = angle_deg.to_radians();
    Vector::new(r.cos(), r.sin())
}

/// Heading in degrees `[0, 360)` of a non-zero vector.
pub fn vector_heading(v: Vector) -> f64 {
    normalize_deg(v.y.atan2(v.x).to_degrees())
}

/// First `tau` in `[0, horizon]` at which two discs, whose centres are `d0` apart
/// (position of A minus position of B) and whose relative velocity is `dv` (velocity of A minus
/// velocity of B), come to centre distance `reach` while approaching (seed eq. 4.11).
///
/// Discs that already touch or overlap count only if they are approaching (`d0·dv < 0`), so
/// robots that touch and move apart, or slide tangentially, do not collide again. A grazing
/// pass whose closest distance is not below `reach` is not a contact.
pub fn first_contact_linear(d0: Vector, dv: Vector, reach: f64, horizon: f64) -> Option<f64> {
    let a = dv.norm_squared();
    let b = 2.0 * d0.dot(&dv);
    let c = d0.norm_squared() - reach * reach;
    if b >= 0.0 || a == 0.0 {
        // Separating, tangential or stationary relative to each other.
        return None;
    }
    if c <= 0.0 {
        return Some(0.0);
    }
    let disc = b * b - 4.0 * a * c;
    if disc <= 0.0 {
        return None;
    }
    // Entry root of a·τ² + b·τ + c = 0 in the cancellation-free form c / q.
    let q = 0.5 * (-b + disc.sqrt());
    let tau = c / q;
    (tau <= horizon).then_some(tau)
}

/// First `tau` in `[0, horizon]` at which a disc of radius `radius` centred at `p0` moving with
/// velocity `v` touches a wall of the axis-aligned box `[lo, hi]` while moving towards it.
/// Returns the time and the contact point on the wall.
pub fn first_wall_contact(
    p0: Point,
    v: Vector,
    radius: f64,
    lo: Point,
    hi: Point,
    horizon: f64,
) -> Option<(f64, Point)> {
    let mut best: Option<(f64, Point)> = None;
    for axis in 0..2 {
        let (x0, vx) = (p0[axis], v[axis]);
        let wall = if vx > 0.0 {
            hi[axis]
        } else if vx < 0.0 {
            lo[axis]
        } else {
            continue;
        };
        let limit = if vx > 0.0 {
            wall - radius
        } else {
            wall + radius
        };
        let tau = ((limit - x0) / vx).max(0.0);
        if tau <= horizon && best.is_none_or(|(t, _)| tau < t) {
            let mut contact = p0 + v * tau;
            contact[axis] = wall;
            best = Some((tau, contact));
        }
    }
    best
}

/// Time `tau >= 0` at which a point at `p0` moving with `v` leaves the axis-aligned cell
/// `[lo, lo + size)`, together with the cell offset `(di, dj)` it moves into, or `None` when it
/// never leaves (zero velocity).
pub fn cell_exit_linear(p0: Point, v: Vector, lo: Point, size: f64) -> Option<(f64, [i64; 2])> {
    let mut best: Option<(f64, [i64; 2])> = None;
    for axis in 0..2 {
        let vx = v[axis];
        let (bound, step) = if vx > 0.0 {
            (lo[axis] + size, 1)
        } else if vx < 0.0 {
            (lo[axis], -1)
        } else {
            continue;
        };
        let tau = ((bound - p0[axis]) / vx).max(0.0);
        let mut offset = [0, 0];
        offset[axis] = step;
        match &mut best {
            None => best = Some((tau, offset)),
            Some((t, off)) if tau < *t => {
                *t = tau;
                *off = offset;
            }
            // Leaving through a corner crosses both axes at once.
            Some((t, off)) if tau == *t => off[axis] = step,
            _ => {}
        }
    }
    best
}

/// Minimum over `tau in [0, horizon]` of the distance `|d0 + dv·tau|`, with the `tau` where it
/// is reached.
pub fn closest_approach(d0: Vector, dv: Vector, horizon: f64) -> (f64, f64) {
    let a = dv.norm_squared();
    let tau = if a == 0.0 {
        0.0
    } else {
        (-d0.dot(&dv) / a).clamp(0.0, horizon)
    };
    ((d0 + dv * tau).norm(), tau)
}

/// Distance from `p` to the segment `[a, b]`.
pub fn point_segment_distance(p: Point, a: Point, b: Point) -> f64 {
    let ab = b - a;
    let l2 = ab.norm_squared();
    let t = if l2 == 0.0 {
        0.0
    } else {
        ((p - a).dot(&ab) / l2).clamp(0.0, 1.0)
    };
    (p - (a + ab * t)).norm()
}

/// Smallest distance between the segments `[a, b]` and `[c, d]` (zero when they cross).
pub fn segment_distance(a: Point, b: Point, c: Point, d: Point) -> f64 {
    let cross = |o: Point, p: Point, q: Point| (p - o).perp(&(q - o));
    let (d1, d2, d3, d4) = (
        cross(c, d, a),
        cross(c, d, b),
        cross(a, b, c),
        cross(a, b, d),
    );
    if ((d1 > 0.0 && d2 < 0.0) || (d1 < 0.0 && d2 > 0.0))
        && ((d3 > 0.0 && d4 < 0.0) || (d3 < 0.0 && d4 > 0.0))
    {
        return 0.0;
    }
    point_segment_distance(a, c, d)
        .min(point_segment_distance(b, c, d))
        .min(point_segment_distance(c, a, b))
        .min(point_segment_distance(d, a, b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn head_on_discs_touch_at_closed_form_time() {
        // Two unit discs 10 apart closing at 2 units/s touch when 8 units are covered.
        let t = first_contact_linear(Vector::new(-10.0, 0.0), Vector::new(2.0, 0.0), 2.0, 100.0);
        assert_eq!(t, Some(4.0));
    }

    #[test]
    fn touching_discs_moving_apart_do_not_collide() {
        let d0 = Vector::new(2.0, 0.0);
        assert_eq!(
            first_contact_linear(d0, Vector::new(1.0, 0.0), 2.0, 10.0),
            None
        );
        assert_eq!(
            first_contact_linear(d0, Vector::new(0.0, 1.0), 2.0, 10.0),
            None
        );
        assert_eq!(
            first_contact_linear(d0, Vector::new(-1.0, 0.0), 2.0, 10.0),
            Some(0.0)
        );
    }

    #[test]
    fn corner_exit_crosses_both_axes() {
        let r = cell_exit_linear(
            Point::new(0.5, 0.5),
            Vector::new(1.0, 1.0),
            Point::new(0.0, 0.0),
            1.0,
        );
        assert_eq!(r, Some((0.5, [1, 1])));
    }

    proptest! {
        /// `rem_360` is `rem_euclid(360.0)` to the bit, near the boundaries of its fast
        /// paths too.
        #[test]
        fn rem_360_is_rem_euclid(
            a in -2000.0f64..2000.0,
            near in prop::sample::select(vec![-720.0f64, -360.0, 0.0, 360.0, 720.0]),
            ulps in -4i64..=4,
            tiny in prop::sample::select(vec![0.0f64, 1e-300, -1e-300, 1e-17, -1e-17, 5e-324, -5e-324]),
        ) {
            let edge = f64::from_bits((near + tiny).to_bits().wrapping_add_signed(ulps));
            for x in [a, edge, near + tiny, -0.0, f64::MAX, f64::MIN, 1e300, -1e300] {
                prop_assert_eq!(rem_360(x).to_bits(), x.rem_euclid(360.0).to_bits(), "{}", x);
            }
        }

        /// The closed form agrees with dense sampling of both segments.
        #[test]
        fn segment_distance_matches_sampling(ax in -9.0f64..9.0, ay in -9.0f64..9.0, bx in -9.0f64..9.0, by in -9.0f64..9.0,
                                             cx in -9.0f64..9.0, cy in -9.0f64..9.0, dx in -9.0f64..9.0, dy in -9.0f64..9.0) {
            let (a, b, c, d) = (Point::new(ax, ay), Point::new(bx, by), Point::new(cx, cy), Point::new(dx, dy));
            let exact = segment_distance(a, b, c, d);
            let n = 400;
            let mut sampled = f64::INFINITY;
            for i in 0..=n {
                let p = a + (b - a) * (i as f64 / n as f64);
                sampled = sampled.min(point_segment_distance(p, c, d));
            }
            // Sampling one segment densely only overestimates, by at most half a step.
            let step = (b - a).norm() / n as f64;
            prop_assert!(exact <= sampled + 1e-9 && sampled - exact <= step, "exact {exact} sampled {sampled}");
        }

        #[test]
        fn shortest_turn_lands_on_target(from in -720.0f64..720.0, to in -720.0f64..720.0) {
            let d = shortest_turn(from, to);
            prop_assert!(d > -180.0 - 1e-9 && d <= 180.0 + 1e-9);
            let diff = shortest_turn(normalize_deg(from + d), to).abs();
            prop_assert!(diff < 1e-9, "diff {diff}");
        }

        #[test]
        fn wall_contact_is_on_the_wall(x in 1.0f64..99.0, y in 1.0f64..99.0, vx in -5.0f64..5.0, vy in -5.0f64..5.0) {
            let p0 = Point::new(x, y);
            let v = Vector::new(vx, vy);
            if let Some((tau, contact)) = first_wall_contact(p0, v, 1.0, Point::new(0.0, 0.0), Point::new(100.0, 100.0), 1e9) {
                let c = p0 + v * tau;
                let gap = (c.x - 1.0).min(99.0 - c.x).min(c.y - 1.0).min(99.0 - c.y);
                prop_assert!(gap.abs() < 1e-9, "centre {c:?} gap {gap}");
                prop_assert!((contact - c).norm() <= 1.0 + 1e-9);
            }
        }
    }
}
