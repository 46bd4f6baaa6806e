//! The spatial index: a uniform grid of square cells, as event-driven molecular dynamics codes
//! use (scale is designed in, seed 3.4 speaks of thousands of robots).
//!
//! Each robot is registered in the cell that contains its centre and, while it moves, in the
//! next ones on its path ([`Span`]); a conditional `CellCrossing` event registers it anew when
//! it leaves the last. Cells are at least as wide as the largest interaction distance (the sum
//! of two radii, or a push sensor's reach), so two robots that can touch are always in
//! neighbouring registered cells, and predictions only ever look at the 3×3 blocks around a
//! robot's cells: O(1) per request at uniform density. Cells are keyed by integer coordinates
//! in a hash map, so an infinite world costs only the occupied cells. The map is only ever
//! looked up, never iterated, so its hashing cannot affect the order of anything. A bounded
//! world whose cells are not many more than its robots also has a dense table of the cells
//! over its area ([`Grid::for_area`]): a 3×3 look-up reads three short runs of it instead of
//! hashing nine keys into a table of a million cells. A cell's robots are in the
//! same order either way.

use std::collections::hash_map::Entry;
use std::collections::HashMap;

use smallvec::SmallVec;

use super::geometry::Point;
use super::RobotId;

/// Integer coordinates of a cell.
pub type Cell = [i64; 2];

/// A cell's robots, inline (24 bytes, as a `Vec`'s header) up to four: most cells hold one
/// or two, and a separate allocation would be a second cache miss at every look and an
/// allocation at every crossing into an empty cell.
type Robots = SmallVec<[RobotId; 4]>;

/// Most cells a moving robot is registered in at once: its cell and the next ones on its path.
/// Six rather than four: with a pair predicted without result not kept, six makes fewer
/// events a simulated second at a million robots and fewer last-level cache misses at 100k,
/// and eight is slower at a million robots (docs/performance.md lists the gain).
pub const SPAN: usize = 6;

/// The cells a robot is registered in, after its first one (kept beside it): up to
/// [`SPAN`] - 1 steps along its path, each to one of the eight neighbouring cells (three bits
/// of count, then four a step). A moving robot is registered in the cells its centre will
/// pass through next, and crosses into new cells only when it leaves the last: one crossing
/// event every [`SPAN`] cells instead of one a cell (with one a cell, crossings would be
/// most of a million robots' events once they have turned). A robot near it is in a cell
/// next to one of them, whenever it is, so the 3×3 blocks around the span's cells still hold
/// every robot it can touch.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Span(u32);

impl Span {
    /// Number of cells, the first included.
    pub fn count(self) -> usize {
        (self.0 & 7) as usize + 1
    }

    /// Whether the span is its first cell alone (it is never empty).
    pub fn is_single(self) -> bool {
        self.0 & 7 == 0
    }

    /// Adds a step by `offset` (each coordinate -1, 0 or 1, not both 0).
    pub fn push(&mut self, offset: [i64; 2]) {
        let n = self.0 & 7;
        assert!((n as usize) < SPAN - 1, "a span of at most {SPAN} cells");
        let code = ((offset[0] + 1) * 3 + offset[1] + 1) as u32;
        self.0 = (self.0 | code << (3 + 4 * n)) & !7 | (n + 1);
    }

    /// The cells, from `first`, as a list kept inline ([`SpanCells`]).
    pub fn cell_list(self, first: Cell) -> SpanCells {
        let mut list = SpanCells {
            cells: [first; SPAN],
            len: self.count() as u8,
        };
        for (slot, c) in list.cells.iter_mut().zip(self.cells(first)) {
            *slot = c;
        }
        list
    }

    /// The cells, from `first`.
    pub fn cells(self, first: Cell) -> impl Iterator<Item = Cell> {
        let mut c = first;
        (0..self.count()).map(move |k| {
            if k > 0 {
                let code = (self.0 >> (3 + 4 * (k - 1))) & 15;
                c = [
                    c[0] + i64::from(code / 3) - 1,
                    c[1] + i64::from(code % 3) - 1,
                ];
            }
            c
        })
    }
}

/// A span's cells, in order ([`Span::cell_list`]): a fixed array and a length, filled without
/// the checks of a growing vector, which collecting into a `SmallVec` would pay at every
/// cell.
#[derive(Clone, Copy, Debug)]
pub struct SpanCells {
    cells: [Cell; SPAN],
    len: u8,
}

