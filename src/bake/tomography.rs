//! Makes an isotropic extinction field agree with the three axis views it was measured from.
//!
//! Each axis's rays measured, per texture column, the fraction of rays that cross it: a target
//! optical depth. Averaging the three per-axis estimates per cell (the starting point) mixes
//! them, so no view's columns sum to their target any more. Simultaneous multiplicative
//! reconstruction (as in tomography) then rescales every cell by the geometric mean of what
//! its three columns ask for, for a few sweeps: the field stays non-negative, empty cells stay
//! empty, and no axis is favoured over another.
//!
//! A column none of whose rays was blocked (target depth 0) has no say. Its cells hold what the other
//! views saw, and an isotropic volume cannot both show that and hide it along this axis:
//! flat cards seen edge-on, as in a crossed-quad billboard, or a leaf between this axis's
//! rays. Its vote, the logarithm of zero, would empty those cells, and with them the views
//! that do see the cards (a billboard baked to an empty texture). Kept, they add a line of
//! cells to this axis's view where the mesh shows none; on the fixtures and the shared real
//! trees each axis's coverage moves towards the mesh's, never away.

use super::grid::Grid;

/// Column optical depths measured along one axis: `[column]`, columns indexed as in the scan.
pub struct Targets {
    pub depth: Vec<f64>,
    /// Columns no ray crossed: their depth is a lower bound, not a value.
    pub opaque: Vec<bool>,
}

/// Sweeps of the fit: the views agree to about 1% after ten on the fixtures; more change little.
const SWEEPS: usize = 10;

pub fn fit(grid: &Grid, sigma: &mut [f32], targets: &[Targets; 3]) {
    let [nx, ny, nz] = grid.dims;
    let mut log_ratio = vec![0.0f64; sigma.len()];
    for _ in 0..SWEEPS {
        log_ratio.iter_mut().for_each(|r| *r = 0.0);
        for (axis, target) in targets.iter().enumerate() {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let mut depth = vec![0.0f64; grid.dims[u] * grid.dims[v]];
            let column = |c: [usize; 3]| c[u] + grid.dims[u] * c[v];
            for z in 0..nz {
                for y in 0..ny {
                    for x in 0..nx {
                        depth[column([x, y, z])] += sigma[x + nx * (y + ny * z)] as f64 * grid.cell;
                    }
                }
            }
            for z in 0..nz {
                for y in 0..ny {
                    for x in 0..nx {
                        let col = column([x, y, z]);
                        let (have, want) = (depth[col], target.depth[col]);
                        if have <= 0.0 || want <= 0.0 || (target.opaque[col] && have >= want) {
                            continue;
                        }
                        log_ratio[x + nx * (y + ny * z)] += (want / have).ln() / 3.0;
                    }
                }
            }
        }
        for (s, r) in sigma.iter_mut().zip(&log_ratio) {
            *s = (*s as f64 * r.exp()) as f32;
        }
    }
}
