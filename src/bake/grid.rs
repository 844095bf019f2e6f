//! The bake grid: cubic texture cells over the model's bounds, each split into `k`^3 fine cells.

use glam::DVec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    /// Minimum corner of the grid, model space, metres.
    pub origin: DVec3,
    /// Edge of a texture cell, metres.
    pub cell: f64,
    /// Texture cells per axis.
    pub dims: [usize; 3],
    /// Fine cells per texture cell edge.
    pub k: usize,
}

impl Grid {
    /// `resolution` texture cells along the longest side of `lo..hi`, as many cubic cells as
    /// needed on the others, centred on the bounds.
    pub fn fit(lo: DVec3, hi: DVec3, resolution: usize, k: usize) -> Grid {
        let extent = hi - lo;
        let cell = extent.max_element() / resolution as f64;
        // The small tolerance keeps an axis that is an exact multiple of the cell from gaining a
        // spurious extra cell through rounding.
        let dims = extent
            .to_array()
            .map(|e| ((e / cell) * (1.0 - 1e-9)).ceil().max(1.0) as usize);
        let size = DVec3::new(dims[0] as f64, dims[1] as f64, dims[2] as f64) * cell;
        Grid {
            origin: (lo + hi) * 0.5 - size * 0.5,
            cell,
            dims,
            k,
        }
    }

    pub fn fine_cell(&self) -> f64 {
        self.cell / self.k as f64
    }

    pub fn fine_dims(&self) -> [usize; 3] {
        self.dims.map(|d| d * self.k)
    }

    pub fn cell_count(&self) -> usize {
        self.dims.iter().product()
    }

    /// Linear index of texture cell (x, y, z), x fastest.
    pub fn index(&self, c: [usize; 3]) -> usize {
        c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])
    }

    pub fn max(&self) -> DVec3 {
        self.origin
            + DVec3::new(
                self.dims[0] as f64,
                self.dims[1] as f64,
                self.dims[2] as f64,
            ) * self.cell
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn longest_side_gets_the_resolution_and_the_grid_covers_the_bounds() {
        let (lo, hi) = (DVec3::new(-1.0, 0.0, -0.5), DVec3::new(1.0, 4.0, 0.5));
        let g = Grid::fit(lo, hi, 32, 8);
        assert_eq!(g.dims, [16, 32, 8]);
        assert!((g.cell - 0.125).abs() < 1e-12);
        assert!(g.origin.cmple(lo).all() && g.max().cmpge(hi).all());
        assert_eq!(g.fine_dims(), [128, 256, 64]);
    }

    #[test]
    fn a_thin_axis_gets_one_cell() {
        let g = Grid::fit(DVec3::ZERO, DVec3::new(10.0, 1e-3, 10.0), 16, 4);
        assert_eq!(g.dims, [16, 1, 16]);
    }
}
