//! The smallest enclosing circle of a set of points (Welzl, "Smallest enclosing disks (balls
//! and ellipsoids)", LNCS 555, 1991), in its iterative form with points in a fixed order, so
//! that the same points give the same circle on every robot. Many Look-Compute-Move
//! algorithms steer by it: Ando et al.'s convergence, gathering, circle formation.

use crate::world::geometry::Point;

/// A circle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Circle {
    pub centre: Point,
    pub radius: f64,
}

impl Circle {
    fn contains(&self, p: Point) -> bool {
        (p - self.centre).norm() <= self.radius * (1.0 + 1e-12) + 1e-12
    }

    fn of_two(a: Point, b: Point) -> Self {
        let centre = Point::from((a.coords + b.coords) / 2.0);
        Self {
            centre,
            radius: (a - centre).norm().max((b - centre).norm()),
        }
    }

    /// The circle through three points; the smallest of the pairs' circles when they are
    /// collinear.
    fn of_three(a: Point, b: Point, c: Point) -> Self {
        let (bx, by) = (b.x - a.x, b.y - a.y);
        let (cx, cy) = (c.x - a.x, c.y - a.y);
        let d = 2.0 * (bx * cy - by * cx);
        if d.abs() < 1e-300 {
            let candidates = [Self::of_two(a, b), Self::of_two(a, c), Self::of_two(b, c)];
            return candidates
                .into_iter()
                .filter(|k| k.contains(a) && k.contains(b) && k.contains(c))
                .min_by(|x, y| x.radius.total_cmp(&y.radius))
                .unwrap_or_else(|| Self::of_two(a, b));
        }
        let (b2, c2) = (bx * bx + by * by, cx * cx + cy * cy);
        let ux = (cy * b2 - by * c2) / d;
        let uy = (bx * c2 - cx * b2) / d;
        let centre = Point::new(a.x + ux, a.y + uy);
        Self {
            centre,
            radius: [
                (a - centre).norm(),
                (b - centre).norm(),
                (c - centre).norm(),
            ]
            .into_iter()
            .fold(0.0, f64::max),
        }
    }
}

/// The smallest circle that encloses every point of `points` (a point's circle of radius 0
/// for one point; `None` for none).
pub fn smallest_enclosing(points: &[Point]) -> Option<Circle> {
    let first = *points.first()?;
    let mut c = Circle {
        centre: first,
        radius: 0.0,
    };
    for i in 1..points.len() {
        if c.contains(points[i]) {
            continue;
        }
        c = Circle {
            centre: points[i],
            radius: 0.0,
        };
        for j in 0..i {
            if c.contains(points[j]) {
                continue;
            }
            c = Circle::of_two(points[i], points[j]);
            for k in 0..j {
                if !c.contains(points[k]) {
                    c = Circle::of_three(points[i], points[j], points[k]);
                }
            }
        }
    }
    Some(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The circle encloses every point, and no circle through a smaller radius does: the
        /// brute-force oracle tries every circle of two or three of the points.
        #[test]
        fn the_circle_is_the_smallest_that_encloses(
            pts in proptest::collection::vec((-100.0..100.0f64, -100.0..100.0f64), 1..9)
        ) {
            let pts: Vec<Point> = pts.into_iter().map(|(x, y)| Point::new(x, y)).collect();
            let c = smallest_enclosing(&pts).expect("a circle");
            for p in &pts {
                prop_assert!((p - c.centre).norm() <= c.radius * (1.0 + 1e-9) + 1e-9);
            }
            let mut best = f64::INFINITY;
            let n = pts.len();
            let encloses = |k: &Circle| pts.iter().all(|p| (p - k.centre).norm() <= k.radius * (1.0 + 1e-9) + 1e-9);
            if n == 1 { best = 0.0; }
            for i in 0..n {
                for j in i + 1..n {
                    let k = Circle::of_two(pts[i], pts[j]);
                    if encloses(&k) { best = best.min(k.radius); }
                    for l in j + 1..n {
                        let k = Circle::of_three(pts[i], pts[j], pts[l]);
                        if encloses(&k) { best = best.min(k.radius); }
                    }
                }
            }
            prop_assert!((c.radius - best).abs() <= 1e-9 * (1.0 + best), "{} vs {}", c.radius, best);
        }
    }
}
