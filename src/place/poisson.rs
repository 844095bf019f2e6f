//! Maximal Poisson-disk sampling with a radius per sample: the paper's dart throwing ("a random
//! point is rejected if it lies in a forbidden zone, else it becomes a tree and forbids a disc of
//! its radius around it"), made fast by Bridson's algorithm (2007) on a background grid.
//!
//! The rule: two samples i and j are at least `max(r_i, r_j)` apart, so no sample lies inside
//! another's disc. Growth: an active sample throws darts in the annulus between its radius and
//! twice it; a dart that the caller accepts (habitable ground, a species and a size drawn
//! there) and that breaks no disc becomes a sample. A sample retires after `ATTEMPTS` failed
//! darts in a row. When no sample is active, a scan over the background grid throws a few
//! darts into every empty cell whose centre no disc covers and starts growth again from the
//! first that takes; so separate patches of habitable ground are all reached and the larger
//! gaps random darts leave are closed. No point is left farther than about 1.25 radii from a
//! sample (measured; an exactly maximal set would have 1).
//!
//! The region is cut into bands along z, each many radii tall. Even bands are sampled first,
//! in parallel (an odd band between any two keeps them from interacting), then odd bands, in
//! parallel, each seeing its neighbours' samples near its edges. The bands are fixed by the
//! region and the radii, and every random draw is keyed by (seed, band, sample, attempt) or
//! (seed, band, grid cell), so the result depends on the seed only, not on the threads.

use rayon::prelude::*;

use crate::rng::{self, purpose};

/// Darts an active sample throws before it retires (Bridson's k).
const ATTEMPTS: u32 = 20;
/// Darts the gap-filling scan throws into an empty cell whose centre no disc covers.
const SCAN_DARTS: u64 = 4;
/// Active samples a parent is drawn from: the most recent ones.
const WINDOW: usize = 32;
/// Height of a band, in largest radii.
const BAND: f64 = 64.0;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disc {
    pub x: f64,
    pub z: f64,
    pub r: f64,
}

/// Why sampling could not start.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PoissonError {
    #[error(
        "the region, {width:.0} m x {depth:.0} m, needs {cells} background cells for a smallest \
         radius of {r_min:.2} m (at most {MAX_CELLS}); narrow it with --region, or check the \
         terrain's units"
    )]
    TooLarge {
        cells: u64,
        r_min: f64,
        width: f64,
        depth: f64,
    },
}

/// Largest background grid (cells) over the whole region: 12 bytes each.
const MAX_CELLS: u64 = 400_000_000;

/// Samples [x0, x1] x [z0, z1]. `propose(x, z, key)` decides whether a tree can stand at
/// (x, z) and, if so, its radius (within [r_min, r_max]) and payload, drawing any randomness
/// from `key`. `may_take([x0, z0, x1, z1])` says cheaply whether any point of a rectangle
/// might be accepted (false lets the gap-filling scan skip it). The result is ordered by band,
/// then by creation; with `max_count` only its first samples are kept.
pub fn sample<T: Send>(
    region: [f64; 4],
    r_min: f64,
    r_max: f64,
    seed: u64,
    max_count: usize,
    may_take: impl Fn([f64; 4]) -> bool + Sync,
    propose: impl Fn(f64, f64, u64) -> Option<(f64, T)> + Sync,
) -> Result<Vec<(Disc, T)>, PoissonError> {
    let [x0, z0, x1, z1] = region;
    let cells = ((x1 - x0) / r_min * std::f64::consts::SQRT_2).ceil()
        * ((z1 - z0) / r_min * std::f64::consts::SQRT_2).ceil();
    if cells > MAX_CELLS as f64 {
        return Err(PoissonError::TooLarge {
            cells: cells as u64,
            r_min,
            width: x1 - x0,
            depth: z1 - z0,
        });
    }
    let height = (BAND * r_max).max(4.0 * r_max);
    let count = ((z1 - z0) / height).ceil().max(1.0) as usize;
    let band = |b: usize| {
        [
            x0,
            z0 + b as f64 * height,
            x1,
            (z0 + (b + 1) as f64 * height).min(z1),
        ]
    };
    let mut results: Vec<Vec<(Disc, T)>> = (0..count).map(|_| Vec::new()).collect();
    for phase in 0..2 {
        let done: Vec<Vec<Disc>> = results
            .iter()
            .map(|r| r.iter().map(|(d, _)| *d).collect())
            .collect();
        let fresh: Vec<(usize, Vec<(Disc, T)>)> = (phase..count)
            .step_by(2)
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|b| {
                let neighbours: Vec<Disc> = [b.wrapping_sub(1), b + 1]
                    .iter()
                    .filter_map(|&n| done.get(n))
                    .flatten()
                    .copied()
                    .collect();
                let key = rng::hash3(seed, purpose::BAND, b as u64);
                (
                    b,
                    sample_band(
                        band(b),
                        &neighbours,
                        (r_min, r_max),
                        key,
                        max_count,
                        &may_take,
                        &propose,
                    ),
                )
            })
            .collect();
        for (b, samples) in fresh {
            results[b] = samples;
        }
    }
    let mut all: Vec<(Disc, T)> = results.into_iter().flatten().collect();
    all.truncate(max_count);
    Ok(all)
}

