//! The spatial index: a uniform grid of square cells, as event-driven molecular dynamics codes
//! use (scale is designed in, seed 3.4 speaks of thousands of robots).
//!
//! Each robot is registered in the cell that contains its centre; a conditional
//! `CellCrossing` event moves it when it leaves. Cells are at least as wide as the largest
//! interaction distance (the sum of two radii, or a push sensor's reach), so two robots that
//! can touch are always in neighbouring cells, and predictions only ever look at the 3×3 block
//! around a robot: O(1) per request at uniform density. Cells are keyed by integer coordinates
//! in a hash map, so an infinite world costs only the occupied cells. The map is only ever
//! looked up, never iterated, so its hashing cannot affect the order of anything.

use std::collections::hash_map::Entry;
use std::collections::HashMap;

use smallvec::SmallVec;

use super::geometry::Point;
use super::RobotId;

/// Integer coordinates of a cell.
pub type Cell = [i64; 2];

/// A uniform grid of robots.
#[derive(Clone, Debug)]
pub struct Grid {
    size: f64,
    /// A cell's robots inline (24 bytes, as a `Vec`'s header) up to four: most cells hold one
    /// or two, and a separate allocation was a second cache miss at every look and an
    /// allocation at every crossing into an empty cell (issue 17).
    cells: HashMap<Cell, SmallVec<[RobotId; 4]>, FixedHash>,
}

impl Grid {
    /// An empty grid of cells `size` wide [units].
    pub fn new(size: f64) -> Self {
        assert!(size.is_finite() && size > 0.0, "cell size must be > 0");
        Self {
            size,
            cells: HashMap::default(),
        }
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
        self.cells.entry(c).or_default().push(id);
    }

    pub fn remove(&mut self, id: RobotId, c: Cell) {
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

    /// Robots in the 3×3 block of cells around `c`.
    pub fn neighbours(&self, c: Cell) -> impl Iterator<Item = RobotId> + '_ {
        (-1..=1)
            .flat_map(move |dx| (-1..=1).map(move |dy| [c[0] + dx, c[1] + dy]))
            .filter_map(|k| self.cells.get(&k))
            .flatten()
            .copied()
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
                if let Some(v) = self.cells.get(&[i, j]) {
                    out.extend_from_slice(v);
                }
            }
        }
        Some(out)
    }
}

/// The engine's hash maps' hasher: aHash under fixed keys, several times faster than the
/// standard SipHash on small keys (cells, ids), and the same on every run (nothing may depend
/// on a map's order anyway).
#[derive(Clone, Debug)]
pub struct FixedHash(ahash::RandomState);

impl Default for FixedHash {
    fn default() -> Self {
        Self(ahash::RandomState::with_seeds(
            0x6e65_6b6f,
            0x7369_6d75,
            0x6c61_746f,
            0x7267_7269,
        ))
    }
}

impl std::hash::BuildHasher for FixedHash {
    type Hasher = ahash::AHasher;

    fn build_hasher(&self) -> ahash::AHasher {
        self.0.build_hasher()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
