//! How well a texture predicts its mesh's silhouette: parallel rays from a direction are traced
//! against the mesh (hit or miss) and through the texture (transmittance exp(-optical depth)),
//! and the two coverages are compared per pixel of one texture cell and over the whole view.

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::geom::{Ray, box_corners};
use crate::mesh_tracer::MeshTracer;
use crate::rng;
use crate::volume::Texel;

#[derive(Clone, Copy, Debug, Serialize)]
pub struct SilhouetteError {
    pub direction: [f64; 3],
    /// Mean coverage over the view's rectangle: fraction of rays the mesh stops, and 1 - mean
    /// transmittance the texture predicts.
    pub coverage_mesh: f64,
    pub coverage_texture: f64,
    /// Root mean square of the per-pixel coverage difference, over pixels either one covers.
    pub pixel_rmse: f64,
    pub pixels: usize,
}

impl SilhouetteError {
    /// Relative error of the total coverage.
    pub fn coverage_error(&self) -> f64 {
        (self.coverage_texture - self.coverage_mesh) / self.coverage_mesh.max(1e-12)
    }
}

/// A region of model space the texture occupies (its grid box), for framing the view.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub lo: DVec3,
    pub hi: DVec3,
    /// Pixel size, metres (a texture cell).
    pub pixel: f64,
}

impl Frame {
    /// The grid box of a texture's finest level, with pixels of one cell.
    pub fn of(texel: &Texel) -> Frame {
        let l0 = &texel.levels[0];
        let lo = texel.origin();
        Frame {
            lo,
            hi: lo + DVec3::from(l0.dims.map(|d| d as f64)) * l0.cell,
            pixel: l0.cell,
        }
    }
}

/// Errors of many views, averaged.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ViewSummary {
    /// Mean relative coverage error (positive: the texture covers more than the mesh).
    pub bias: f64,
    /// Mean absolute relative coverage error.
    pub abs_bias: f64,
    /// Mean per-pixel coverage RMSE.
    pub rmse: f64,
}

/// [`compare`] over every direction in `dirs`, averaged.
pub fn over_views(
    tracer: &MeshTracer,
    frame: Frame,
    dirs: &[DVec3],
    rays: usize,
    extinction: &(dyn Fn(DVec3, DVec3) -> f64 + Sync),
) -> ViewSummary {
    let n = dirs.len() as f64;
    let errors: Vec<SilhouetteError> = dirs
        .iter()
        .map(|d| compare(tracer, frame, *d, rays, extinction))
        .collect();
    ViewSummary {
        bias: errors.iter().map(|e| e.coverage_error()).sum::<f64>() / n,
        abs_bias: errors.iter().map(|e| e.coverage_error().abs()).sum::<f64>() / n,
        rmse: errors.iter().map(|e| e.pixel_rmse).sum::<f64>() / n,
    }
}

/// Compares along `dir` with `rays` x `rays` jittered rays per pixel. `extinction(p, dir)`
/// is the texture's extinction (1/m) at model-space `p` for light going along `dir`.
pub fn compare(
    tracer: &MeshTracer,
    frame: Frame,
    dir: DVec3,
    rays: usize,
    extinction: &(dyn Fn(DVec3, DVec3) -> f64 + Sync),
) -> SilhouetteError {
    let d = dir.normalize();
    let helper = if d.y.abs() < 0.9 { DVec3::Y } else { DVec3::X };
    let e1 = d.cross(helper).normalize();
    let e2 = d.cross(e1);
    let corners = box_corners(frame.lo.to_array(), frame.hi.to_array()).map(DVec3::from);
    let centre = (frame.lo + frame.hi) * 0.5;
    let radius = (frame.hi - frame.lo).length() * 0.5;
    let span = |e: DVec3| {
        corners
            .iter()
            .map(|c| (*c - centre).dot(e))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                (a.min(x), b.max(x))
            })
    };
    let (a0, a1) = span(e1);
    let (b0, b1) = span(e2);
    let (na, nb) = (
        ((a1 - a0) / frame.pixel).ceil() as usize,
        ((b1 - b0) / frame.pixel).ceil() as usize,
    );
    let step = frame.pixel / 4.0;

    let per_pixel: Vec<(f64, f64)> = (0..na * nb)
        .into_par_iter()
        .map(|p| {
            let (pa, pb) = (p % na, p / na);
            let (mut hits, mut transmitted) = (0usize, 0.0f64);
            for s in 0..rays * rays {
                let key = rng::hash3(p as u64, s as u64, rng::purpose::SILHOUETTE_PIXEL);
                let ja = (s % rays) as f64 + rng::unit(key);
                let jb = (s / rays) as f64 + rng::unit(rng::mix64(key));
                let a = a0 + (pa as f64 + ja / rays as f64) * frame.pixel;
                let b = b0 + (pb as f64 + jb / rays as f64) * frame.pixel;
                let origin = centre + e1 * a + e2 * b - d * (radius + 1.0);
                let ray = Ray {
                    origin: origin.as_vec3(),
                    dir: d.as_vec3(),
                };
                if tracer.occluded(&ray, 0.0, f32::INFINITY, key) {
                    hits += 1;
                }
                // Midpoint rule through the texture, with a jittered start.
                let (mut t, mut tau) = (rng::unit(rng::mix64(key ^ 1)) * step, 0.0);
                while t < 2.0 * (radius + 1.0) {
                    tau += extinction(origin + d * t, d) * step;
                    t += step;
                }
                transmitted += (-tau).exp();
            }
            let n = (rays * rays) as f64;
            (hits as f64 / n, 1.0 - transmitted / n)
        })
        .collect();
    summarize(d, &per_pixel)
}

