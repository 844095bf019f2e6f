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

/// Densities only (for shadow rays).
#[inline]
pub fn density(level: &Level, c: Vec3) -> [f32; 2] {
    let Some((idx, w)) = level.trilinear(c) else {
        return [0.0; 2];
    };
    std::array::from_fn(|p| (0..8).map(|k| level.density[p][idx[k]] * w[k]).sum())
}

/// Every channel.
#[inline]
pub fn fetch(level: &Level, c: Vec3) -> Fetch {
    let Some((idx, w)) = level.trilinear(c) else {
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

    /// A field linear in x, y and z is reproduced exactly between cell centres, held at the
    /// edge value in the outer half cell, and empty outside; every channel agrees.
    #[test]
    fn a_linear_field_is_interpolated_exactly_and_clamped_at_the_edges() {
        let dims = [3, 2, 4];
        let mut l = Level::empty(dims, 0.5);
        let f = |x: f32, y: f32, z: f32| 1.0 + 2.0 * x - 0.5 * y + 0.25 * z;
        for i in 0..l.cell_count() {
            let (x, y, z) = (
                (i % 3) as f32 + 0.5,
                ((i / 3) % 2) as f32 + 0.5,
                (i / 6) as f32 + 0.5,
            );
            l.density[0][i] = f(x, y, z);
            l.density[1][i] = 2.0 * f(x, y, z);
            l.albedo[0][i] = [f(x, y, z); 3];
        }
        for p in [
            Vec3::new(0.7, 0.9, 1.1),
            Vec3::new(2.4, 1.5, 3.3),
            Vec3::new(1.5, 0.5, 2.0),
        ] {
            let d = density(&l, p);
            assert!((d[0] - f(p.x, p.y, p.z)).abs() < 1e-5, "{d:?} at {p}");
            assert!((d[1] - 2.0 * d[0]).abs() < 1e-5);
            let all = fetch(&l, p);
            assert_eq!(all.density, d);
            assert!((all.albedo[0].x - d[0]).abs() < 1e-5);
        }
        // The outer half cell holds the edge value: x = 0.2 reads as x = 0.5.
        assert!((density(&l, Vec3::new(0.2, 1.0, 2.0))[0] - f(0.5, 1.0, 2.0)).abs() < 1e-5);
        assert_eq!(density(&l, Vec3::new(-0.1, 1.0, 1.0)), [0.0; 2]);
        assert_eq!(density(&l, Vec3::new(1.0, 2.1, 1.0)), [0.0; 2]);
    }
}