impl std::ops::Deref for SpanCells {
    type Target = [Cell];
    fn deref(&self) -> &[Cell] {
        &self.cells[..usize::from(self.len)]
    }
}

/// Whether `a` is `b` or one of its eight neighbours.
pub fn next_to(a: Cell, b: Cell) -> bool {
    (a[0] - b[0]).abs() <= 1 && (a[1] - b[1]).abs() <= 1
}

/// The cells of the 3×3 blocks around `cells`, each once: block by block in order, each
/// row by row as [`Grid::neighbours`] reads it, leaving out those of an earlier block.
pub fn blocks(cells: &[Cell]) -> SmallVec<[Cell; 3 * SPAN + 6]> {
    let mut out = SmallVec::new();
    for (k, &c) in cells.iter().enumerate() {
        for dx in -1..=1 {
            for dy in -1..=1 {
                let b = [c[0] + dx, c[1] + dy];
                if !cells[..k].iter().any(|&e| next_to(e, b)) {
                    out.push(b);
                }
            }
        }
    }
    out
}

/// Calls `visit` with the cells of [`blocks`]`(cells)` that are next to no cell of `skip`, in
/// the same order: the cells a robot registered in `cells` comes next to when it was in
/// `skip` before. The cells seen are kept in a bitmap, a row of bits per column of cells,
/// when all of them fit in 32 x 32 cells (a crossing's spans always do), so that a cell
/// costs a bit test rather than a comparison with each earlier cell (those comparisons would
/// be a large share of the instructions of the predictions around a robot).
pub fn blocks_beyond(cells: &[Cell], skip: &[Cell], mut visit: impl FnMut(Cell)) {
    const SIDE: i64 = 32;
    let (mut lo, mut hi) = ([i64::MAX; 2], [i64::MIN; 2]);
    for c in cells.iter().chain(skip) {
        for k in 0..2 {
            lo[k] = lo[k].min(c[k]);
            hi[k] = hi[k].max(c[k]);
        }
    }
    if cells.is_empty() {
        return;
    }
    if hi[0] - lo[0] + 3 > SIDE || hi[1] - lo[1] + 3 > SIDE {
        for (k, &c) in cells.iter().enumerate() {
            for dx in -1..=1 {
                for dy in -1..=1 {
                    let b = [c[0] + dx, c[1] + dy];
                    if !cells[..k].iter().chain(skip).any(|&e| next_to(e, b)) {
                        visit(b);
                    }
                }
            }
        }
        return;
    }
    // Column x of the window is cell column lo[0] - 1 + x; bit y of it, cell row lo[1] - 1 + y.
    let at = |c: Cell| ((c[0] - lo[0] + 1) as usize, (c[1] - lo[1] + 1) as u32);
    let mut seen = [0u32; SIDE as usize];
    let mark = |seen: &mut [u32; SIDE as usize], c: Cell| {
        let (x, y) = at(c);
        let block = 0b111 << (y - 1);
        for column in &mut seen[x - 1..=x + 1] {
            *column |= block;
        }
    };
    for &e in skip {
        mark(&mut seen, e);
    }
    for &c in cells {
        let (x, y) = at(c);
        for column in [x - 1, x, x + 1] {
            let mut free = (0b111 << (y - 1)) & !seen[column];
            while free != 0 {
                let bit = free.trailing_zeros();
                free &= free - 1;
                visit([lo[0] - 1 + column as i64, lo[1] - 1 + i64::from(bit)]);
            }
        }
        mark(&mut seen, c);
    }
}

/// A uniform grid of robots.
#[derive(Clone, Debug)]
pub struct Grid {
    size: f64,
    /// The cells over a bounded world's area, if it has them.
    dense: Option<Dense>,
    /// The other cells.
    cells: HashMap<Cell, Robots, FixedHash>,
}

