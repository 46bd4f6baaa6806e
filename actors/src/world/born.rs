//! Random born points (seed 6.1 `bornpoint.random`): non-overlapping robot positions inside
//! the world, drawn from a seeded random stream, with a clear error when they cannot fit.

use rand::Rng;

use super::geometry::Point;

/// Why born points could not be drawn.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum BornError {
    /// Not all robots fit without overlapping (fatal before the run starts).
    #[error("could not place {count} robots of radius {radius} without overlap in a {width}x{height} area (placed {placed}); use a larger world or fewer/smaller robots")]
    DoesNotFit {
        count: usize,
        radius: f64,
        width: f64,
        height: f64,
        placed: usize,
    },
}

/// Draws `count` centres for robots of `radius` in `[0, width] × [0, height]`, keeping each
/// robot inside the area and clear of `occupied` discs `(centre, radius)` and of each other.
/// Rejection sampling over a grid: expected O(count) at the densities robots can move in.
pub fn random_born_points(
    count: usize,
    radius: f64,
    width: f64,
    height: f64,
    occupied: &[(Point, f64)],
    rng: &mut (impl Rng + Clone),
) -> Result<Vec<Point>, BornError> {
    random_born_points_clear(count, radius, width, height, occupied, &|_| true, rng)
}

/// [`random_born_points`] keeping only centres where `clear` holds as well (clear of the
/// world's obstacles): the same draws, a candidate is refused when it fails `clear`.
pub fn random_born_points_clear(
    count: usize,
    radius: f64,
    width: f64,
    height: f64,
    occupied: &[(Point, f64)],
    clear: &dyn Fn(Point) -> bool,
    rng: &mut (impl Rng + Clone),
) -> Result<Vec<Point>, BornError> {
    let fail = |placed| BornError::DoesNotFit {
        count,
        radius,
        width,
        height,
        placed,
    };
    if count == 0 {
        return Ok(Vec::new());
    }
    if width < 2.0 * radius || height < 2.0 * radius {
        return Err(fail(0));
    }
    let max_r = occupied.iter().map(|o| o.1).fold(radius, f64::max);
    let mut grid = Cells::new(width, height, 2.0 * max_r, occupied.len() + count);
    let mut discs: Vec<(Point, f64)> = Vec::with_capacity(occupied.len() + count);
    for &(p, r) in occupied {
        grid.insert(p);
        discs.push((p, r));
    }
    let mut out = Vec::with_capacity(count);
    let budget = 1000 + 200 * count;
    let mut tries = 0;
    let draw = |rng: &mut _| {
        Point::new(
            Rng::gen_range(rng, radius..=width - radius),
            Rng::gen_range(rng, radius..=height - radius),
        )
    };
    // The candidates to come, drawn from a copy of the stream: the caller's stream moves on
    // by exactly the candidates drawn, as it always did.
    let mut ahead = rng.clone();
    let mut coming: std::collections::VecDeque<Point> =
        (0..AHEAD).map(|_| draw(&mut ahead)).collect();
    coming.iter().for_each(|&q| grid.prefetch_block(q));
    while out.len() < count {
        tries += 1;
        if tries > budget {
            return Err(fail(out.len()));
        }
        let p = draw(rng);
        coming.pop_front();
        let q = draw(&mut ahead);
        grid.prefetch_block(q);
        coming.push_back(q);
        if let Some(&q) = coming.get(AHEAD / 2) {
            grid.prefetch_discs(q, &discs);
        }
        if grid.clear(p, |i| {
            let (q, r) = discs[i as usize];
            (q - p).norm() >= r + radius
        }) && clear(p)
        {
            grid.insert(p);
            discs.push((p, radius));
            out.push(p);
        }
    }
    Ok(out)
}

/// How many candidates ahead of the one checked the placement asks for memory (issue 17: a
/// million robots' cells and discs are tens of megabytes, and each check was a chain of cache
/// misses): the cells around a candidate this many ahead, and the first discs of those cells
/// for the candidate half as many ahead, whose cells were asked for earlier. Only hints: the
/// same candidates are checked in the same order.
const AHEAD: usize = 16;

/// A dense grid over the area for the rejection sampling: cells at least `min_cell` wide
/// (the largest diameter, so overlapping discs are in neighbouring cells) and about as many
/// as discs, each a linked list of the discs in it (`head`, `next`): two flat arrays, no
/// allocation per cell. Discs outside the area (an explicit robot may sit anywhere in the
/// world) go to the nearest border cell, which keeps overlapping discs in neighbouring cells.
struct Cells {
    size: f64,
    cols: usize,
    rows: usize,
    head: Vec<u32>,
    next: Vec<u32>,
}

const NONE: u32 = u32::MAX;

