//! Filters on texture grids: the mip reduction and the albedo fill.

use super::sobel;
use crate::volume::Level;

/// The next mip level: 2 x 2 x 2 cells become one (grids of odd size grow by half a cell, the
/// missing children being empty). Each part's density is the one whose coarse cell lets
/// through, along each axis, the mean of what its four columns of two children let through,
/// averaged over the three axes (`extinction_scale` turns density into extinction). A plain
/// average would conserve optical mass but make distant trees too opaque: the mean of
/// exp(-x) is more than exp of the mean. Albedo is the density-weighted average of each part
/// (weighted by the part's solid instead where a child has solid: an opaque surface is what
/// shows), each part's normal moment the average weighted by its density, the solids' inside
/// fractions the plain mean of the eight (a box filter);
/// gradients are recomputed on the coarser density.
pub fn reduce(level: &Level, extinction_scale: f64) -> Level {
    let dims = level.dims.map(|d| d.div_ceil(2));
    let mut out = Level::empty(dims, level.cell * 2.0);
    if level.has_solid() {
        out.solid = [0, 1].map(|_| vec![0.0; out.cell_count()]);
    }
    if !level.wood_normals.is_empty() {
        out.wood_normals = vec![crate::volume::ISOTROPIC_LEAVES; out.cell_count()];
    }
    for z in 0..dims[2] {
        for y in 0..dims[1] {
            for x in 0..dims[0] {
                let o = out.index(x, y, z);
                for part in 0..2 {
                    let (mut mass, mut weighted, mut plain, mut n) =
                        (0.0f64, [0.0f64; 3], [0.0f64; 3], 0);
                    let (mut solid, mut on_solid) = (0.0f64, [0.0f64; 3]);
                    let mut children = [0.0f64; 8];
                    for (k, (dx, dy, dz)) in (0..8).map(|c| (c, (c & 1, (c >> 1) & 1, c >> 2))) {
                        let (cx, cy, cz) = (2 * x + dx, 2 * y + dy, 2 * z + dz);
                        if cx >= level.dims[0] || cy >= level.dims[1] || cz >= level.dims[2] {
                            continue;
                        }
                        let i = level.index(cx, cy, cz);
                        let d = level.density[part][i] as f64;
                        children[k] = d;
                        mass += d;
                        let s = if level.has_solid() {
                            f64::from(level.solid[part][i])
                        } else {
                            0.0
                        };
                        solid += s;
                        for c in 0..3 {
                            weighted[c] += d * level.albedo[part][i][c] as f64;
                            on_solid[c] += s * level.albedo[part][i][c] as f64;
                            plain[c] += level.albedo[part][i][c] as f64;
                        }
                        n += 1;
                    }
                    if level.has_solid() {
                        out.solid[part][o] = (solid / 8.0) as f32;
                    }
                    out.density[part][o] =
                        transmitted_density(&children, level.cell * extinction_scale) as f32;
                    out.albedo[part][o] = if solid > 0.0 {
                        on_solid.map(|c| (c / solid) as f32)
                    } else if mass > 0.0 {
                        weighted.map(|c| (c / mass) as f32)
                    } else {
                        plain.map(|c| (c / n as f64) as f32)
                    };
                }
                out.leaves[o] = reduced_moment(level, &level.leaves, 1, [x, y, z]);
                if !level.wood_normals.is_empty() {
                    out.wood_normals[o] = reduced_moment(level, &level.wood_normals, 0, [x, y, z]);
                }
            }
        }
    }
    for part in 0..2 {
        out.gradient[part] = sobel::gradient(&out.density[part], dims, out.cell);
    }
    out
}

/// A part's normal moment (`moments`, of `part`) in the coarse cell `[x, y, z]`: its
/// children's, weighted by their density of the part (the area they stand for); the plain
/// mean where none has any.
fn reduced_moment(
    level: &Level,
    moments: &[[f32; 6]],
    part: usize,
    [x, y, z]: [usize; 3],
) -> [f32; 6] {
    let (mut weighted, mut plain, mut mass, mut n) = ([0.0f64; 6], [0.0f64; 6], 0.0f64, 0);
    for c in 0..8 {
        let (cx, cy, cz) = (2 * x + (c & 1), 2 * y + ((c >> 1) & 1), 2 * z + (c >> 2));
        if cx >= level.dims[0] || cy >= level.dims[1] || cz >= level.dims[2] {
            continue;
        }
        let i = level.index(cx, cy, cz);
        let d = f64::from(level.density[part][i]);
        for (k, m) in moments[i].iter().enumerate() {
            weighted[k] += d * f64::from(*m);
            plain[k] += f64::from(*m);
        }
        mass += d;
        n += 1;
    }
    crate::volume::unit_moment(if mass > 0.0 {
        weighted.map(|v| (v / mass) as f32)
    } else {
        plain.map(|v| (v / n.max(1) as f64) as f32)
    })
}