/// The cells of a rectangle of them, in square tiles of [`TILE`] x [`TILE`] cells (8 KB, two
/// memory pages), tile by tile and row by row within a tile: the 3×3 block around a cell is
/// then almost always on one page or two, where rows of a million robots' world are 32 KB
/// apart and each of the block's three rows would be a page of its own (a miss in the
/// address translation's cache).
#[derive(Clone)]
struct Dense {
    lo: Cell,
    width: i64,
    height: i64,
    /// Tiles in a row of tiles.
    tiles: i64,
    /// Per cell (eight bytes a cell: a million robots at the seed's density have 16 million
    /// cells), `[EMPTY, EMPTY]`; or its robots themselves when they are one or two, the second
    /// [`EMPTY`] when alone (most occupied cells hold one robot or two, and reading a list
    /// would be a second cache miss at every look); or [`LIST`] plus the index of the cell's
    /// robots in `lists` first.
    heads: Vec<[u32; 2]>,
    lists: Vec<Robots>,
    /// Indices of empty lists in `lists`.
    free: Vec<u32>,
}

/// Cells on a side of a tile of [`Dense`].
const TILE_BITS: u32 = 5;
const TILE: i64 = 1 << TILE_BITS;

/// A dense cell without robots.
const EMPTY: u32 = u32::MAX;

/// The bit of a dense cell that says it holds a list index, not a robot.
const LIST: u32 = 1 << 31;

impl std::fmt::Debug for Dense {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Dense")
            .field("lo", &self.lo)
            .field("width", &self.width)
            .field("height", &self.height)
            .field("lists", &(self.lists.len() - self.free.len()))
            .finish()
    }
}

impl Dense {
    /// The index of `c` in `heads`, if it is in the rectangle.
    fn index(&self, c: Cell) -> Option<usize> {
        let (x, y) = (c[0].wrapping_sub(self.lo[0]), c[1].wrapping_sub(self.lo[1]));
        ((0..self.width).contains(&x) && (0..self.height).contains(&y)).then(|| {
            let tile = (y >> TILE_BITS) * self.tiles + (x >> TILE_BITS);
            let within = ((y & (TILE - 1)) << TILE_BITS) | (x & (TILE - 1));
            ((tile << (2 * TILE_BITS)) | within) as usize
        })
    }

    /// The robots of cell `i`, in order.
    fn get(&self, i: usize) -> &[RobotId] {
        let h = &self.heads[i];
        match h[0] {
            EMPTY => &[],
            k if k & LIST != 0 => &self.lists[(k & !LIST) as usize],
            _ => &h[..if h[1] == EMPTY { 1 } else { 2 }],
        }
    }

    /// Appends `id` to cell `i`'s robots.
    fn insert(&mut self, id: RobotId, i: usize) {
        let h = self.heads[i];
        let inline = h[0] & LIST == 0;
        if id & LIST == 0 {
            if h[0] == EMPTY {
                self.heads[i] = [id, EMPTY];
                return;
            }
            if inline && h[1] == EMPTY {
                self.heads[i][1] = id;
                return;
            }
        }
        if h[0] != EMPTY && !inline {
            self.lists[(h[0] & !LIST) as usize].push(id);
            return;
        }
        let k = self.free.pop().unwrap_or_else(|| {
            self.lists.push(Robots::new());
            let k = u32::try_from(self.lists.len() - 1).expect("fewer than 2^31 lists");
            assert!(k & LIST == 0, "fewer than 2^31 lists");
            k
        });
        let list = &mut self.lists[k as usize];
        list.extend(h.into_iter().filter(|&r| r != EMPTY));
        list.push(id);
        self.heads[i] = [k | LIST, EMPTY];
    }

    /// Removes `id` from cell `i`'s robots (the last takes its place, as `swap_remove`).
    fn remove(&mut self, id: RobotId, i: usize) {
        let h = self.heads[i];
        if h[0] == EMPTY {
            return;
        }
        if h[0] & LIST == 0 {
            if h[0] == id {
                self.heads[i] = [h[1], EMPTY];
            } else if h[1] == id {
                self.heads[i][1] = EMPTY;
            }
            return;
        }
        let k = h[0] & !LIST;
        let v = &mut self.lists[k as usize];
        if let Some(j) = v.iter().position(|&x| x == id) {
            v.swap_remove(j);
        }
        let inline = match v.as_slice() {
            [] => Some([EMPTY, EMPTY]),
            &[r] if r & LIST == 0 => Some([r, EMPTY]),
            &[r, s] if (r | s) & LIST == 0 => Some([r, s]),
            _ => None,
        };
        if let Some(head) = inline {
            if v.spilled() {
                *v = Robots::new();
            } else {
                v.clear();
            }
            self.heads[i] = head;
            self.free.push(k);
        }
    }
}

