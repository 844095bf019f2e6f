//! Filters on texture grids: the mip reduction and the albedo fill.

use super::sobel;
use crate::volume::Level;

/// The next mip level: 2 x 2 x 2 cells become one (grids of odd size grow by half a cell, the
/// missing children being empty). Density is the plain average, so the optical "mass" (density
/// x volume) is conserved; albedo is the density-weighted average of each part; gradients are
/// recomputed on the coarser density.
pub fn reduce(level: &Level) -> Level {
    let dims = level.dims.map(|d| d.div_ceil(2));
    let mut out = Level::empty(dims, level.cell * 2.0);
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let o = out.index(x, y, z);
                for part in 0..2 {
                    let (mut mass, mut weighted, mut plain, mut n) =
                        (0.0f64, [0.0f64; 3], [0.0f64; 3], 0);
                    for (dx, dy, dz) in (0..8).map(|c| (c & 1, (c >> 1) & 1, c >> 2)) {
                        let (cx, cy, cz) = (2 * x + dx, 2 * y + dy, 2 * z + dz);
                        if cx >= level.dims[0] || cy >= level.dims[1] || cz >= level.dims[2] {
                            continue;
                        }
                        let i = level.index(cx, cy, cz);
                        let d = level.density[part][i] as f64;
                        mass += d;
                        for c in 0..3 {
                            weighted[c] += d * level.albedo[part][i][c] as f64;
                            plain[c] += level.albedo[part][i][c] as f64;
                        }
                        n += 1;
                    }
                    out.density[part][o] = (mass / 8.0) as f32;
                    out.albedo[part][o] = if mass > 0.0 {
                        weighted.map(|c| (c / mass) as f32)
                    } else {
                        plain.map(|c| (c / n as f64) as f32)
                    };
                }
            }
        }
    }
    for part in 0..2 {
        out.gradient[part] = sobel::gradient(&out.density[part], dims, out.cell);
    }
    out
}

/// Fills cells without a known albedo from their known neighbours, one ring per pass, so that
/// interpolating albedo next to a surface does not blend towards black. Cells farther than
/// any known one stay as they are; with nothing known at all every cell is zero.
pub fn fill_unknown(albedo: &mut [[f32; 3]], known: &mut [bool], dims: [usize; 3]) {
    let [nx, ny, nz] = dims;
    loop {
        let mut filled = Vec::new();
        for z in 0..nz {
            for y in 0..ny {
                for x in 0..nx {
                    let i = x + nx * (y + ny * z);
                    if known[i] {
                        continue;
                    }
                    let (mut sum, mut n) = ([0.0f32; 3], 0);
                    for dz in z.saturating_sub(1)..(z + 2).min(nz) {
                        for dy in y.saturating_sub(1)..(y + 2).min(ny) {
                            for dx in x.saturating_sub(1)..(x + 2).min(nx) {
                                let j = dx + nx * (dy + ny * dz);
                                if known[j] {
                                    for c in 0..3 {
                                        sum[c] += albedo[j][c];
                                    }
                                    n += 1;
                                }
                            }
                        }
                    }
                    if n > 0 {
                        filled.push((i, sum.map(|s| s / n as f32)));
                    }
                }
            }
        }
        if filled.is_empty() {
            return;
        }
        for (i, a) in filled {
            albedo[i] = a;
            known[i] = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Stream;

    fn random_level(dims: [usize; 3], seed: u64) -> Level {
        let mut s = Stream::new(seed, 0);
        let mut level = Level::empty(dims, 0.5);
        for part in 0..2 {
            for i in 0..level.cell_count() {
                level.density[part][i] = if s.unit() < 0.3 {
                    0.0
                } else {
                    (s.unit() * 10.0) as f32
                };
                level.albedo[part][i] = [s.unit() as f32, s.unit() as f32, s.unit() as f32];
            }
        }
        level
    }

    /// The test: averaging conserves the mean (density x volume), on odd sizes too.
    #[test]
    fn mip_reduction_conserves_the_optical_mass() {
        for dims in [[8, 8, 8], [7, 5, 3], [1, 4, 9]] {
            let mut level = random_level(dims, 3);
            while level.cell_count() > 1 {
                let next = reduce(&level);
                for part in 0..2 {
                    let mass = |l: &Level| {
                        l.density[part].iter().map(|&d| d as f64).sum::<f64>() * l.cell.powi(3)
                    };
                    assert!(
                        (mass(&level) - mass(&next)).abs() <= 1e-5 * mass(&level),
                        "{dims:?}"
                    );
                }
                level = next;
            }
            assert_eq!(level.dims, [1, 1, 1]);
        }
    }

    #[test]
    fn reduced_albedo_is_the_density_weighted_mean() {
        let mut level = Level::empty([2, 1, 1], 1.0);
        level.density[0] = vec![3.0, 1.0];
        level.albedo[0] = vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let next = reduce(&level);
        assert_eq!(next.albedo[0][0], [0.75, 0.25, 0.0]);
    }

    #[test]
    fn unknown_albedo_is_filled_from_neighbours() {
        let dims = [4, 1, 1];
        let mut albedo = vec![[0.0; 3], [0.5, 0.5, 0.5], [0.0; 3], [0.0; 3]];
        let mut known = vec![false, true, false, false];
        fill_unknown(&mut albedo, &mut known, dims);
        assert!(known.iter().all(|&k| k));
        assert!(albedo.iter().all(|a| *a == [0.5, 0.5, 0.5]));
    }
}
