//! Terrain: a triangulated glTF surface, resampled into a height raster whose attributes
//! (slope, aspect, topographic position, wetness) decide where which tree grows.

mod attributes;
pub mod heightmap;
mod raster;
pub mod survey;

pub use attributes::{Attributes, TERRAIN_ATTRIBUTES, hillshade};
pub use heightmap::{HeightmapError, HeightmapOptions};
pub use raster::Heightfield;

use std::path::Path;

use glam::{DVec3, Vec3};

use crate::geom::{Ray, TriangleBvh};
use crate::import::{self, ImportError, Model};
use crate::limits::Limits;

/// A terrain surface with exact height queries.
pub struct Terrain {
    pub model: Model,
    triangles: TriangleBvh,
    /// Bounds of the surface, metres.
    pub lo: DVec3,
    pub hi: DVec3,
    /// How a heightmap was turned into the mesh; `None` for a glTF terrain.
    pub heightmap: Option<HeightmapOptions>,
}

#[derive(Debug, thiserror::Error)]
pub enum TerrainError {
    #[error(transparent)]
    Import(#[from] ImportError),
    #[error(transparent)]
    Heightmap(#[from] HeightmapError),
    #[error("{0}")]
    Invalid(String),
}

impl Terrain {
    /// A glTF terrain, or a heightmap whose size and heights the image says (a GeoTIFF).
    pub fn load(path: &Path, limits: &Limits) -> Result<Terrain, TerrainError> {
        Terrain::load_with(path, &HeightmapOptions::default(), limits)
    }

    /// A glTF terrain, or a heightmap converted with `options`.
    pub fn load_with(
        path: &Path,
        options: &HeightmapOptions,
        limits: &Limits,
    ) -> Result<Terrain, TerrainError> {
        let (model, heightmap) = load_model(path, options, "to place trees on", limits)?;
        let terrain = Terrain::from_model(model);
        // A wall, a line or a point: no raster cell of ground to judge or stand a tree on.
        let (lo, hi) = (terrain.lo, terrain.hi);
        if !(hi.x - lo.x > 0.0 && hi.z - lo.z > 0.0) {
            return Err(TerrainError::Invalid(format!(
                "{}: the terrain covers no ground seen from above (x {} to {}, z {} to {} m); \
                 trees need ground that spans both x and z (+Y is up)",
                path.display(),
                lo.x,
                hi.x,
                lo.z,
                hi.z
            )));
        }
        Ok(Terrain {
            heightmap,
            ..terrain
        })
    }

    pub fn from_model(model: Model) -> Terrain {
        let mesh = &model.mesh;
        let corners = mesh.corners();
        let triangles = TriangleBvh::new(corners);
        let b = triangles.bounds();
        Terrain {
            model,
            triangles,
            lo: b.lo.as_dvec3(),
            hi: b.hi.as_dvec3(),
            heightmap: None,
        }
    }

    /// Height of the highest surface above (x, z), if any: a ray cast straight down.
    pub fn height_at(&self, x: f64, z: f64) -> Option<f64> {
        if x < self.lo.x || x > self.hi.x || z < self.lo.z || z > self.hi.z {
            return None;
        }
        let top = self.hi.y + 1.0;
        let ray = Ray {
            origin: Vec3::new(x as f32, top as f32, z as f32),
            dir: Vec3::NEG_Y,
        };
        let (_, hit) = self
            .triangles
            .nearest(&ray, 0.0, f32::INFINITY, |_, _| true)?;
        Some(top - hit.t as f64)
    }

    /// The highest point of `mesh`'s surface above (x, z), if any: one query without building
    /// a hierarchy (the renderer's check of where the eye is), a pass over the triangles.
    pub fn surface_height(mesh: &crate::import::Mesh, x: f64, z: f64) -> Option<f64> {
        let mut best: Option<f64> = None;
        for t in &mesh.triangles {
            let [a, b, c] = t.vertices.map(|v| mesh.positions[v as usize].as_dvec3());
            // Barycentric coordinates of (x, z) in the triangle's shadow on the ground.
            let det = (b.x - a.x) * (c.z - a.z) - (c.x - a.x) * (b.z - a.z);
            if det == 0.0 || !det.is_finite() {
                continue;
            }
            let u = ((x - a.x) * (c.z - a.z) - (c.x - a.x) * (z - a.z)) / det;
            let v = ((b.x - a.x) * (z - a.z) - (x - a.x) * (b.z - a.z)) / det;
            if u < 0.0 || v < 0.0 || u + v > 1.0 {
                continue;
            }
            let y = a.y + u * (b.y - a.y) + v * (c.y - a.y);
            best = Some(best.map_or(y, |h| h.max(y)));
        }
        best
    }

    /// The cell size matching the mesh's own resolution: the side of a square cell that a
    /// regular grid of the same number of triangles over the same ground would have.
    pub fn natural_cell(&self) -> f64 {
        let area = (self.hi.x - self.lo.x) * (self.hi.z - self.lo.z);
        (area / (self.triangles.len().max(1) as f64 / 2.0)).sqrt()
    }
}

/// The terrain surface at `path`: a heightmap image (by its first bytes or its name)
/// triangulated with `options`, with the options as recorded, or a glTF (`purpose` completes
/// "there is nothing ..." when it holds no triangles), for which `options` must be empty.
pub fn load_model(
    path: &Path,
    options: &HeightmapOptions,
    purpose: &str,
    limits: &Limits,
) -> Result<(Model, Option<HeightmapOptions>), TerrainError> {
    let (model, heightmap) = if let Some(format) = heightmap::Format::of_file(path) {
        let model = heightmap::load(path, format, options, limits)?;
        (model, Some(*options))
    } else {
        if !options.is_empty() {
            return Err(TerrainError::Invalid(format!(
                "{}: --terrain-size and --height-range convert heightmap images (PNG, EXR, \
                 TIFF, .r16); this is a glTF terrain, already in metres",
                path.display()
            )));
        }
        (import::load_surface(path, purpose, limits)?, None)
    };
    check_reach(path, &model)?;
    Ok((model, heightmap))
}

/// How far from its origin a terrain may reach, in metres: a million kilometres, far beyond
/// any terrain, and well inside what rays in f32 can meet (a triangle test multiplies three
/// lengths; 1e27 is far below f32's 3e38).
const MAX_REACH: f32 = 1e9;

/// Refuses a terrain that reaches beyond [`MAX_REACH`]: valid in its file, it would overflow
/// the f32 arithmetic of placement and rendering, which then found no ground at all.
fn check_reach(path: &Path, model: &Model) -> Result<(), TerrainError> {
    let reach = |p: &Vec3| p.abs().max_element();
    let Some(far) = model
        .mesh
        .positions
        .iter()
        .max_by(|a, b| reach(a).total_cmp(&reach(b)))
    else {
        return Ok(());
    };
    if reach(far) > MAX_REACH {
        // Huge coordinates in exponent form, not as forty digits.
        let at = far.to_array().map(|v| {
            if v.abs() < 1e6 {
                format!("{v}")
            } else {
                format!("{v:e}")
            }
        });
        return Err(TerrainError::Invalid(format!(
            "{}: the terrain reaches {:e} m from its origin (a vertex at ({}) m), beyond the \
             {MAX_REACH:e} m texel's arithmetic holds; export it in metres about the origin",
            path.display(),
            reach(far),
            at.join(", ")
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use crate::import::{Material, Mesh};

    /// A ridge of two sloping triangles: the surface's height where the point's shadow falls
    /// in either, the higher where they overlap, none off the mesh.
    #[test]
    fn surface_height_is_the_highest_triangle_above_the_point() {
        let positions = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(10.0, 10.0, 0.0),
            Vec3::new(0.0, 0.0, 10.0),
            Vec3::new(10.0, 20.0, 10.0),
        ];
        let mesh = Mesh::plain(positions, &[[0, 1, 2], [1, 3, 2]], Material::default());
        let h = |x, z| super::Terrain::surface_height(&mesh, x, z);
        assert!((h(2.0, 2.0).unwrap() - 2.0).abs() < 1e-9);
        assert!((h(8.0, 8.0).unwrap() - 14.0).abs() < 1e-9);
        assert_eq!(h(-1.0, 5.0), None);
        assert_eq!(h(5.0, 11.0), None);
    }
}