/// One band's samples as they grow.
struct Strip<T> {
    grid: DiscGrid,
    discs: Vec<Disc>,
    payloads: Vec<T>,
    /// Darts each sample has thrown.
    tries: Vec<u32>,
    /// Samples still throwing darts.
    active: Vec<u32>,
}

impl<T> Strip<T> {
    /// Accepts (x, z) if the caller takes it and it breaks no disc, and makes it active. The
    /// caller is asked only after the cheap test against the existing discs' own radii, which
    /// most darts fail.
    fn try_dart(
        &mut self,
        x: f64,
        z: f64,
        key: u64,
        propose: &impl Fn(f64, f64, u64) -> Option<(f64, T)>,
    ) -> bool {
        if !self.grid.inside(x, z) || self.grid.covers(x, z) {
            return false;
        }
        let Some((r, payload)) = propose(x, z, key) else {
            return false;
        };
        if !self.grid.fits(x, z, r) {
            return false;
        }
        self.grid.put(x, z, r);
        self.active.push(self.discs.len() as u32);
        self.discs.push(Disc { x, z, r });
        self.payloads.push(payload);
        self.tries.push(0);
        true
    }
}

/// Samples one band, respecting the discs of samples already made beside it; stops at `cap`
/// samples (no band needs more than the whole forest may keep, and a dense species file must
/// not fill memory before the cap applies).
fn sample_band<T>(
    region: [f64; 4],
    neighbours: &[Disc],
    (r_min, r_max): (f64, f64),
    seed: u64,
    cap: usize,
    may_take: &impl Fn([f64; 4]) -> bool,
    propose: &impl Fn(f64, f64, u64) -> Option<(f64, T)>,
) -> Vec<(Disc, T)> {
    let mut grid = DiscGrid::new(region, r_min, r_max);
    for d in neighbours {
        grid.put(d.x, d.z, d.r);
    }
    let [x0, z0, x1, z1] = region;
    let mut band = Strip {
        grid,
        discs: Vec::new(),
        payloads: Vec::new(),
        tries: Vec::new(),
        active: Vec::new(),
    };
    let mut scan = 0usize;
    let mut step = 0u64;
    while band.discs.len() < cap {
        if !band.active.is_empty() {
            // A random one of the most recently added: growth stays on a compact front, which
            // keeps the grid's working set in cache, yet is not a single ordered wave.
            let window = band.active.len().min(WINDOW);
            let slot =
                band.active.len() - 1 - rng::hash3(seed, purpose::PICK, step) as usize % window;
            let parent = band.active[slot] as usize;
            step += 1;
            let p = band.discs[parent];
            let mut placed = false;
            for _ in 0..ATTEMPTS {
                let attempt = band.tries[parent];
                band.tries[parent] += 1;
                let key = rng::hash3(seed ^ purpose::GROW, parent as u64, attempt as u64);
                // A point of the annulus between r and 2r, uniform over its area, by
                // rejection from the enclosing square (no trigonometry in the inner loop).
                let mut k = key;
                let (dx, dz) = loop {
                    let (u, v) = (
                        2.0 * rng::unit(k) - 1.0,
                        2.0 * rng::unit(rng::mix64(k)) - 1.0,
                    );
                    let d2 = u * u + v * v;
                    if (0.25..=1.0).contains(&d2) {
                        break (u * 2.0 * p.r, v * 2.0 * p.r);
                    }
                    k = rng::mix64(k ^ purpose::GROW);
                };
                if band.try_dart(p.x + dx, p.z + dz, rng::mix64(key ^ purpose::GROW), propose) {
                    placed = true;
                    break;
                }
            }
            if !placed {
                band.active.swap_remove(slot);
            }
            continue;
        }
        // Nothing active: look for the next empty cell that can take a sample. Where the cell's
        // centre lies in no disc, a few darts in the cell look for room.
        let finest = &band.grid.classes[0];
        let (cell, nx, nz) = (finest.cell, finest.nx, finest.nz);
        let mut seeded = false;
        while scan < nx * nz && !seeded {
            let (ci, cj) = (scan % nx, scan / nx);
            scan += 1;
            let (sx, sz) = (x0 + ci as f64 * cell, z0 + cj as f64 * cell);
            if band.grid.holds(ci, cj)
                || !may_take([sx, sz, sx + cell, sz + cell])
                || band.grid.covers(sx + 0.5 * cell, sz + 0.5 * cell)
            {
                continue;
            }
            let c = band.grid.scan_key(ci, cj);
            seeded = (0..SCAN_DARTS).any(|k| {
                let key = rng::hash3(seed ^ purpose::SCAN, c as u64, k);
                let (x, z) = (
                    sx + rng::unit(key) * cell,
                    sz + rng::unit(rng::mix64(key)) * cell,
                );
                x < x1 && z < z1 && band.try_dart(x, z, rng::mix64(key ^ purpose::SCAN), propose)
            });
        }
        if !seeded {
            break;
        }
    }
    band.discs.into_iter().zip(band.payloads).collect()
}

