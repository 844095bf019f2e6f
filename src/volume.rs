//! A baked 3D texture in memory: a mip chain of grids of extinction, density gradient and
//! albedo, split into wood and foliage. This is what `.texel` files hold (see
//! `formats/texel.md`) and what the renderer samples.
//!
//! Values are cell averages located at cell centres; between centres they are interpolated
//! trilinearly, within half a cell of the grid's faces they are held constant (clamp to edge),
//! and outside the grid the texture is empty. With that convention the optical depth along any
//! axis-aligned line through cell centres is exactly the sum of `sigma x cell` over the cells.

use glam::{DVec3, Vec3};
use serde::Serialize;

use crate::provenance::SourceFile;

/// How the density channels relate to extinction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, bincode::Encode, bincode::Decode)]
pub enum DensityModel {
    /// The paper's: density is the solid occupancy of the cell (0..1), extinction is gamma x it.
    Occupancy,
    /// Density is extinction (1/m) calibrated so axis-aligned optical depths match the mesh.
    Transmittance,
}

impl DensityModel {
    pub fn name(self) -> &'static str {
        match self {
            DensityModel::Occupancy => "occupancy",
            DensityModel::Transmittance => "transmittance",
        }
    }
}

/// One level of the mip chain. Arrays are indexed `x + nx * (y + ny * z)`; the per-part pairs
/// are `[wood, foliage]`: foliage follows the season, wood does not.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    pub dims: [usize; 3],
    /// Edge of a cell, metres.
    pub cell: f64,
    /// Density per part (see [`DensityModel`]).
    pub density: [Vec<f32>; 2],
    /// Gradient of each part's density (density units per metre), by the 3D Sobel operator.
    pub gradient: [Vec<[f32; 3]>; 2],
    /// Linear albedo of each part's surfaces; filled in from neighbours where the part is absent.
    pub albedo: [Vec<[f32; 3]>; 2],
}

impl Level {
    pub fn empty(dims: [usize; 3], cell: f64) -> Level {
        let n = dims.iter().product();
        Level {
            dims,
            cell,
            density: [vec![0.0; n], vec![0.0; n]],
            gradient: [vec![[0.0; 3]; n], vec![[0.0; 3]; n]],
            albedo: [vec![[0.0; 3]; n], vec![[0.0; 3]; n]],
        }
    }

    pub fn cell_count(&self) -> usize {
        self.dims.iter().product()
    }

    pub fn index(&self, x: usize, y: usize, z: usize) -> usize {
        x + self.dims[0] * (y + self.dims[1] * z)
    }

    /// The eight cells around `c` (cell units from the grid origin, centres at i + 0.5) and
    /// their trilinear weights, clamped to the edge inside the grid; `None` outside it.
    #[inline]
    pub fn trilinear(&self, c: Vec3) -> Option<([usize; 8], [f32; 8])> {
        let d = self.dims;
        let outside = c.x < 0.0
            || c.y < 0.0
            || c.z < 0.0
            || c.x > d[0] as f32
            || c.y > d[1] as f32
            || c.z > d[2] as f32;
        if outside || !c.is_finite() {
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

    /// Trilinear interpolation of a per-cell field at `p` (cell units from the grid origin).
    pub fn interpolate(&self, data: &[f32], p: DVec3) -> f32 {
        self.trilinear(p.as_vec3())
            .map_or(0.0, |(idx, w)| (0..8).map(|k| data[idx[k]] * w[k]).sum())
    }
}

/// The parameters a bake was run with, recorded so a texture can be re-made or compared.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BakeParameters {
    /// Texture cells along the longest side of the model.
    pub resolution: u32,
    /// Fine cells along the longest side of the model.
    pub fine: u32,
    /// Case-insensitive regular expression on material names that marks foliage.
    pub foliage_pattern: String,
    /// gamma (1/m) given on the command line; `None` = fitted automatically (occupancy only).
    pub requested_gamma: Option<f64>,
    /// Case-insensitive regular expression on material names that marks wood whatever else
    /// says foliage (`--wood`); `None` where none was given (and in files before v1.1).
    pub wood_pattern: Option<String>,
}

/// Where a material of the model went: wood or foliage, and why.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MaterialPart {
    pub name: String,
    pub foliage: bool,
    pub reason: PartReason,
    /// Share of the material's surface its alpha (`MASK` or `BLEND`) removes.
    pub cut: f32,
    /// Triangles of the model drawn with it.
    pub triangles: u64,
}

/// Why a material is wood or foliage, in the order the rules are tried.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PartReason {
    /// Wood: its name matches the `--wood` pattern.
    WoodPattern,
    /// Foliage: its name matches the `--foliage` pattern.
    FoliagePattern,
    /// Foliage: its alpha removes part of its surface (leaf cards).
    AlphaCuts,
    /// Wood: nothing says foliage.
    Solid,
}

impl PartReason {
    pub fn describe(self) -> &'static str {
        match self {
            PartReason::WoodPattern => "name matches --wood",
            PartReason::FoliagePattern => "name matches --foliage",
            PartReason::AlphaCuts => "alpha cuts leaf shapes",
            PartReason::Solid => "solid",
        }
    }
}

/// Everything about a texture but its voxels.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TexelInfo {
    pub generator: String,
    /// Bounds of the model's triangles, model space, metres.
    pub model_min: [f64; 3],
    pub model_max: [f64; 3],
    /// Minimum corner of every level's grid, model space, metres.
    pub origin: [f64; 3],
    pub density_model: DensityModel,
    /// gamma: extinction (1/m) = gamma x density. 1 for the transmittance model.
    pub extinction_scale: f64,
    pub triangles: u64,
    pub foliage_triangles: u64,
    /// Fraction of the rays parallel to x, y and z, one per fine cell over the grid's face, that
    /// hit the mesh: the silhouette coverage the texture is calibrated to.
    pub mesh_coverage: [f64; 3],
    pub sources: Vec<SourceFile>,
    /// SHA-256 over the SHA-256 of every source, in order.
    #[serde(serialize_with = "crate::hex::hex32")]
    pub inputs_sha256: [u8; 32],
    pub parameters: BakeParameters,
    /// How each material of the model divided between wood and foliage (empty in files
    /// before v1.1).
    pub materials: Vec<MaterialPart>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Texel {
    pub info: TexelInfo,
    /// Finest first; each level halves the previous (rounding up) down to a single cell.
    pub levels: Vec<Level>,
}

impl Texel {
    pub fn origin(&self) -> DVec3 {
        DVec3::from(self.info.origin)
    }

    /// Extinction (1/m) of both parts at model-space point `p` on level `level`.
    pub fn extinction(&self, level: usize, p: DVec3) -> f32 {
        let l = &self.levels[level];
        let q = (p - self.origin()) / l.cell;
        let s = self.info.extinction_scale as f32;
        s * (l.interpolate(&l.density[0], q) + l.interpolate(&l.density[1], q))
    }
}