impl Cells {
    fn new(width: f64, height: f64, min_cell: f64, discs: usize) -> Self {
        let size = min_cell.max((width * height / discs.max(1) as f64).sqrt());
        let count = |extent: f64| ((extent / size).ceil() as usize).max(1);
        let (cols, rows) = (count(width), count(height));
        Self {
            size,
            cols,
            rows,
            head: vec![NONE; cols * rows],
            next: Vec::with_capacity(discs),
        }
    }

    fn cell(&self, p: Point) -> (usize, usize) {
        let index = |v: f64, n: usize| ((v / self.size).floor().max(0.0) as usize).min(n - 1);
        (index(p.x, self.cols), index(p.y, self.rows))
    }

    /// Adds the next disc (numbered in insertion order) at `p`.
    fn insert(&mut self, p: Point) {
        let (c, r) = self.cell(p);
        let k = r * self.cols + c;
        self.next.push(self.head[k]);
        self.head[k] = (self.next.len() - 1) as u32;
    }

    /// The rows of the 3 × 3 cells around `p`, each as a range of indices into `head`.
    fn block(&self, p: Point) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
        let (c, r) = self.cell(p);
        let (c0, c1) = (c.saturating_sub(1), (c + 1).min(self.cols - 1));
        (r.saturating_sub(1)..=(r + 1).min(self.rows - 1))
            .map(move |row| row * self.cols + c0..row * self.cols + c1 + 1)
    }

    /// Asks for the heads of the 3 × 3 cells around `p` ([`super::prefetch`]).
    fn prefetch_block(&self, p: Point) {
        for row in self.block(p) {
            super::prefetch::prefetch(&self.head[row.start]);
            super::prefetch::prefetch(&self.head[row.end - 1]);
        }
    }

    /// Asks for the first disc of each of the 3 × 3 cells around `p`, and its link.
    fn prefetch_discs(&self, p: Point, discs: &[(Point, f64)]) {
        for row in self.block(p) {
            for &h in &self.head[row] {
                if let (Some(d), Some(n)) = (discs.get(h as usize), self.next.get(h as usize)) {
                    super::prefetch::prefetch(d);
                    super::prefetch::prefetch(n);
                }
            }
        }
    }

    /// Whether `ok` holds for every disc in the 3 × 3 cells around `p`.
    fn clear(&self, p: Point, mut ok: impl FnMut(u32) -> bool) -> bool {
        for row in self.block(p) {
            for k in row {
                let mut i = self.head[k];
                while i != NONE {
                    if !ok(i) {
                        return false;
                    }
                    i = self.next[i as usize];
                }
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn points_are_inside_and_do_not_overlap_and_are_seeded() {
        let draw = |seed| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            random_born_points(
                300,
                5.0,
                400.0,
                300.0,
                &[(Point::new(50.0, 50.0), 20.0)],
                &mut rng,
            )
            .unwrap()
        };
        let pts = draw(3);
        assert_eq!(pts, draw(3));
        assert_ne!(pts, draw(4));
        for (i, p) in pts.iter().enumerate() {
            assert!(p.x >= 5.0 && p.x <= 395.0 && p.y >= 5.0 && p.y <= 295.0);
            assert!((p - Point::new(50.0, 50.0)).norm() >= 25.0);
            for q in &pts[..i] {
                assert!((p - q).norm() >= 10.0);
            }
        }
    }

    #[test]
    fn impossible_placement_is_a_clear_error() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let e = random_born_points(50, 5.0, 40.0, 40.0, &[], &mut rng).unwrap_err();
        assert!(matches!(e, BornError::DoesNotFit { count: 50, .. }));
        assert!(e.to_string().contains("could not place 50 robots"));
    }

    /// The same rejection sampling checked against every disc (O(n^2)): the grid changes the
    /// cost, never a point. Occupied discs of several sizes, one outside the area.
    #[test]
    fn the_grid_accepts_exactly_what_a_brute_force_check_accepts() {
        let occupied = [
            (Point::new(50.0, 50.0), 20.0),
            (Point::new(-8.0, 100.0), 12.0),
            (Point::new(390.0, 290.0), 3.0),
        ];
        // The last case is dense enough that the cells are as wide as a diameter.
        for (seed, count, radius, occupied) in [
            (1, 400, 5.0, &occupied[..]),
            (2, 40, 9.0, &occupied[..]),
            (3, 900, 3.0, &occupied[..]),
            (4, 2000, 2.0, &occupied[..]),
            (5, 3000, 2.0, &[][..]),
        ] {
            let (w, h) = (400.0, 300.0);
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let got = random_born_points(count, radius, w, h, occupied, &mut rng).unwrap();
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let mut discs = occupied.to_vec();
            let mut want = Vec::new();
            while want.len() < count {
                let p = Point::new(
                    rng.gen_range(radius..=w - radius),
                    rng.gen_range(radius..=h - radius),
                );
                if discs.iter().all(|(q, r)| (q - p).norm() >= r + radius) {
                    discs.push((p, radius));
                    want.push(p);
                }
            }
            assert_eq!(got, want, "seed {seed}");
        }
    }
}
