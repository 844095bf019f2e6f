//! A regular height raster over the ground plane (x east, z south), cell values at cell
//! centres; cells with no terrain beneath are NaN.

use rayon::prelude::*;

use super::Terrain;

#[derive(Clone, Debug, PartialEq)]
pub struct Heightfield {
    /// World x and z of the raster's minimum corner.
    pub x0: f64,
    pub z0: f64,
    pub cell: f64,
    pub nx: usize,
    pub nz: usize,
    /// Row-major, x fastest: `height[i + nx * j]` at (x0 + (i + 0.5) cell, z0 + (j + 0.5) cell).
    pub height: Vec<f32>,
}

impl Heightfield {
    /// Resamples the terrain over [x0, x1] x [z0, z1] with square cells of `cell` metres by
    /// casting a ray down through every cell centre: the highest surface wins.
    pub fn sample(terrain: &Terrain, x0: f64, z0: f64, x1: f64, z1: f64, cell: f64) -> Heightfield {
        let nx = (((x1 - x0) / cell).ceil() as usize).max(1);
        let nz = (((z1 - z0) / cell).ceil() as usize).max(1);
        let height = (0..nx * nz)
            .into_par_iter()
            .map(|k| {
                let (i, j) = (k % nx, k / nx);
                let x = x0 + (i as f64 + 0.5) * cell;
                let z = z0 + (j as f64 + 0.5) * cell;
                terrain.height_at(x, z).map_or(f32::NAN, |h| h as f32)
            })
            .collect();
        Heightfield {
            x0,
            z0,
            cell,
            nx,
            nz,
            height,
        }
    }

    pub fn at(&self, i: usize, j: usize) -> f32 {
        self.height[i + self.nx * j]
    }

    /// The four cells and weights of bilinear interpolation at world (x, z), clamped to the
    /// raster.
    pub fn bilinear(&self, x: f64, z: f64) -> ([usize; 4], [f32; 4]) {
        let fx = ((x - self.x0) / self.cell - 0.5).clamp(0.0, (self.nx - 1) as f64);
        let fz = ((z - self.z0) / self.cell - 0.5).clamp(0.0, (self.nz - 1) as f64);
        let (i, j) = (fx as usize, fz as usize);
        let (i1, j1) = ((i + 1).min(self.nx - 1), (j + 1).min(self.nz - 1));
        let (tx, tz) = ((fx - i as f64) as f32, (fz - j as f64) as f32);
        (
            [
                i + self.nx * j,
                i1 + self.nx * j,
                i + self.nx * j1,
                i1 + self.nx * j1,
            ],
            [
                (1.0 - tx) * (1.0 - tz),
                tx * (1.0 - tz),
                (1.0 - tx) * tz,
                tx * tz,
            ],
        )
    }

    /// Bilinear interpolation of a per-cell field at world (x, z), clamped to the raster;
    /// NaN cells poison the result (no terrain there).
    pub fn interpolate(&self, field: &[f32], x: f64, z: f64) -> f32 {
        let (cells, weights) = self.bilinear(x, z);
        (0..4).map(|k| field[cells[k]] * weights[k]).sum()
    }
}