/// The most cells a dense table may have per robot (eight bytes each), beyond a floor.
const DENSE_PER_ROBOT: f64 = 32.0;

impl Grid {
    /// An empty grid of cells `size` wide [units].
    pub fn new(size: f64) -> Self {
        assert!(size.is_finite() && size > 0.0, "cell size must be > 0");
        Self {
            size,
            dense: None,
            cells: HashMap::default(),
        }
    }

    /// An empty grid of cells `size` wide [units] for `robots` robots in the rectangle
    /// `[min, max]`: with a dense table of the cells over it (and a margin of one cell) when
    /// they are at most 32 a robot (or 65,536); cells outside it, where robots can only be
    /// if nothing holds them in, are kept as in [`Grid::new`].
    pub fn for_area(size: f64, min: Point, max: Point, robots: usize) -> Self {
        let mut grid = Self::new(size);
        let (a, b) = (grid.cell_of(min), grid.cell_of(max));
        let (width, height) = ((b[0] - a[0] + 3) as f64, (b[1] - a[1] + 3) as f64);
        let cells = width * height;
        if cells.is_finite() && cells <= (DENSE_PER_ROBOT * robots as f64).max(65_536.0) {
            let (width, height) = (width as i64, height as i64);
            let tiles = (width + TILE - 1) >> TILE_BITS;
            let rows = (height + TILE - 1) >> TILE_BITS;
            grid.dense = Some(Dense {
                lo: [a[0] - 1, a[1] - 1],
                width,
                height,
                tiles,
                heads: vec![[EMPTY; 2]; ((tiles * rows) as usize) << (2 * TILE_BITS)],
                lists: Vec::new(),
                free: Vec::new(),
            });
        }
        grid
    }

    /// Width of a cell [units].
    pub fn cell_size(&self) -> f64 {
        self.size
    }

    /// The cell containing `p`.
    pub fn cell_of(&self, p: Point) -> Cell {
        [
            (p.x / self.size).floor() as i64,
            (p.y / self.size).floor() as i64,
        ]
    }

    /// The lower corner of a cell.
    pub fn lower_corner(&self, c: Cell) -> Point {
        Point::new(c[0] as f64 * self.size, c[1] as f64 * self.size)
    }

    pub fn insert(&mut self, id: RobotId, c: Cell) {
        if let Some(d) = self.dense.as_mut() {
            if let Some(i) = d.index(c) {
                return d.insert(id, i);
            }
        }
        self.cells.entry(c).or_default().push(id);
    }

    pub fn remove(&mut self, id: RobotId, c: Cell) {
        if let Some(d) = self.dense.as_mut() {
            if let Some(i) = d.index(c) {
                return d.remove(id, i);
            }
        }
        // One look-up, also when the cell empties (most cells hold one robot).
        if let Entry::Occupied(mut cell) = self.cells.entry(c) {
            let v = cell.get_mut();
            if let Some(i) = v.iter().position(|&x| x == id) {
                v.swap_remove(i);
            }
            if v.is_empty() {
                cell.remove();
            }
        }
    }

    /// The robots of cell `c`.
    fn get(&self, c: Cell) -> &[RobotId] {
        if let Some(d) = &self.dense {
            if let Some(i) = d.index(c) {
                return d.get(i);
            }
        }
        self.cells.get(&c).map_or(&[], |v| v.as_slice())
    }

    /// Asks for the dense table's cells of the 3×3 block around cell `c` to be brought into
    /// cache ([`super::prefetch`]), ahead of an event that will look at them. A no-op outside
    /// the dense table. (The caller reads `c` from the robot's state, which its handling
    /// reads anyway: a table of each robot's cell kept here for this would be one more cache
    /// miss at every registration and every look-ahead.)
    pub fn prefetch_around(&self, c: Cell) {
        let Some(d) = &self.dense else {
            return;
        };
        let Some(i) = d.index(c) else {
            return;
        };
        // Away from its tile's edges, the block is three runs of three cells a row apart in
        // the same tile.
        let (x, y) = (
            i & (TILE as usize - 1),
            (i >> TILE_BITS) & (TILE as usize - 1),
        );
        if (1..TILE as usize - 1).contains(&x) && (1..TILE as usize - 1).contains(&y) {
            for row in [i - TILE as usize, i, i + TILE as usize] {
                super::prefetch::prefetch(&d.heads[row - 1]);
                super::prefetch::prefetch(&d.heads[row + 1]);
            }
            return;
        }
        for dy in -1..=1 {
            for dx in [-1, 1] {
                if let Some(k) = d.index([c[0] + dx, c[1] + dy]) {
                    super::prefetch::prefetch(&d.heads[k]);
                }
            }
        }
    }