/// The density of a cell of twice the size whose transmittance along each axis is the mean of
/// its four columns' (two children each), averaged over the axes. `children[k]` is child
/// (k & 1, k >> 1 & 1, k >> 2); `optical` turns a density into the optical depth of one child.
fn transmitted_density(children: &[f64; 8], optical: f64) -> f64 {
    let mean = children.iter().sum::<f64>() / 8.0;
    if mean <= 0.0 || optical <= 0.0 || !optical.is_finite() {
        return mean.max(0.0);
    }
    let mut per_axis = 0.0;
    for axis in 0..3 {
        let bit = 1 << axis;
        // Optical depth of each column of two children along `axis`.
        let mut depths = [0.0f64; 4];
        for (d, k) in depths.iter_mut().zip((0..8).filter(|k| k & bit == 0)) {
            *d = (children[k] + children[k | bit]) * optical;
        }
        // -ln(mean exp(-depth)), kept finite for very dense columns.
        let least = depths.iter().copied().fold(f64::INFINITY, f64::min);
        let rest = depths.iter().map(|d| (least - d).exp()).sum::<f64>() / 4.0;
        per_axis += least - rest.ln();
    }
    // Depth across the coarse cell (two children) back to a density.
    per_axis / 3.0 / (2.0 * optical)
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

    /// Along each axis a coarse cell lets through what its columns let through on average
    /// (here a field layered in y, where the x and z columns differ and the y columns agree);
    /// a uniform field is unchanged; the chain ends in one cell, on odd sizes too.
    #[test]
    fn mip_reduction_keeps_the_mean_transmittance_of_the_columns() {
        let mut level = Level::empty([2, 2, 2], 0.5);
        let (a, b) = (0.4f64, 3.0f64);
        for i in 0..8 {
            level.density[0][i] = if (i >> 1) & 1 == 0 {
                a as f32
            } else {
                b as f32
            };
        }
        let scale = 2.0;
        let next = reduce(&level, scale);
        let c = 0.5 * scale;
        // x and z columns stay in one layer; y columns cross both.
        let layered = -(((-2.0 * a * c).exp() + (-2.0 * b * c).exp()) / 2.0).ln();
        let across = (a + b) * c;
        let want = (2.0 * layered + across) / 3.0 / (2.0 * c);
        assert!(
            (next.density[0][0] as f64 - want).abs() < 1e-6,
            "{:?} vs {want}",
            next.density
        );
        assert!(
            (next.density[0][0] as f64) < (a + b) / 2.0,
            "less opaque than the mean"
        );
        let mut uniform = Level::empty([4, 4, 4], 0.25);
        uniform.density[1] = vec![5.0; 64];
        assert!(
            reduce(&uniform, 1.0).density[1]
                .iter()
                .all(|&d| (d - 5.0).abs() < 1e-5)
        );
        // Without an extinction scale, the plain average.
        assert!((reduce(&level, 0.0).density[0][0] as f64 - (a + b) / 2.0).abs() < 1e-6);
        for dims in [[8, 8, 8], [7, 5, 3], [1, 4, 9]] {
            let mut level = random_level(dims, 3);
            while level.cell_count() > 1 {
                level = reduce(&level, 1.0);
                assert!(
                    level
                        .density
                        .iter()
                        .flatten()
                        .all(|d| d.is_finite() && *d >= 0.0)
                );
            }
            assert_eq!(level.dims, [1, 1, 1]);
        }
        // Columns far too dense for exp() still give a finite, sensible density.
        let mut dense = Level::empty([2, 2, 2], 1.0);
        dense.density[0] = vec![1e6; 8];
        assert!((reduce(&dense, 1.0).density[0][0] - 1e6).abs() < 1.0);
    }

    #[test]
    fn reduced_albedo_is_the_density_weighted_mean() {
        let mut level = Level::empty([2, 1, 1], 1.0);
        level.density[0] = vec![3.0, 1.0];
        level.albedo[0] = vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let next = reduce(&level, 1.0);
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