/// A background cell: the sample in it, position relative to the region's minimum corner;
/// radius 0 for none. Keeping the sample in the grid saves a dependent load per lookup.
#[derive(Clone, Copy)]
struct Slot {
    x: f32,
    z: f32,
    r: f32,
}

const EMPTY: Slot = Slot {
    x: 0.0,
    z: 0.0,
    r: 0.0,
};

/// The discs made so far, sorted by radius into classes an octave wide: class k holds radii
/// in [r_min 2^k, r_min 2^(k+1)) (the last up to r_max), on a grid of cells r_min 2^k / sqrt 2
/// wide, so that a cell holds at most one of them. A query of radius r looks, in each class,
/// only at the cells within max(r, the class's largest radius). On one grid of r_min's cells
/// every query looked at all the cells within r_max: about 6 (r_max / r_min)^2 of them, 25,000
/// at a ratio of 64, where a small dart's fit needs a few dozen per class. Only speed depends
/// on the classes: whether a dart fits is the same test against the same discs.
struct DiscGrid {
    x0: f64,
    z0: f64,
    x1: f64,
    z1: f64,
    /// The finest first: its cells are the gap-filling scan's.
    classes: Vec<ClassGrid>,
}

/// One class of [`DiscGrid`]: its cells, with a border of empty cells as wide as the largest
/// radius so neighbourhood scans need no bounds checks.
struct ClassGrid {
    cell: f64,
    /// The largest radius the class holds.
    r_top: f64,
    nx: usize,
    nz: usize,
    pad: usize,
    stride: usize,
    cells: Vec<Slot>,
    /// Linear offsets of the cells that can hold a sample closer than r_max, nearest first,
    /// each with its gap (the least distance between a point of the cell and one of the
    /// centre cell): a query stops at the first gap beyond its reach, and a conflict (or a
    /// covering disc) is usually found in the first few lookups.
    offsets: Vec<(isize, f64)>,
}

