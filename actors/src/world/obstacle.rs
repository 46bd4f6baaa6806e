//! Obstacle objects (seed 7.2, future work: "obstacle objects" and "communication ranges tied
//! to obstacles"): static segments, rectangles, polygons and circles that stop robots exactly
//! where they touch and block lines of sight.
//!
//! A shape is made of primitives: segments (a rectangle's and a polygon's edges, end points
//! included) and circles. A moving disc's first contact with a segment is the earlier of its
//! face contact (the centre's distance to the segment's line reaching the radius, with the
//! foot on the segment) and its end points' contacts (a point is a circle of radius zero); with
//! a circle it is eq. 4.11 with the sum of the radii. Straight pieces are solved in closed form,
//! curved pieces by conservative advancement (as robot-robot contacts in [`super::collision`]).
//!
//! The primitives are indexed by the cells of the world's spatial grid they cross
//! ([`ObstacleIndex`]); a robot is predicted against the primitives of the 3×3 block around
//! its cell, again whenever it crosses into another cell, so a motion request costs O(1) at a
//! uniform obstacle density.

use std::collections::HashMap;

use serde::{Deserialize, Serialize};

use super::collision::{advance, Track};
use super::geometry::MAX_COORDINATE;
use super::geometry::{first_contact_linear, point_segment_distance, Point, Vector};
use super::grid::{Cell, FixedHash};
use super::motion::Shape as PieceShape;

/// An obstacle as a scenario writes it (`obstacles: [Rect(min: (0, 0), max: (10, 5)), ...]`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Shape {
    /// A wall of no thickness from `from` to `to`.
    Segment { from: (f64, f64), to: (f64, f64) },
    /// A solid axis-aligned rectangle.
    Rect { min: (f64, f64), max: (f64, f64) },
    /// A solid simple polygon through its corners in order (closed automatically).
    Polygon(Vec<(f64, f64)>),
    /// A solid disc.
    Circle { center: (f64, f64), radius: f64 },
}

/// Why an obstacle is refused, with the field of the shape it concerns (`from`, `[2]`, ...).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct ShapeError {
    /// The field inside the shape (empty: the shape as a whole).
    pub field: String,
    pub message: String,
    /// What would be accepted.
    pub expected: String,
}

fn p(v: (f64, f64)) -> Point {
    Point::new(v.0, v.1)
}

impl Shape {
    /// Checks the shape: finite numbers, no degenerate shape.
    pub fn check(&self) -> Result<(), ShapeError> {
        let bad = |field: &str, message: String, expected: &str| {
            Err(ShapeError {
                field: field.to_string(),
                message,
                expected: expected.to_string(),
            })
        };
        // Beyond [`MAX_COORDINATE`] positions lose the precision exact contacts need, and the
        // obstacle index would walk the cells of an edge spanning astronomically many.
        let finite = |field: &str, v: (f64, f64)| {
            if !(v.0.is_finite() && v.1.is_finite()) {
                bad(
                    field,
                    format!("({}, {}) is not a point", v.0, v.1),
                    "finite coordinates",
                )
            } else if v.0.abs() > MAX_COORDINATE || v.1.abs() > MAX_COORDINATE {
                bad(
                    field,
                    format!("({:e}, {:e}) is too far out", v.0, v.1),
                    "coordinates at most 1e9 in size (beyond, positions lose the precision exact contacts need)",
                )
            } else {
                Ok(())
            }
        };
        match self {
            Shape::Segment { from, to } => {
                finite("from", *from)?;
                finite("to", *to)?;
                if from == to {
                    return bad(
                        "to",
                        "a segment of length 0".into(),
                        "two different end points",
                    );
                }
            }
            Shape::Rect { min, max } => {
                finite("min", *min)?;
                finite("max", *max)?;
                if !(max.0 > min.0 && max.1 > min.1) {
                    return bad(
                        "max",
                        format!(
                            "max ({}, {}) is not above and right of min ({}, {})",
                            max.0, max.1, min.0, min.1
                        ),
                        "max.x > min.x and max.y > min.y",
                    );
                }
            }
            Shape::Polygon(points) => {
                for (k, v) in points.iter().enumerate() {
                    finite(&format!("[{k}]"), *v)?;
                }
                if points.len() < 3 {
                    return bad(
                        "",
                        format!("a polygon of {} points", points.len()),
                        "at least 3 corners",
                    );
                }
                for k in 0..points.len() {
                    if points[k] == points[(k + 1) % points.len()] {
                        return bad(
                            &format!("[{k}]"),
                            "two consecutive corners are the same point".into(),
                            "distinct consecutive corners",
                        );
                    }
                }
                if polygon_area(points).abs() < 1e-12 {
                    return bad(
                        "",
                        "a polygon of area 0".into(),
                        "corners that enclose an area",
                    );
                }
                let n = points.len();
                for i in 0..n {
                    for j in i + 1..n {
                        // Edges sharing a corner meet there; others must not touch.
                        if j == i + 1 || (i == 0 && j == n - 1) {
                            continue;
                        }
                        let (a, b) = (p(points[i]), p(points[(i + 1) % n]));
                        let (c, d) = (p(points[j]), p(points[(j + 1) % n]));
                        if super::geometry::segment_distance(a, b, c, d) == 0.0 {
                            return bad(
                                &format!("[{j}]"),
                                format!("edges {i} and {j} cross"),
                                "a simple polygon (edges that do not cross)",
                            );
                        }
                    }
                }
            }
            Shape::Circle { center, radius } => {
                finite("center", *center)?;
                if !(radius.is_finite() && *radius > 0.0) {
                    return bad(
                        "radius",
                        format!("radius is {radius}"),
                        "a finite number > 0",
                    );
                }
                if *radius > MAX_COORDINATE {
                    return bad("radius", format!("radius is {radius:e}"), "at most 1e9");
                }
            }
        }
        Ok(())
    }

