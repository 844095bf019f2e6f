//! Trilinear lookups in a texture level, every channel from one set of weights, following
//! `formats/texel.md`: values at cell centres, clamp to edge inside the grid, empty outside.

use glam::Vec3;

use crate::volume::Level;

/// What one point of a texture holds, per part (`[wood, foliage]`).
#[derive(Clone, Copy, Debug, Default)]
pub struct Fetch {
    pub density: [f32; 2],
    pub gradient: [Vec3; 2],
    pub albedo: [Vec3; 2],
}

/// The eight cells and weights around `c` (cell units from the grid origin), or `None`
/// outside the grid.
#[inline]
fn corners(level: &Level, c: Vec3) -> Option<([usize; 8], [f32; 8])> {
    let d = level.dims;
    if c.x < 0.0
        || c.y < 0.0
        || c.z < 0.0
        || c.x > d[0] as f32
        || c.y > d[1] as f32
        || c.z > d[2] as f32
        || !c.is_finite()
    {
        return None;
    }
    let axis = |v: f32, n: usize| -> (usize, usize, f32) {
        let x = (v - 0.5).clamp(0.0, (n - 1) as f32);
        let i = (x as usize).min(n - 1);
        (i, (i + 1).min(n - 1), x - i as f32)
    };
    let (x0, x1, fx) = axis(c.x, d[0]);
    let (y0, y1, fy) = axis(c.y, d[1]);
    let (z0, z1, fz) = axis(c.z, d[2]);
    let (sx, sxy) = (d[0], d[0] * d[1]);
    let idx = [
        x0 + sx * y0 + sxy * z0,
        x1 + sx * y0 + sxy * z0,
        x0 + sx * y1 + sxy * z0,
        x1 + sx * y1 + sxy * z0,
        x0 + sx * y0 + sxy * z1,
        x1 + sx * y0 + sxy * z1,
        x0 + sx * y1 + sxy * z1,
        x1 + sx * y1 + sxy * z1,
    ];
    let (gx, gy, gz) = (1.0 - fx, 1.0 - fy, 1.0 - fz);
    let w = [
        gx * gy * gz,
        fx * gy * gz,
        gx * fy * gz,
        fx * fy * gz,
        gx * gy * fz,
        fx * gy * fz,
        gx * fy * fz,
        fx * fy * fz,
    ];
    Some((idx, w))
}

/// Densities only (for shadow rays).
#[inline]
pub fn density(level: &Level, c: Vec3) -> [f32; 2] {
    let Some((idx, w)) = corners(level, c) else {
        return [0.0; 2];
    };
    std::array::from_fn(|p| (0..8).map(|k| level.density[p][idx[k]] * w[k]).sum())
}

/// Every channel.
#[inline]
pub fn fetch(level: &Level, c: Vec3) -> Fetch {
    let Some((idx, w)) = corners(level, c) else {
        return Fetch::default();
    };
    let mut f = Fetch::default();
    for p in 0..2 {
        for k in 0..8 {
            let i = idx[k];
            f.density[p] += level.density[p][i] * w[k];
            f.gradient[p] += Vec3::from(level.gradient[p][i]) * w[k];
            f.albedo[p] += Vec3::from(level.albedo[p][i]) * w[k];
        }
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn matches_the_reference_interpolation() {
        let mut l = Level::empty([3, 2, 4], 0.5);
        for i in 0..l.cell_count() {
            l.density[0][i] = i as f32;
            l.density[1][i] = (i * i) as f32 * 0.1;
        }
        for p in [
            Vec3::new(0.2, 0.3, 0.1),
            Vec3::new(1.7, 1.2, 3.9),
            Vec3::new(2.5, 0.5, 2.0),
        ] {
            let d = density(&l, p);
            let r = [0, 1].map(|k| {
                l.interpolate(
                    &l.density[k],
                    DVec3::new(p.x as f64, p.y as f64, p.z as f64),
                )
            });
            assert!(
                (d[0] - r[0]).abs() < 1e-4 && (d[1] - r[1]).abs() < 1e-3,
                "{d:?} {r:?}"
            );
            assert_eq!(fetch(&l, p).density, d);
        }
        assert_eq!(density(&l, Vec3::new(-0.1, 1.0, 1.0)), [0.0; 2]);
    }
}