impl ClassGrid {
    fn new(region: [f64; 4], cell: f64, r_top: f64, r_max: f64) -> ClassGrid {
        let [x0, z0, x1, z1] = region;
        let nx = ((x1 - x0) / cell).ceil().max(1.0) as usize;
        let nz = ((z1 - z0) / cell).ceil().max(1.0) as usize;
        let reach = (r_max / cell).ceil() as usize + 1;
        let stride = nx + 2 * reach;
        let cells = stride * (nz + 2 * reach);
        let reach_i = reach as isize;
        let mut offsets: Vec<(isize, isize, f64)> = (-reach_i..=reach_i)
            .flat_map(|dj| (-reach_i..=reach_i).map(move |di| (di, dj)))
            .map(|(di, dj)| {
                let gap = |d: isize| (d.abs() - 1).max(0) as f64 * cell;
                (di, dj, gap(di).hypot(gap(dj)))
            })
            .filter(|o| o.2 < r_max)
            .collect();
        offsets.sort_by(|a, b| a.2.total_cmp(&b.2).then((a.1, a.0).cmp(&(b.1, b.0))));
        ClassGrid {
            cell,
            r_top,
            nx,
            nz,
            pad: reach,
            stride,
            cells: vec![EMPTY; cells],
            offsets: offsets
                .iter()
                .map(|&(di, dj, gap)| (di + dj * stride as isize, gap))
                .collect(),
        }
    }

    /// The cell of a point (relative to the region's corner) in the region or within a
    /// cell of it, whose neighbourhood the border still holds.
    fn cell_of(&self, x: f64, z: f64) -> usize {
        self.index((x / self.cell) as usize, (z / self.cell) as usize)
    }

    /// Cell (i, j) of the region as one index into `cells`.
    fn index(&self, i: usize, j: usize) -> usize {
        (i + self.pad) + (j + self.pad) * self.stride
    }

    /// The cell of a point in the grid or its border (for samples beside the region).
    fn padded_cell_of(&self, x: f64, z: f64) -> Option<usize> {
        let i = (x / self.cell).floor() as isize + self.pad as isize;
        let j = (z / self.cell).floor() as isize + self.pad as isize;
        let rows = (self.cells.len() / self.stride) as isize;
        (i >= 0 && j >= 0 && i < self.stride as isize && j < rows)
            .then(|| i as usize + j as usize * self.stride)
    }
}

impl DiscGrid {
    fn new(region: [f64; 4], r_min: f64, r_max: f64) -> DiscGrid {
        let [x0, z0, x1, z1] = region;
        let mut classes = Vec::new();
        let mut low = r_min;
        loop {
            let last = 2.0 * low > r_max;
            let r_top = if last { r_max } else { 2.0 * low };
            classes.push(ClassGrid::new(
                region,
                low / std::f64::consts::SQRT_2,
                r_top,
                r_max,
            ));
            if last {
                break;
            }
            low *= 2.0;
        }
        DiscGrid {
            x0,
            z0,
            x1,
            z1,
            classes,
        }
    }

    /// The class of a disc of radius `r`.
    fn class_of(&self, r: f64) -> usize {
        let last = self.classes.len() - 1;
        self.classes[..last]
            .iter()
            .position(|g| r < g.r_top)
            .unwrap_or(last)
    }

    fn inside(&self, x: f64, z: f64) -> bool {
        x >= self.x0 && z >= self.z0 && x < self.x1 && z < self.z1
    }

