//! Density gradients by the 3D Sobel operator: a central difference along each axis smoothed by
//! [1 2 1] x [1 2 1] across it. Outside the grid the density is zero, so gradients at the faces
//! point inwards, as they should for a model that fills its box.

/// Gradient of `density` (per metre) on a grid of `dims` cells of edge `cell`.
///
/// Where the density is constant the gradient is exactly zero; a normal is defined only where
/// the gradient is not (see `formats/texel.md`), so no division happens here.
pub fn gradient(density: &[f32], dims: [usize; 3], cell: f64) -> Vec<[f32; 3]> {
    let [nx, ny, nz] = dims.map(|d| d as isize);
    let at = |x: isize, y: isize, z: isize| -> f64 {
        if x < 0 || y < 0 || z < 0 || x >= nx || y >= ny || z >= nz {
            0.0
        } else {
            density[(x + nx * (y + ny * z)) as usize] as f64
        }
    };
    const W: [f64; 3] = [1.0, 2.0, 1.0];
    // A linear ramp of slope g gives sum = 16 * g * 2 cell on each axis.
    let scale = 1.0 / (32.0 * cell);
    let mut out = Vec::with_capacity(density.len());
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let mut g = [0.0f64; 3];
                for (a, b) in (-1..=1isize).zip(W) {
                    for (c, d) in (-1..=1isize).zip(W) {
                        let w = b * d;
                        g[0] += w * (at(x + 1, y + a, z + c) - at(x - 1, y + a, z + c));
                        g[1] += w * (at(x + c, y + 1, z + a) - at(x + c, y - 1, z + a));
                        g[2] += w * (at(x + a, y + c, z + 1) - at(x + a, y + c, z - 1));
                    }
                }
                out.push(g.map(|v| (v * scale) as f32));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::volume::normal;

    /// The test: Sobel normals of an analytic sphere density point outward.
    #[test]
    fn sobel_normals_of_a_sphere_point_outward_within_two_degrees() {
        let n = 32usize;
        let cell = 0.25;
        let centre = n as f64 * cell / 2.0;
        let radius = 2.5;
        // A smooth ball: density 1 inside, falling to 0 over two cells at the surface.
        let density: Vec<f32> = (0..n * n * n)
            .map(|i| {
                let p = [i % n, (i / n) % n, i / (n * n)].map(|c| (c as f64 + 0.5) * cell - centre);
                let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
                let s = ((radius - r) / (2.0 * cell)).clamp(-1.0, 1.0);
                (0.5 + 0.5 * (s * std::f64::consts::FRAC_PI_2).sin()) as f32
            })
            .collect();
        let g = gradient(&density, [n; 3], cell);
        let mut checked = 0;
        let mut worst = 0.0f64;
        for (i, g) in g.iter().enumerate() {
            let p = [i % n, (i / n) % n, i / (n * n)].map(|c| (c as f64 + 0.5) * cell - centre);
            let r = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            if (r - radius).abs() > 1.5 * cell {
                continue; // only the shell where the density changes
            }
            let nrm = normal(*g).expect("gradient in the shell");
            let cos = (nrm[0] as f64 * p[0] + nrm[1] as f64 * p[1] + nrm[2] as f64 * p[2]) / r;
            worst = worst.max(cos.clamp(-1.0, 1.0).acos().to_degrees());
            checked += 1;
        }
        assert!(checked > 500, "{checked}");
        assert!(worst < 2.0, "worst angle {worst} degrees");
    }

    #[test]
    fn uniform_density_has_zero_gradient_and_no_normal() {
        let g = gradient(&[1.0; 27], [3, 3, 3], 1.0);
        assert_eq!(g[13], [0.0; 3]); // the centre cell of a uniform block
        assert_eq!(normal(g[13]), None);
        assert_eq!(normal([0.0; 3]), None);
    }

    #[test]
    fn a_linear_ramp_has_its_slope() {
        let dims = [5, 4, 3];
        let d: Vec<f32> = (0..60).map(|i| (i % 5) as f32 * 0.5).collect(); // 0.5 per cell in x
        let g = gradient(&d, dims, 2.0);
        let interior = 2 + 5 * (1 + 4);
        assert!((g[interior][0] - 0.25).abs() < 1e-6 && g[interior][1].abs() < 1e-6);
    }
}