    /// How many cells of a grid `size` wide [`ObstacleIndex`] visits to index the shape: those
    /// of its primitives' bounding boxes (a scenario bounds it before the index is built).
    pub fn index_cells(&self, size: f64) -> f64 {
        self.primitives()
            .iter()
            .map(|pr| {
                let (lo, hi) = pr.bounds();
                let cells = |a: f64, b: f64| (b / size).floor() - (a / size).floor() + 1.0;
                cells(lo.x, hi.x) * cells(lo.y, hi.y)
            })
            .sum()
    }

    /// The shape's primitives: edges (closed for solids) or its circle.
    pub fn primitives(&self) -> Vec<Primitive> {
        match self {
            Shape::Segment { from, to } => vec![Primitive::Segment(p(*from), p(*to))],
            Shape::Rect { min, max } => {
                let c = [
                    p(*min),
                    Point::new(max.0, min.1),
                    p(*max),
                    Point::new(min.0, max.1),
                ];
                (0..4)
                    .map(|k| Primitive::Segment(c[k], c[(k + 1) % 4]))
                    .collect()
            }
            Shape::Polygon(points) => (0..points.len())
                .map(|k| Primitive::Segment(p(points[k]), p(points[(k + 1) % points.len()])))
                .collect(),
            Shape::Circle { center, radius } => vec![Primitive::Circle(p(*center), *radius)],
        }
    }

    /// Distance from `q` to the shape: 0 inside a solid shape.
    pub fn distance(&self, q: Point) -> f64 {
        if self.contains(q) {
            return 0.0;
        }
        self.primitives()
            .iter()
            .map(|pr| pr.distance(q))
            .fold(f64::INFINITY, f64::min)
    }

    /// Whether `q` is inside the solid shape (a segment has no inside).
    pub fn contains(&self, q: Point) -> bool {
        match self {
            Shape::Segment { .. } => false,
            Shape::Rect { min, max } => {
                q.x >= min.0 && q.x <= max.0 && q.y >= min.1 && q.y <= max.1
            }
            Shape::Polygon(points) => {
                // Even-odd rule.
                let mut inside = false;
                let n = points.len();
                for k in 0..n {
                    let (a, b) = (p(points[k]), p(points[(k + 1) % n]));
                    if (a.y > q.y) != (b.y > q.y) {
                        let x = a.x + (q.y - a.y) / (b.y - a.y) * (b.x - a.x);
                        if q.x < x {
                            inside = !inside;
                        }
                    }
                }
                inside
            }
            Shape::Circle { center, radius } => (q - p(*center)).norm() <= *radius,
        }
    }

