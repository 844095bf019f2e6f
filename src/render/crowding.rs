//! How many trees stand over one spot of a forest. A ray's work grows with the trees whose
//! boxes it is inside at once: it enters them all where it enters the first, before any is
//! dense enough to stop it. `place` keeps every tree its spacing from the next, so a point of
//! its forests lies under a few trees; but a hand-made `.instances` file of a few kilobytes
//! can stand a million trees on one spot, and a render of it would take hours. So the renderer
//! counts, before it builds anything, the trees over each tree's base, and refuses a forest
//! where one count is over the limit (`--max-overlap`).
//!
//! A tree stands over a point when the point lies within its reach: the largest horizontal
//! distance from its base (the model's origin, which it turns about) to a corner of its box,
//! times its scale. Heights are left out, so trees piled one above another count as one pile.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use rayon::prelude::*;

/// The first tree whose base more than `limit` trees stand over (itself included), and how
/// many do; `None` where every base has at most `limit`. `trees` are each tree's base (x, z)
/// and reach, in metres.
///
/// Trees are binned by reach into square grids whose cells are the next power of two up, so a
/// tree over a point is binned in the point's cell of its grid or one next to it. A query
/// stops at `limit + 1`: a pile is refused after `limit` comparisons, and a forest that keeps
/// its spacing reads a few trees per grid.
pub fn most_crowded(trees: &[([f64; 2], f64)], limit: u64) -> Option<(usize, u64)> {
    let grids = Grids::new(trees);
    let first = (0..trees.len())
        .into_par_iter()
        .position_first(|i| grids.over(trees, trees[i].0, limit.saturating_add(1)) > limit)?;
    Some((first, grids.over(trees, trees[first].0, u64::MAX)))
}

/// Cells are keyed by their grid (the power of two of their size) and their place in it.
type Cell = (i32, i64, i64);

struct Grids {
    /// The grids that hold any tree, by their power of two.
    levels: Vec<i32>,
    /// Per cell, its trees: a range of `order`.
    cells: HashMap<Cell, (u32, u32), BuildHasherDefault<CellHasher>>,
    /// The trees, cell by cell.
    order: Vec<u32>,
}

impl Grids {
    fn new(trees: &[([f64; 2], f64)]) -> Grids {
        let mut keyed: Vec<(Cell, u32)> = trees
            .par_iter()
            .enumerate()
            .map(|(i, &(base, reach))| (cell(base, level(reach)), i as u32))
            .collect();
        keyed.par_sort_unstable();
        let mut cells = HashMap::default();
        let mut start = 0;
        for run in keyed.chunk_by(|a, b| a.0 == b.0) {
            cells.insert(run[0].0, (start as u32, (start + run.len()) as u32));
            start += run.len();
        }
        let mut levels: Vec<i32> = keyed.iter().map(|(c, _)| c.0).collect();
        levels.dedup();
        Grids {
            levels,
            cells,
            order: keyed.into_iter().map(|(_, i)| i).collect(),
        }
    }

    /// How many trees stand over `point`, counted up to `most`.
    fn over(&self, trees: &[([f64; 2], f64)], point: [f64; 2], most: u64) -> u64 {
        let mut n = 0;
        for &l in &self.levels {
            let (_, cx, cz) = cell(point, l);
            for dx in -1..=1 {
                for dz in -1..=1 {
                    // Past i64's range there is no cell (a point there is in the last one).
                    let (Some(x), Some(z)) = (cx.checked_add(dx), cz.checked_add(dz)) else {
                        continue;
                    };
                    let Some(&(from, to)) = self.cells.get(&(l, x, z)) else {
                        continue;
                    };
                    for &j in &self.order[from as usize..to as usize] {
                        let ([x, z], reach) = trees[j as usize];
                        let (dx, dz) = ((x - point[0]).abs(), (z - point[1]).abs());
                        // Most are told by a side alone; hypot, not a sum of squares, where
                        // squares of 1e300 would overflow.
                        if dx <= reach && dz <= reach && dx.hypot(dz) <= reach {
                            n += 1;
                            if n >= most {
                                return n;
                            }
                        }
                    }
                }
            }
        }
        n
    }
}

/// A hasher for cells: a multiply and a rotate per word (as rustc's FxHasher). The cells
/// come from the file, but a collision only costs time, and equal keys are compared whole.
#[derive(Default)]
struct CellHasher(u64);

impl Hasher for CellHasher {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(u64::from(b));
        }
    }

    fn write_u32(&mut self, n: u32) {
        self.write_u64(u64::from(n));
    }

    fn write_i32(&mut self, n: i32) {
        self.write_u64(n as u64);
    }

    fn write_i64(&mut self, n: i64) {
        self.write_u64(n as u64);
    }

    fn write_u64(&mut self, n: u64) {
        self.0 = (self.0.rotate_left(5) ^ n).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

/// The grid of a tree of `reach` m: cells of the least power of two at or above it (within
/// f64's range: 2^-1000 to 2^1000 m).
fn level(reach: f64) -> i32 {
    if reach > 0.0 {
        (reach.log2().ceil() as i32).clamp(-1000, 1000)
    } else {
        -1000
    }
}

/// The cell of `point` in grid `level` (a point beyond i64's range of cells shares the last
/// one: its trees are still told apart by their distance).
fn cell(point: [f64; 2], level: i32) -> Cell {
    let size = 2f64.powi(level);
    (
        level,
        (point[0] / size).floor() as i64,
        (point[1] / size).floor() as i64,
    )
}

#[cfg(test)]
mod tests {
    use super::most_crowded;

    #[test]
    fn a_pile_is_found_and_counted_and_a_spaced_forest_passes() {
        // A grid of trees 5 m apart, each reaching 6 m: a base lies within reach of itself
        // and its four nearest neighbours (5 m), not the diagonal ones (7.1 m).
        let mut trees: Vec<([f64; 2], f64)> = (0..400)
            .map(|i| ([f64::from(i % 20) * 5.0, f64::from(i / 20) * 5.0], 6.0))
            .collect();
        assert_eq!(most_crowded(&trees, 5), None);
        // A corner tree has two neighbours, an edge tree three: the first inside is 21.
        assert_eq!(most_crowded(&trees, 4), Some((21, 5)));
        // A pile of 3,000 trees on one base, and one giant whose reach covers everything.
        trees.extend(std::iter::repeat_n(([50.0, 50.0], 1.0), 3000));
        trees.push(([-1e6, 0.0], 2e6));
        let (i, n) = most_crowded(&trees, 1024).unwrap();
        assert_eq!(trees[i].0, [50.0, 50.0]);
        // The pile, the giant, and the grid tree standing on the same spot with its four
        // neighbours.
        assert_eq!(n, 3000 + 1 + 5);
    }

    #[test]
    fn reaches_of_every_size_and_far_places_are_binned_without_overflow() {
        let trees = [
            ([0.0, 0.0], 0.0),
            ([0.0, 0.0], 1e-300),
            ([1e300, -1e300], 1e300),
            ([-1e300, 1e300], 3.0),
            ([0.5, 0.0], 0.5),
        ];
        // The first two stand on one spot, and the fifth reaches it.
        assert_eq!(most_crowded(&trees, 2), Some((0, 3)));
        assert_eq!(most_crowded(&trees, 3), None);
    }
}