/// `n` directions spread uniformly over the sphere, the same for every caller.
pub fn random_directions(n: usize, seed: u64) -> Vec<DVec3> {
    let mut s = rng::Stream::new(seed, rng::purpose::SILHOUETTE_DIRECTION);
    (0..n)
        .map(|_| {
            let z = s.range(-1.0, 1.0);
            let phi = s.range(0.0, std::f64::consts::TAU);
            let r = (1.0 - z * z).sqrt();
            DVec3::new(r * phi.cos(), z, r * phi.sin())
        })
        .collect()
}

/// Per-column check along a grid axis: each level-0 column's optical depth (the sum of
/// extinction x cell along it, which is what a ray through the column's centre integrates)
/// predicts the fraction of rays through the column's footprint that miss the mesh. The mesh
/// is traced independently of the bake, `rays` x `rays` jittered rays per column.
pub fn axis_columns(
    tracer: &MeshTracer,
    texel: &Texel,
    axis: usize,
    rays: usize,
) -> SilhouetteError {
    let l = &texel.levels[0];
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let depths = texel.column_depths(0, axis);
    let origin = texel.origin();
    let per_column: Vec<(f64, f64)> = (0..depths.len())
        .into_par_iter()
        .map(|c| {
            let (cu, cv) = (c % l.dims[u], c / l.dims[u]);
            let mut hits = 0;
            for s in 0..rays * rays {
                let key = rng::hash3(
                    c as u64,
                    s as u64,
                    rng::purpose::SILHOUETTE_AXIS + axis as u64,
                );
                let mut o = origin;
                o[u] += (cu as f64 + ((s % rays) as f64 + rng::unit(key)) / rays as f64) * l.cell;
                o[v] += (cv as f64
                    + ((s / rays) as f64 + rng::unit(rng::mix64(key))) / rays as f64)
                    * l.cell;
                o[axis] -= 1.0;
                let mut dir = DVec3::ZERO;
                dir[axis] = 1.0;
                let ray = Ray {
                    origin: o.as_vec3(),
                    dir: dir.as_vec3(),
                };
                hits += tracer.occluded(&ray, 0.0, f32::INFINITY, key) as usize;
            }
            (hits as f64 / (rays * rays) as f64, 1.0 - (-depths[c]).exp())
        })
        .collect();
    summarize(
        DVec3::from(std::array::from_fn(|i| (i == axis) as u8 as f64)),
        &per_column,
    )
}

fn summarize(d: DVec3, per_pixel: &[(f64, f64)]) -> SilhouetteError {
    let n = per_pixel.len() as f64;
    let covered: Vec<f64> = per_pixel
        .iter()
        .filter(|p| p.0 > 0.0 || p.1 > 1e-3)
        .map(|p| (p.1 - p.0).powi(2))
        .collect();
    SilhouetteError {
        direction: d.to_array(),
        coverage_mesh: per_pixel.iter().map(|p| p.0).sum::<f64>() / n,
        coverage_texture: per_pixel.iter().map(|p| p.1).sum::<f64>() / n,
        pixel_rmse: (covered.iter().sum::<f64>() / covered.len().max(1) as f64).sqrt(),
        pixels: covered.len(),
    }
}