    /// The points that draw the shape: a closed line for solids (a circle by 64 chords).
    pub fn outline(&self) -> Vec<Point> {
        match self {
            Shape::Circle { center, radius } => (0..=64)
                .map(|k| {
                    let a = std::f64::consts::TAU * f64::from(k) / 64.0;
                    p(*center) + Vector::new(a.cos(), a.sin()) * *radius
                })
                .collect(),
            other => {
                let prims = other.primitives();
                let mut out: Vec<Point> = prims
                    .iter()
                    .map(|pr| match pr {
                        Primitive::Segment(a, _) => *a,
                        Primitive::Circle(c, _) => *c,
                    })
                    .collect();
                if let Some(Primitive::Segment(_, b)) = prims.last() {
                    out.push(*b);
                }
                out
            }
        }
    }
}

/// Twice the signed area... halved: the shoelace formula.
fn polygon_area(points: &[(f64, f64)]) -> f64 {
    let n = points.len();
    (0..n)
        .map(|k| {
            let (a, b) = (points[k], points[(k + 1) % n]);
            a.0 * b.1 - b.0 * a.1
        })
        .sum::<f64>()
        / 2.0
}

/// A piece of an obstacle's boundary.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Primitive {
    /// A segment, end points included.
    Segment(Point, Point),
    /// A circle `(centre, radius)`.
    Circle(Point, f64),
}

impl Primitive {
    /// The primitive's bounding box `(lower-left, upper-right)`.
    pub fn bounds(&self) -> (Point, Point) {
        match *self {
            Primitive::Segment(a, b) => (
                Point::new(a.x.min(b.x), a.y.min(b.y)),
                Point::new(a.x.max(b.x), a.y.max(b.y)),
            ),
            Primitive::Circle(c, r) => (c - Vector::new(r, r), c + Vector::new(r, r)),
        }
    }

    /// Distance from `q` to the primitive (to a circle's rim from outside; 0 inside).
    pub fn distance(&self, q: Point) -> f64 {
        match *self {
            Primitive::Segment(a, b) => point_segment_distance(q, a, b),
            Primitive::Circle(c, r) => ((q - c).norm() - r).max(0.0),
        }
    }

