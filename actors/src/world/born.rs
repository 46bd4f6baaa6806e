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
    for &(p, r) in occupied {
        grid.insert(p, r);
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
    // The candidates to come, drawn from a copy of the stream, [`AHEAD`] before their turn:
    // the caller's stream moves on by exactly the candidates drawn, as it always did.
    let mut ahead = rng.clone();
    for _ in 0..AHEAD {
        grid.prefetch_block(draw(&mut ahead));
    }
    while out.len() < count {
        tries += 1;
        if tries > budget {
            return Err(fail(out.len()));
        }
        let p = draw(rng);
        grid.prefetch_block(draw(&mut ahead));
        if grid.clear(p, |q, r| (q - p).norm() >= r + radius) && clear(p) {
            grid.insert(p, radius);
            out.push(p);
        }
    }
    Ok(out)
}

/// How many candidates ahead of the one checked the placement asks for the cells around it
/// (a million robots' cells are tens of megabytes, and each check would otherwise be a chain
/// of cache misses). Only a hint: the same candidates are checked in the same order.
const AHEAD: usize = 16;

/// Discs a cell keeps in itself; more go to a shared list. The cells are about as many as
/// the discs, so most hold none, one or two.
const INLINE: usize = 2;

/// Cells on a side of a tile of [`Cells`] (64 cells of 64 bytes: a 4 KB page).
const TILE_BITS: usize = 3;
const TILE: usize = 1 << TILE_BITS;

/// A dense grid over the area for the rejection sampling: cells at least `min_cell` wide
/// (the largest diameter, so overlapping discs are in neighbouring cells) and about as many
/// as discs. Each cell is one cache line holding its first discs itself, and the cells are
/// laid out in square tiles of a page, so a check of the 3 × 3 cells around a candidate
/// mostly reads three runs of three lines on one page (a list of disc numbers per cell would
/// send each check to a disc and a link elsewhere in tens of megabytes). Discs outside
/// the area (an explicit robot may sit anywhere in the world) go to the nearest border cell,
/// which keeps overlapping discs in neighbouring cells.
struct Cells {
    size: f64,
    cols: usize,
    rows: usize,
    /// Tiles in a row of tiles.
    tiles: usize,
    cells: Vec<Cell>,
    /// The discs beyond a cell's [`INLINE`] first, each with the number (plus one) of the
    /// next of its cell's (0: none).
    more: Vec<((Point, f64), u32)>,
}

/// A cell of [`Cells`]: its first discs `(centre, radius)`, their number, and the number
/// (plus one) in [`Cells::more`] of its latest further disc (0: none).
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Cell {
    discs: [(Point, f64); INLINE],
    count: u32,
    more: u32,
}

const EMPTY: Cell = Cell {
    discs: [(Point::new(0.0, 0.0), 0.0); INLINE],
    count: 0,
    more: 0,
};

impl Cells {
    fn new(width: f64, height: f64, min_cell: f64, discs: usize) -> Self {
        let size = min_cell.max((width * height / discs.max(1) as f64).sqrt());
        let count = |extent: f64| ((extent / size).ceil() as usize).max(1);
        let (cols, rows) = (count(width), count(height));
        let tiles = cols.div_ceil(TILE);
        Self {
            size,
            cols,
            rows,
            tiles,
            cells: vec![EMPTY; tiles * rows.div_ceil(TILE) * TILE * TILE],
            more: Vec::new(),
        }
    }

    fn cell(&self, p: Point) -> (usize, usize) {
        let index = |v: f64, n: usize| ((v / self.size).floor().max(0.0) as usize).min(n - 1);
        (index(p.x, self.cols), index(p.y, self.rows))
    }

    /// The index in `cells` of the cell in column `c` and row `r`.
    fn at(&self, c: usize, r: usize) -> usize {
        let tile = (r >> TILE_BITS) * self.tiles + (c >> TILE_BITS);
        (tile << (2 * TILE_BITS)) | ((r & (TILE - 1)) << TILE_BITS) | (c & (TILE - 1))
    }

    /// Adds a disc of radius `r` at `p`.
    fn insert(&mut self, p: Point, r: f64) {
        let (c, row) = self.cell(p);
        let k = self.at(c, row);
        let cell = &mut self.cells[k];
        match cell.discs.get_mut(cell.count as usize) {
            Some(d) => *d = (p, r),
            None => {
                self.more.push(((p, r), cell.more));
                cell.more = u32::try_from(self.more.len()).expect("fewer than 2^32 discs");
            }
        }
        cell.count += 1;
    }

    /// The cells around `p`: columns and rows, each clipped to the grid.
    fn block(
        &self,
        p: Point,
    ) -> (
        std::ops::RangeInclusive<usize>,
        std::ops::RangeInclusive<usize>,
    ) {
        let (c, r) = self.cell(p);
        (
            c.saturating_sub(1)..=(c + 1).min(self.cols - 1),
            r.saturating_sub(1)..=(r + 1).min(self.rows - 1),
        )
    }

    /// Asks for the 3 × 3 cells around `p` ([`super::prefetch`]).
    fn prefetch_block(&self, p: Point) {
        let (cols, rows) = self.block(p);
        for r in rows {
            for c in cols.clone() {
                super::prefetch::prefetch(&self.cells[self.at(c, r)]);
            }
        }
    }

    /// Whether `ok(centre, radius)` holds for every disc in the 3 × 3 cells around `p`.
    fn clear(&self, p: Point, ok: impl Fn(Point, f64) -> bool) -> bool {
        let (cols, rows) = self.block(p);
        rows.into_iter().all(|r| {
            cols.clone().all(|c| {
                let cell = &self.cells[self.at(c, r)];
                let inline = (cell.count as usize).min(INLINE);
                cell.discs[..inline].iter().all(|&(q, s)| ok(q, s)) && {
                    let mut i = cell.more;
                    let mut clear = true;
                    while clear && i != 0 {
                        let ((q, s), next) = self.more[i as usize - 1];
                        clear = ok(q, s);
                        i = next;
                    }
                    clear
                }
            })
        })
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
