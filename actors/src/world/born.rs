//! Random born points (seed 6.1 `bornpoint.random`): non-overlapping robot positions inside
//! the world, drawn from a seeded random stream, with a clear error when they cannot fit.

use rand::Rng;

use super::geometry::Point;
use super::grid::Grid;

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
    rng: &mut impl Rng,
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
    let mut grid = Grid::new(2.0 * max_r);
    let mut discs: Vec<(Point, f64)> = Vec::with_capacity(occupied.len() + count);
    for &(p, r) in occupied {
        grid.insert(discs.len() as u32, grid.cell_of(p));
        discs.push((p, r));
    }
    let mut out = Vec::with_capacity(count);
    let budget = 1000 + 200 * count;
    let mut tries = 0;
    while out.len() < count {
        tries += 1;
        if tries > budget {
            return Err(fail(out.len()));
        }
        let p = Point::new(
            rng.gen_range(radius..=width - radius),
            rng.gen_range(radius..=height - radius),
        );
        let clear = grid
            .neighbours(grid.cell_of(p))
            .all(|i| (discs[i as usize].0 - p).norm() >= discs[i as usize].1 + radius);
        if clear {
            grid.insert(discs.len() as u32, grid.cell_of(p));
            discs.push((p, radius));
            out.push(p);
        }
    }
    Ok(out)
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
}