    /// Adds a disc, in the region or beside it (a neighbouring band's, which is dropped if
    /// it lies beyond the border, where no query reaches).
    fn put(&mut self, x: f64, z: f64, r: f64) {
        let k = self.class_of(r);
        let (x, z) = (x - self.x0, z - self.z0);
        let grid = &mut self.classes[k];
        if let Some(c) = grid.padded_cell_of(x, z) {
            grid.cells[c] = Slot {
                x: x as f32,
                z: z as f32,
                r: r as f32,
            };
        }
    }

    /// Whether a sample of radius `r` at (x, z), in the region, is at least max(r, r_j)
    /// from every sample j (`r` = 0: whether no disc covers the point).
    fn fits(&self, x: f64, z: f64, r: f64) -> bool {
        let (x, z) = (x - self.x0, z - self.z0);
        let (xf, zf, rf) = (x as f32, z as f32, r as f32);
        self.classes.iter().all(|grid| {
            let c = grid.cell_of(x, z) as isize;
            // A little beyond the class's reach, so that rounding of the radii to f32 can
            // never leave out a cell whose disc the test below would find.
            let reach = r.max(grid.r_top) * (1.0 + 1e-6);
            grid.offsets
                .iter()
                .take_while(|o| o.1 < reach)
                .all(|&(o, _)| {
                    let s = grid.cells[(c + o) as usize];
                    let limit = s.r.max(rf);
                    s.r == 0.0 || (s.x - xf).powi(2) + (s.z - zf).powi(2) >= limit * limit
                })
        })
    }

    /// Whether some disc covers the point (x, z), in the region or within a cell of it.
    fn covers(&self, x: f64, z: f64) -> bool {
        !self.fits(x, z, 0.0)
    }

    /// Whether the finest class's cell (i, j) holds a sample: a cheap first look, for the
    /// gap-filling scan, that [`DiscGrid::covers`] would confirm.
    fn holds(&self, i: usize, j: usize) -> bool {
        self.classes[0].cells[self.scan_key(i, j)].r != 0.0
    }