    /// The robots registered in cell `c`.
    pub fn robots_in(&self, c: Cell) -> &[RobotId] {
        self.get(c)
    }

    /// Robots in the 3×3 block of cells around `c`, column by column (`x` - 1 first), each
    /// from its lowest row.
    pub fn neighbours(&self, c: Cell) -> impl Iterator<Item = RobotId> + '_ {
        // The k-th cell's offset from `c`.
        let offset = |k: usize| (k as i64 / 3 - 1, k as i64 % 3 - 1);
        // Away from its tile's edges, a dense cell's neighbours are at fixed offsets from it:
        // one index worked out instead of nine.
        let interior = self.dense.as_ref().and_then(|d| {
            let i = d.index(c)?;
            let (x, y) = (
                i & (TILE as usize - 1),
                (i >> TILE_BITS) & (TILE as usize - 1),
            );
            let inside = 1..TILE as usize - 1;
            (inside.contains(&x) && inside.contains(&y)).then_some((d, i))
        });
        let cells: [&[RobotId]; 9] = match interior {
            Some((d, i)) => std::array::from_fn(|k| {
                let (dx, dy) = offset(k);
                d.get((i as i64 + dy * TILE + dx) as usize)
            }),
            None => std::array::from_fn(|k| {
                let (dx, dy) = offset(k);
                self.get([c[0] + dx, c[1] + dy])
            }),
        };
        cells.into_iter().flatten().copied()
    }

    /// Robots registered in cells that intersect the square `[lo, hi]`, or `None` when that
    /// square spans more cells than `limit` (the caller should then scan every robot).
    pub fn in_box(&self, lo: Point, hi: Point, limit: usize) -> Option<Vec<RobotId>> {
        let (a, b) = (self.cell_of(lo), self.cell_of(hi));
        let span = (b[0] - a[0] + 1) as f64 * (b[1] - a[1] + 1) as f64;
        if !span.is_finite() || span > limit as f64 {
            return None;
        }
        let mut out = Vec::new();
        for i in a[0]..=b[0] {
            for j in a[1]..=b[1] {
                out.extend_from_slice(self.get([i, j]));
            }
        }
        Some(out)
    }
}