    /// The point of the primitive nearest to `q`.
    pub fn nearest(&self, q: Point) -> Point {
        match *self {
            Primitive::Segment(a, b) => {
                let ab = b - a;
                let u = ((q - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
                a + ab * u
            }
            Primitive::Circle(c, r) => {
                let d = q - c;
                let n = d.norm();
                if n == 0.0 {
                    c + Vector::new(r, 0.0)
                } else {
                    c + d * (r / n)
                }
            }
        }
    }

    /// Whether the segment `[s, e]` crosses or touches the primitive.
    pub fn blocks(&self, s: Point, e: Point) -> bool {
        match *self {
            Primitive::Segment(a, b) => super::geometry::segment_distance(s, e, a, b) == 0.0,
            Primitive::Circle(c, r) => point_segment_distance(c, s, e) < r,
        }
    }
}

/// First `tau` in `[0, horizon]` at which a disc of `radius` centred at `p0` moving with
/// velocity `v` touches `prim` while moving towards it, with the contact point.
pub fn first_contact(
    p0: Point,
    v: Vector,
    radius: f64,
    prim: &Primitive,
    horizon: f64,
) -> Option<(f64, Point)> {
    match *prim {
        Primitive::Circle(c, r) => {
            first_contact_linear(p0 - c, v, radius + r, horizon).map(|tau| {
                let at = p0 + v * tau;
                (tau, c + (at - c) * (r / (radius + r)))
            })
        }
        Primitive::Segment(a, b) => {
            let ab = b - a;
            let len = ab.norm();
            let n = Vector::new(-ab.y, ab.x) / len;
            let (s0, vn) = ((p0 - a).dot(&n), v.dot(&n));
            // The face: the centre's signed distance to the line reaches ±radius while
            // approaching it, with the foot inside the segment.
            let face = if s0.abs() <= radius {
                // Touching the line already (a robot stopped against the face, to rounding):
                // a contact now if it moves towards it.
                (s0 * vn < 0.0).then_some(0.0)
            } else if s0 > radius && vn < 0.0 {
                Some((s0 - radius) / -vn)
            } else if s0 < -radius && vn > 0.0 {
                Some((-radius - s0) / vn)
            } else {
                None
            }
            .filter(|tau| *tau <= horizon)
            .and_then(|tau| {
                let at = p0 + v * tau;
                let u = (at - a).dot(&ab) / (len * len);
                (0.0..=1.0).contains(&u).then(|| (tau, a + ab * u))
            });
            let ends = [a, b].into_iter().filter_map(|e| {
                first_contact_linear(p0 - e, v, radius, horizon).map(|tau| (tau, e))
            });
            face.into_iter()
                .chain(ends)
                .min_by(|x, y| x.0.total_cmp(&y.0))
        }
    }
}

/// First instant `>= now` at which a robot of `radius` following `track` touches `prim`
/// while moving towards it, with the contact point.
pub fn predict_obstacle(
    track: &Track,
    radius: f64,
    prim: &Primitive,
    now: f64,
) -> Option<(f64, Point)> {
    for x in track.pieces_from(now) {
        let hit = match x.shape {
            PieceShape::Linear { p0, v } => {
                first_contact(p0, v, radius, prim, x.t1 - x.t0).map(|(tau, c)| (x.t0 + tau, c))
            }
            PieceShape::Curve { max_speed } => advance(
                x.t0,
                x.t1,
                max_speed,
                |t| prim.distance(track.pos_at(t)) - radius,
                |t| {
                    let q = track.pos_at(t);
                    (prim.nearest(q) - q).dot(&track.vel_at(t)) > 0.0
                },
            )
            .map(|t| (t, prim.nearest(track.pos_at(t)))),
        };
        if hit.is_some() {
            return hit;
        }
    }
    None
}

/// The obstacles of a world with their primitives indexed by grid cell.
#[derive(Clone, Debug, Default)]
pub struct ObstacleIndex {
    shapes: Vec<Shape>,
    /// Every primitive with the index of its shape.
    prims: Vec<(u32, Primitive)>,
    cells: HashMap<Cell, Vec<u32>, FixedHash>,
    size: f64,
}

impl ObstacleIndex {
    /// Indexes `shapes` on a grid of cells `size` wide (the world's spatial index's).
    pub fn new(shapes: Vec<Shape>, size: f64) -> Self {
        let prims: Vec<(u32, Primitive)> = shapes
            .iter()
            .enumerate()
            .flat_map(|(k, s)| s.primitives().into_iter().map(move |p| (k as u32, p)))
            .collect();
        let mut index = Self {
            shapes,
            prims,
            cells: HashMap::default(),
            size,
        };
        index.reindex(size);
        index
    }

    /// Indexes again on cells `size` wide.
    pub fn reindex(&mut self, size: f64) {
        self.size = size;
        self.cells.clear();
        let cell = |q: Point| [(q.x / size).floor() as i64, (q.y / size).floor() as i64];
        for (i, (_, prim)) in self.prims.iter().enumerate() {
            let (lo, hi) = prim.bounds();
            let (c0, c1) = (cell(lo), cell(hi));
            for x in c0[0]..=c1[0] {
                for y in c0[1]..=c1[1] {
                    // Only the cells the primitive really crosses: its distance to the cell's
                    // centre within the cell's half diagonal.
                    let centre = Point::new((x as f64 + 0.5) * size, (y as f64 + 0.5) * size);
                    if prim.distance(centre)
                        <= size * std::f64::consts::FRAC_1_SQRT_2 * (1.0 + 1e-9)
                    {
                        self.cells.entry([x, y]).or_default().push(i as u32);
                    }
                }
            }
        }
    }

    /// Whether the world has no obstacle.
    pub fn is_empty(&self) -> bool {
        self.shapes.is_empty()
    }

    /// The shapes, in the scenario's order (a primitive's shape index is its place here).
    pub fn shapes(&self) -> &[Shape] {
        &self.shapes
    }

    /// Every primitive: `(shape index, primitive)`.
    pub fn primitives(&self) -> &[(u32, Primitive)] {
        &self.prims
    }

    /// Primitives crossing the 3×3 block of cells around `cell`, each once, by index.
    pub fn around(&self, cell: Cell) -> Vec<u32> {
        let mut out = Vec::new();
        for dx in -1..=1 {
            for dy in -1..=1 {
                if let Some(v) = self.cells.get(&[cell[0] + dx, cell[1] + dy]) {
                    out.extend_from_slice(v);
                }
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The primitive number `i` with its shape's index.
    pub fn get(&self, i: u32) -> (u32, Primitive) {
        self.prims[i as usize]
    }

    /// Whether the straight line from `a` to `b` crosses an obstacle (line of sight).
    pub fn blocks(&self, a: Point, b: Point) -> bool {
        if self.shapes.is_empty() {
            return false;
        }
        // The cells of the segment's bounding box: sight lines are short beside the world.
        let size = self.size;
        let cell = |q: Point| [(q.x / size).floor() as i64, (q.y / size).floor() as i64];
        let (lo, hi) = (
            cell(Point::new(a.x.min(b.x), a.y.min(b.y))),
            cell(Point::new(a.x.max(b.x), a.y.max(b.y))),
        );
        let cells = ((hi[0] - lo[0] + 1) as u128) * ((hi[1] - lo[1] + 1) as u128);
        if cells > self.prims.len() as u128 {
            return self.prims.iter().any(|(_, p)| p.blocks(a, b));
        }
        for x in lo[0]..=hi[0] {
            for y in lo[1]..=hi[1] {
                if let Some(v) = self.cells.get(&[x, y]) {
                    if v.iter().any(|&i| self.prims[i as usize].1.blocks(a, b)) {
                        return true;
                    }
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seg(a: (f64, f64), b: (f64, f64)) -> Primitive {
        Primitive::Segment(p(a), p(b))
    }

    #[test]
    fn a_disc_hits_a_face_at_the_closed_form_time() {
        // Wall x = 10 from y = -5 to 5; a disc of radius 1 at the origin moving right at 2:
        // it touches when its centre reaches x = 9, at t = 4.5, at (10, 0).
        let hit = first_contact(
            Point::origin(),
            Vector::new(2.0, 0.0),
            1.0,
            &seg((10.0, -5.0), (10.0, 5.0)),
            100.0,
        );
        assert_eq!(hit, Some((4.5, Point::new(10.0, 0.0))));
        // From the other side, and on a slant: approach speed along the normal.
        let hit = first_contact(
            Point::new(20.0, 1.0),
            Vector::new(-3.0, 4.0),
            1.0,
            &seg((10.0, -50.0), (10.0, 50.0)),
            100.0,
        )
        .unwrap();
        assert!((hit.0 - 3.0).abs() < 1e-12, "{hit:?}");
        assert!((hit.1 - Point::new(10.0, 13.0)).norm() < 1e-12);
    }

    #[test]
    fn a_disc_hits_an_end_point_at_the_closed_form_time() {
        // The wall's end (10, 0.5); the disc moves along y = 0 to the right: it touches the end
        // point when (x - 10)^2 + 0.25 = 1, x = 10 - sqrt(0.75).
        let hit = first_contact(
            Point::origin(),
            Vector::new(1.0, 0.0),
            1.0,
            &seg((10.0, 0.5), (10.0, 5.0)),
            100.0,
        )
        .unwrap();
        assert!((hit.0 - (10.0 - 0.75f64.sqrt())).abs() < 1e-12, "{hit:?}");
        assert_eq!(hit.1, Point::new(10.0, 0.5));
    }

    #[test]
    fn a_corner_of_a_rectangle_is_hit_by_a_diagonal_approach() {
        // The rectangle [10, 20] x [10, 20], a disc of radius 1 moving along y = x from the
        // origin at speed sqrt(2) (1 per axis): the corner (10, 10) is touched when the centre
        // is 1 from it, at x = y = 10 - 1/sqrt(2).
        let rect = Shape::Rect {
            min: (10.0, 10.0),
            max: (20.0, 20.0),
        };
        let best = rect
            .primitives()
            .iter()
            .filter_map(|pr| first_contact(Point::origin(), Vector::new(1.0, 1.0), 1.0, pr, 100.0))
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .unwrap();
        assert!(
            (best.0 - (10.0 - std::f64::consts::FRAC_1_SQRT_2)).abs() < 1e-12,
            "{best:?}"
        );
        assert!((best.1 - Point::new(10.0, 10.0)).norm() < 1e-12);
    }

    #[test]
    fn grazing_past_an_end_and_sliding_along_a_face_miss() {
        // Passing the end point (10, 1) with the centre on y = 0 and radius 1: tangent, no hit.
        let graze = first_contact(
            Point::origin(),
            Vector::new(1.0, 0.0),
            1.0,
            &seg((10.0, 1.0), (10.0, 5.0)),
            100.0,
        );
        assert_eq!(graze, None);
        // Moving parallel to a wall at exactly one radius: no approach, no hit.
        let slide = first_contact(
            Point::new(0.0, 1.0),
            Vector::new(1.0, 0.0),
            1.0,
            &seg((-5.0, 0.0), (50.0, 0.0)),
            100.0,
        );
        assert_eq!(slide, None);
        // Sliding past a vertex 1.0001 away: no hit; 0.9999 away: the vertex is hit.
        let past = first_contact(
            Point::new(0.0, 1.0001),
            Vector::new(1.0, 0.0),
            1.0,
            &seg((5.0, 0.0), (5.0, -10.0)),
            100.0,
        );
        assert_eq!(past, None);
        let hit = first_contact(
            Point::new(0.0, 0.9999),
            Vector::new(1.0, 0.0),
            1.0,
            &seg((5.0, 0.0), (5.0, -10.0)),
            100.0,
        );
        assert_eq!(hit.map(|h| h.1), Some(Point::new(5.0, 0.0)));
        // Resting against a wall (one radius away, to rounding) and moving into it: a contact
        // at once; moving along it: none.
        let wall = seg((10.0, -5.0), (10.0, 5.0));
        let into = first_contact(
            Point::new(9.0 + 1e-15, 0.0),
            Vector::new(1.0, 0.1),
            1.0,
            &wall,
            100.0,
        );
        assert_eq!(into.map(|h| h.0), Some(0.0));
        let along = first_contact(
            Point::new(9.0 - 1e-15, 0.0),
            Vector::new(0.0, 1.0),
            1.0,
            &wall,
            100.0,
        );
        assert_eq!(along, None);
        // Moving away from a wall already touched: no contact.
        let away = first_contact(
            Point::new(9.0, 0.0),
            Vector::new(-1.0, 0.0),
            1.0,
            &seg((10.0, -5.0), (10.0, 5.0)),
            100.0,
        );
        assert_eq!(away, None);
    }

    #[test]
    fn a_disc_hits_a_circle_at_the_sum_of_the_radii() {
        let hit = first_contact(
            Point::origin(),
            Vector::new(1.0, 0.0),
            1.0,
            &Primitive::Circle(Point::new(10.0, 0.0), 3.0),
            100.0,
        );
        assert_eq!(hit, Some((6.0, Point::new(7.0, 0.0))));
    }

    #[test]
    fn degenerate_shapes_are_refused_with_their_field() {
        let field = |s: Shape| s.check().unwrap_err().field;
        assert_eq!(
            field(Shape::Segment {
                from: (1.0, 1.0),
                to: (1.0, 1.0)
            }),
            "to"
        );
        assert_eq!(
            field(Shape::Rect {
                min: (0.0, 0.0),
                max: (0.0, 5.0)
            }),
            "max"
        );
        assert_eq!(field(Shape::Polygon(vec![(0.0, 0.0), (1.0, 0.0)])), "");
        assert_eq!(
            field(Shape::Polygon(vec![(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)])),
            ""
        );
        assert_eq!(
            field(Shape::Polygon(vec![
                (0.0, 0.0),
                (f64::NAN, 0.0),
                (2.0, 1.0)
            ])),
            "[1]"
        );
        // A bow tie: edges 0 and 2 cross.
        assert_eq!(
            field(Shape::Polygon(vec![
                (0.0, 0.0),
                (3.0, 2.0),
                (3.0, 0.0),
                (0.0, 3.0)
            ])),
            "[2]"
        );
        assert_eq!(
            field(Shape::Circle {
                center: (0.0, 0.0),
                radius: 0.0
            }),
            "radius"
        );
        assert!(Shape::Polygon(vec![(0.0, 0.0), (4.0, 0.0), (2.0, 3.0)])
            .check()
            .is_ok());
    }

    #[test]
    fn inside_and_distance_of_solid_shapes() {
        let tri = Shape::Polygon(vec![(0.0, 0.0), (4.0, 0.0), (0.0, 4.0)]);
        assert!(tri.contains(Point::new(1.0, 1.0)));
        assert!(!tri.contains(Point::new(3.0, 3.0)));
        assert_eq!(tri.distance(Point::new(1.0, 1.0)), 0.0);
        assert!((tri.distance(Point::new(3.0, 3.0)) - 2.0f64.sqrt()).abs() < 1e-12);
        assert!((tri.distance(Point::new(-3.0, 0.0)) - 3.0).abs() < 1e-12);
    }

    #[test]
    fn sight_lines_are_blocked_exactly_by_what_they_cross() {
        let idx = ObstacleIndex::new(
            vec![
                Shape::Rect {
                    min: (10.0, -1.0),
                    max: (12.0, 1.0),
                },
                Shape::Circle {
                    center: (0.0, 20.0),
                    radius: 2.0,
                },
            ],
            4.0,
        );
        assert!(idx.blocks(Point::new(0.0, 0.0), Point::new(20.0, 0.0)));
        assert!(!idx.blocks(Point::new(0.0, 1.5), Point::new(20.0, 1.5)));
        assert!(idx.blocks(Point::new(-5.0, 21.0), Point::new(5.0, 21.0)));
        assert!(!idx.blocks(Point::new(-5.0, 22.5), Point::new(5.0, 22.5)));
    }

    mod props {
        use super::*;
        use proptest::prelude::*;

        /// The sampled oracle: the earliest time on a fine grid at which the centre is within
        /// the radius of the primitive, refined by bisection. Independent of the closed forms.
        fn sampled(p0: Point, v: Vector, r: f64, prim: &Primitive, horizon: f64) -> Option<f64> {
            let gap = |t: f64| prim.distance(p0 + v * t) - r;
            if gap(0.0) <= 0.0 {
                return None;
            }
            let steps = 20_000;
            let mut prev = 0.0;
            for k in 1..=steps {
                let t = horizon * f64::from(k) / f64::from(steps);
                if gap(t) <= 0.0 {
                    let (mut lo, mut hi) = (prev, t);
                    for _ in 0..80 {
                        let mid = 0.5 * (lo + hi);
                        if gap(mid) <= 0.0 {
                            hi = mid;
                        } else {
                            lo = mid;
                        }
                    }
                    return Some(hi);
                }
                prev = t;
            }
            None
        }

        fn coord() -> impl Strategy<Value = f64> {
            -20.0..20.0f64
        }

        proptest! {
            #![proptest_config(ProptestConfig::with_cases(400))]
            #[test]
            fn contact_times_match_a_sampled_oracle(
                ax in coord(), ay in coord(), bx in coord(), by in coord(),
                px in coord(), py in coord(), vx in -5.0..5.0f64, vy in -5.0..5.0f64,
                r in 0.2..3.0f64, circle in any::<bool>(),
            ) {
                let prim = if circle {
                    Primitive::Circle(Point::new(ax, ay), (bx.abs() / 4.0).max(0.1))
                } else {
                    prop_assume!((ax - bx).hypot(ay - by) > 0.5);
                    Primitive::Segment(Point::new(ax, ay), Point::new(bx, by))
                };
                let p0 = Point::new(px, py);
                prop_assume!(prim.distance(p0) > r + 1e-6);
                let v = Vector::new(vx, vy);
                let horizon = 20.0;
                let got = first_contact(p0, v, r, &prim, horizon);
                let want = sampled(p0, v, r, &prim, horizon);
                match (got, want) {
                    (Some((t, c)), Some(w)) => {
                        prop_assert!((t - w).abs() < 1e-6 * (1.0 + w), "closed form {t}, sampled {w}");
                        // The contact point is on the primitive, one radius from the centre.
                        prop_assert!(prim.distance(c) < 1e-9);
                        prop_assert!(((p0 + v * t) - c).norm() - r < 1e-7);
                    }
                    (None, None) => {}
                    // A contact so shallow that the grid misses it: the closest approach is
                    // within a hair of the radius.
                    (Some((t, _)), None) => {
                        let min = (0..=2000).map(|k| prim.distance(p0 + v * (t + (f64::from(k) - 1000.0) * 1e-5))).fold(f64::INFINITY, f64::min);
                        prop_assert!(min > r - 1e-6, "missed by the oracle yet {min} < {r}");
                    }
                    (None, Some(w)) => prop_assert!(false, "no contact found, sampled one at {w}"),
                }
            }
        }
    }
}