    /// The finest class's cell (i, j) as one number, which keys the scan's darts there.
    fn scan_key(&self, i: usize, j: usize) -> usize {
        self.classes[0].index(i, j)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_radius_samples_keep_their_distance_and_fill_the_square() {
        let r = 1.0;
        let s = sample(
            [0.0, 0.0, 40.0, 40.0],
            r,
            r,
            7,
            usize::MAX,
            |_| true,
            |_, _, _| Some((r, ())),
        )
        .unwrap();
        for (i, (a, _)) in s.iter().enumerate() {
            for (b, _) in &s[i + 1..] {
                assert!((a.x - b.x).hypot(a.z - b.z) >= r);
            }
        }
        // Nearly maximal: every point of the square is within 1.3 r of a sample (an exactly
        // maximal set: r; the bound: 2 r; checked on a fine grid).
        let mut worst: f64 = 0.0;
        for k in 0..400 * 400 {
            let (x, z) = ((k % 400) as f64 * 0.1 + 0.05, (k / 400) as f64 * 0.1 + 0.05);
            let near = s
                .iter()
                .map(|(d, _)| (d.x - x).hypot(d.z - z))
                .fold(f64::INFINITY, f64::min);
            worst = worst.max(near);
        }
        assert!(worst < 1.3 * r, "largest gap {worst}");
        // Density of a maximal Poisson-disk set: about 0.6 to 0.75 samples per r^2.
        let density = s.len() as f64 / 1600.0;
        assert!((0.55..0.8).contains(&density), "{density}");
    }

    #[test]
    fn separate_patches_are_all_filled_and_radii_may_vary() {
        // Two habitable strips 10 m apart; radius grows with x.
        let propose = |x: f64, _z: f64, _k: u64| -> Option<(f64, ())> {
            let habitable = !(10.0..=20.0).contains(&x);
            habitable.then_some((0.5 + x / 30.0, ()))
        };
        let s = sample(
            [0.0, 0.0, 30.0, 10.0],
            0.5,
            1.5,
            3,
            usize::MAX,
            |_| true,
            propose,
        )
        .unwrap();
        assert!(s.iter().any(|(d, _)| d.x < 10.0) && s.iter().any(|(d, _)| d.x > 20.0));
        assert!(s.iter().all(|(d, _)| d.x < 10.0 || d.x > 20.0));
        for (i, (a, _)) in s.iter().enumerate() {
            for (b, _) in &s[i + 1..] {
                assert!((a.x - b.x).hypot(a.z - b.z) >= a.r.max(b.r) - 1e-12);
            }
        }
    }

    #[test]
    fn radii_64_times_apart_keep_the_rule_and_leave_no_room() {
        // The radius a tree at (x, z) would take: 0.25 m at the left edge to 16 m at the
        // right, with a dart's own jitter; every octave of radius meets the next.
        let radius = |x: f64| 0.25 * 64f64.powf(x / 60.0);
        let propose = |x: f64, _z: f64, key: u64| -> Option<(f64, ())> {
            let wobble = 1.0 + 0.2 * (rng::unit(key) - 0.5);
            Some(((radius(x) * wobble).clamp(0.25, 16.0), ()))
        };
        let s = sample(
            [0.0, 0.0, 60.0, 30.0],
            0.25,
            16.0,
            5,
            usize::MAX,
            |_| true,
            propose,
        )
        .unwrap();
        let discs: Vec<Disc> = s.iter().map(|(d, _)| *d).collect();
        assert!(discs.iter().any(|d| d.r < 0.5) && discs.iter().any(|d| d.r > 8.0));
        for (i, a) in discs.iter().enumerate() {
            for b in &discs[i + 1..] {
                let d = (a.x - b.x).hypot(a.z - b.z);
                assert!(d >= a.r.max(b.r) * (1.0 - 1e-6), "{a:?} and {b:?}: {d}");
            }
        }
        // Nearly maximal, as with one radius: at every point some disc is nearer than 1.3
        // times the larger of its radius and the radius a tree there would take.
        for k in 0..300 * 150 {
            let (x, z) = ((k % 300) as f64 * 0.2 + 0.1, (k / 300) as f64 * 0.2 + 0.1);
            let room = discs
                .iter()
                .map(|d| (d.x - x).hypot(d.z - z) / d.r.max(0.9 * radius(x)))
                .fold(f64::INFINITY, f64::min);
            assert!(room < 1.3, "room at ({x}, {z}): {room}");
        }
    }

    #[test]
    fn the_same_seed_gives_the_same_samples_and_another_does_not() {
        let run = |seed| {
            sample(
                [0.0, 0.0, 20.0, 20.0],
                1.0,
                1.0,
                seed,
                usize::MAX,
                |_| true,
                |_, _, _| Some((1.0, ())),
            )
            .unwrap()
        };
        let (a, b, c) = (run(1), run(1), run(2));
        assert_eq!(
            a.iter().map(|x| x.0).collect::<Vec<_>>(),
            b.iter().map(|x| x.0).collect::<Vec<_>>()
        );
        assert_ne!(
            a.iter().map(|x| x.0).collect::<Vec<_>>(),
            c.iter().map(|x| x.0).collect::<Vec<_>>()
        );
    }

    #[test]
    fn max_count_stops_early_and_huge_regions_are_refused() {
        let s = sample(
            [0.0, 0.0, 100.0, 100.0],
            1.0,
            1.0,
            1,
            50,
            |_| true,
            |_, _, _| Some((1.0, ())),
        )
        .unwrap();
        assert_eq!(s.len(), 50);
        let e = sample(
            [0.0, 0.0, 1e6, 1e6],
            0.1,
            0.1,
            1,
            10,
            |_| true,
            |_, _, _| Some((0.1, ())),
        )
        .unwrap_err();
        assert!(matches!(e, PoissonError::TooLarge { .. }));
    }
}