/// The engine's hash maps' hasher: the standard SipHash under fixed keys, the same on every
/// run (nothing may depend on a map's order anyway, and a run must not depend on the
/// process's random keys).
pub type FixedHash = std::hash::BuildHasherDefault<std::collections::hash_map::DefaultHasher>;

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// The dense table and the hash map hold the same robots in the same order: the same
        /// neighbours in the same sequence (predictions are made in that order), the same
        /// boxes, after any inserts and removes, also of cells outside the dense area and of
        /// robots alone in a cell, in a list or too large an id to stand alone.
        #[test]
        fn a_dense_grid_agrees_with_the_hashed_one(
            ops in prop::collection::vec(
                (any::<bool>(), 0u32..40, -3i64..9, -3i64..9, 0usize..4, any::<bool>()), 0..300),
            probes in prop::collection::vec((-4i64..10, -4i64..10, 0usize..4), 1..20),
        ) {
            let mut hashed = Grid::new(10.0);
            // Cells 0..=35 (and a margin) dense, two tiles a side: the others hashed. Robots
            // gather around the corners of the dense area and around where its tiles meet.
            let mut dense = Grid::for_area(10.0, Point::new(0.0, 0.0), Point::new(355.0, 355.0), 40);
            let shift = |q: usize| [[0, 0], [28, 0], [0, 28], [28, 28]][q];
            prop_assert!(dense.dense.is_some());
            let mut at: Vec<Option<Cell>> = vec![None; 40];
            for (add, k, x, y, q, crowd) in ops {
                // Half the robots crowd into two by two cells, so that cells hold one, two,
                // three and more robots and go from each to each.
                let (x, y) = if crowd { (x.rem_euclid(2), y.rem_euclid(2)) } else { (x, y) };
                let (x, y) = (x + shift(q)[0], y + shift(q)[1]);
                // Some ids too large to stand alone in a dense cell.
                let id = if k % 5 == 0 { LIST | k } else { k };
                match (add, at[k as usize]) {
                    (true, None) => {
                        hashed.insert(id, [x, y]);
                        dense.insert(id, [x, y]);
                        at[k as usize] = Some([x, y]);
                    }
                    (false, Some(c)) => {
                        hashed.remove(id, c);
                        dense.remove(id, c);
                        at[k as usize] = None;
                    }
                    _ => {}
                }
            }
            for (x, y, q) in probes {
                let (x, y) = (x + shift(q)[0], y + shift(q)[1]);
                let a: Vec<RobotId> = hashed.neighbours([x, y]).collect();
                let b: Vec<RobotId> = dense.neighbours([x, y]).collect();
                prop_assert_eq!(a, b);
                let lo = Point::new(x as f64 * 10.0, y as f64 * 10.0);
                let hi = lo + nalgebra::Vector2::new(75.0, 55.0);
                prop_assert_eq!(hashed.in_box(lo, hi, 1000), dense.in_box(lo, hi, 1000));
            }
        }
    }

    /// Asking for the block around any cell (in the dense table, at its tiles' and its own
    /// edges, outside it, or in a hashed grid) is only a hint: it does not panic, and every
    /// cell's neighbours stay as they were.
    #[test]
    fn asking_for_cells_changes_nothing() {
        let mut dense = Grid::for_area(10.0, Point::new(0.0, 0.0), Point::new(355.0, 355.0), 40);
        let mut hashed = Grid::new(10.0);
        for (k, c) in [[0, 0], [5, 5], [31, 32], [-1, -1], [36, 36], [400, -7]]
            .iter()
            .enumerate()
        {
            dense.insert(k as RobotId, *c);
            hashed.insert(k as RobotId, *c);
        }
        let look = |g: &Grid| -> Vec<Vec<RobotId>> {
            (-3..40)
                .flat_map(|x| (-3..40).map(move |y| [x, y]))
                .map(|c| g.neighbours(c).collect())
                .collect()
        };
        let (before_dense, before_hashed) = (look(&dense), look(&hashed));
        for x in -3..40 {
            for y in -3..40 {
                for g in [&dense, &hashed] {
                    g.prefetch_around([x, y]);
                }
            }
        }
        dense.prefetch_around([i64::MAX, i64::MIN]);
        dense.prefetch_around([i64::MIN, i64::MAX]);
        assert_eq!(look(&dense), before_dense);
        assert_eq!(look(&hashed), before_hashed);
        assert_eq!(before_dense, before_hashed);
    }

    #[test]
    fn only_a_bounded_area_of_few_cells_a_robot_is_dense() {
        let (lo, hi) = (Point::new(0.0, 0.0), Point::new(800.0, 800.0));
        // 40 x 40 cells (42 x 42 with the margin) for 100 robots: under the floor.
        assert!(Grid::for_area(20.0, lo, hi, 100).dense.is_some());
        // 8,003 x 8,003 cells for 1,000 robots: too many; for 2.1 million, at most 32 a robot.
        let far = Point::new(160_000.0, 160_000.0);
        assert!(Grid::for_area(20.0, lo, far, 1_000).dense.is_none());
        assert!(Grid::for_area(20.0, lo, far, 2_000_000).dense.is_none());
        assert!(Grid::for_area(20.0, lo, far, 2_100_000).dense.is_some());
    }

    #[test]
    fn a_span_gives_back_its_steps() {
        let steps = [[1, 0], [1, 1], [0, -1]];
        let mut span = Span::default();
        assert!(span.is_single());
        assert_eq!(span.cells([5, -7]).collect::<Vec<_>>(), vec![[5, -7]]);
        for (k, &s) in steps.iter().enumerate() {
            span.push(s);
            assert_eq!(span.count(), k + 2);
        }
        assert!(!span.is_single());
        assert_eq!(
            span.cells([5, -7]).collect::<Vec<_>>(),
            vec![[5, -7], [6, -7], [7, -6], [7, -7]]
        );
        assert_eq!(
            &*span.cell_list([5, -7]),
            &[[5, -7], [6, -7], [7, -6], [7, -7]]
        );
        assert_eq!(&*Span::default().cell_list([5, -7]), &[[5, -7]]);
        // A full span, as a list and as the iterator.
        span.push([-1, -1]);
        span.push([-1, 1]);
        let full = [[5, -7], [6, -7], [7, -6], [7, -7], [6, -8], [5, -7]];
        assert_eq!(&*span.cell_list([5, -7]), &full);
        assert_eq!(span.cells([5, -7]).collect::<Vec<_>>(), full);
        // Every one of the eight steps, and -1 in both coordinates.
        for dx in -1..=1 {
            for dy in -1..=1 {
                if (dx, dy) != (0, 0) {
                    let mut one = Span::default();
                    one.push([dx, dy]);
                    assert_eq!(one.cells([0, 0]).last(), Some([dx, dy]));
                }
            }
        }
    }

    #[test]
    fn blocks_are_the_union_of_the_three_by_three_blocks_once_each() {
        for cells in [
            vec![[0, 0]],
            vec![[0, 0], [1, 0], [2, 0], [3, 0]],
            vec![[0, 0], [1, 1], [2, 1], [2, 2]],
            vec![[4, 4], [4, 3], [3, 2]],
        ] {
            let got = blocks(&cells);
            // Brute force: every cell of a box around them that is next to one of them.
            let mut want = Vec::new();
            for x in -2..8 {
                for y in -2..8 {
                    if cells.iter().any(|&c| next_to(c, [x, y])) {
                        want.push([x, y]);
                    }
                }
            }
            let mut sorted = got.to_vec();
            sorted.sort_unstable();
            sorted.dedup();
            assert_eq!(sorted.len(), got.len(), "{cells:?}: a cell twice");
            assert_eq!(sorted, want, "{cells:?}");
            // The first block comes first, in the order of `neighbours`.
            let c = cells[0];
            let first: Vec<Cell> = (-1..=1)
                .flat_map(|dx| (-1..=1).map(move |dy| [c[0] + dx, c[1] + dy]))
                .collect();
            assert_eq!(got[..9], first[..]);
        }
    }

    proptest! {
        /// The cells beyond the blocks of `skip` are those of [`blocks`] not next to a cell of
        /// `skip`, in the same order (brute force), for spans as a robot has them (a crossing's
        /// old cells, then the new ones from the neighbour of the last) and for cells far
        /// apart (beyond the bitmap's 32 x 32 cells).
        #[test]
        fn blocks_beyond_are_the_blocks_not_next_to_the_cells_skipped(
            start in (-50i64..50, -50i64..50),
            steps in prop::collection::vec((-1i64..=1, -1i64..=1), 1..8),
            split in 0usize..8,
            far in prop::collection::vec((-100i64..100, -100i64..100), 0..3),
        ) {
            let mut path = vec![[start.0, start.1]];
            for (dx, dy) in steps {
                let l = path[path.len() - 1];
                path.push([l[0] + dx, l[1] + dy]);
            }
            let split = split.min(path.len() - 1);
            let (skip, cells) = path.split_at(split);
            let mut cells = cells.to_vec();
            cells.extend(far.iter().map(|&(x, y)| [x, y]));
            let want: Vec<Cell> = blocks(&cells)
                .into_iter()
                .filter(|&b| !skip.iter().any(|&e| next_to(e, b)))
                .collect();
            let mut got = Vec::new();
            blocks_beyond(&cells, skip, |c| got.push(c));
            prop_assert_eq!(got, want);
        }
    }

    #[test]
    fn neighbours_are_the_robots_of_the_three_by_three_block() {
        let mut g = Grid::new(10.0);
        for (id, c) in [
            (0, [0, 0]),
            (1, [1, 1]),
            (2, [2, 0]),
            (3, [-1, -1]),
            (4, [0, 0]),
        ] {
            g.insert(id, c);
        }
        let mut n: Vec<RobotId> = g.neighbours([0, 0]).collect();
        n.sort_unstable();
        assert_eq!(n, vec![0, 1, 3, 4]);
        g.remove(0, [0, 0]);
        n = g.neighbours([0, 0]).collect();
        n.sort_unstable();
        assert_eq!(n, vec![1, 3, 4]);
        assert_eq!(g.cell_of(Point::new(-0.5, 19.9)), [-1, 1]);
    }
}
