//! `bake`: a polygon tree becomes a 3D texture (the paper's section 2).
//!
//! The passes, in order: fit the grid over the model, classify triangles (foliage or wood, open
//! or closed, thick closed parts apart), scan along the three axes, turn what the rays saw into
//! density and albedo per texture cell, fit level 0's density ray by ray to the mesh along 13
//! directions (`bake::refine`), take Sobel gradients, and build the mip chain; where the
//! model has thick closed parts, again with those parts as solids over the density of the rest
//! (`bake::solid`), kept on the levels that hold their shape; then fit each level's
//! directional form, self-shadowing and wood weight to the mesh.

mod calibrate;
mod classify;
mod filter;
mod grid;
mod refine;
mod scan;
mod seen;
pub mod sobel;
mod solid;
mod tomography;

use rayon::prelude::*;
use regex::Regex;

use std::path::Path;

use crate::import::{Mesh, Model};
use crate::number::number;
use crate::provenance;
use crate::volume::{
    BakeParameters, DensityModel, ISOTROPIC_LEAVES, Level, Texel, TexelInfo, unit_moment,
};
pub use classify::MIN_CUT;
pub use grid::Grid;
use scan::{AxisScan, ScanModel};

/// The material names that mark foliage unless `--foliage` says otherwise.
pub const DEFAULT_FOLIAGE: &str = "leaf|leaves|foliage|needle|crown";

#[derive(Clone, Debug)]
pub struct BakeSettings {
    /// Texture cells along the model's longest side.
    pub resolution: usize,
    /// Fine cells along the model's longest side; a multiple of `resolution`.
    pub fine: usize,
    pub density: DensityModel,
    /// Extinction per unit occupancy (1/m) for the occupancy model; `None` fits it.
    pub gamma: Option<f64>,
    /// Case-insensitive pattern on material names marking foliage.
    pub foliage: String,
    /// Case-insensitive pattern on material names marking wood, before anything else.
    pub wood: Option<String>,
}

impl Default for BakeSettings {
    fn default() -> Self {
        BakeSettings {
            resolution: 32,
            fine: 256,
            density: DensityModel::Transmittance,
            gamma: None,
            foliage: DEFAULT_FOLIAGE.to_string(),
            wood: None,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum BakeError {
    /// A flag or setting is out of range.
    #[error("{0}")]
    Settings(String),
    /// The model cannot be baked as it is.
    #[error("{0}")]
    Model(String),
    #[error("the model is flat: it has no extent along {axis} (a 3D texture needs all three)")]
    Flat { axis: char },
}

impl BakeSettings {
    /// Checks the settings on their own, before any model is read.
    pub fn validate(&self) -> Result<(), BakeError> {
        let (res, fine) = (self.resolution, self.fine);
        if !(1..=MAX_RESOLUTION).contains(&res) {
            return Err(BakeError::Settings(format!(
                "--resolution {res} must be between 1 and {MAX_RESOLUTION}"
            )));
        }
        if fine < res || fine % res != 0 || fine > MAX_FINE {
            return Err(BakeError::Settings(format!(
                "--fine {fine} must be a multiple of --resolution {res} and at most {MAX_FINE}"
            )));
        }
        if let Some(g) = self.gamma
            && !(g.is_finite() && g > 0.0)
        {
            return Err(BakeError::Settings(format!(
                "--gamma {g} must be a positive number of 1/m"
            )));
        }
        self.patterns().map(|_| ())
    }

    /// The foliage and wood patterns, compiled.
    fn patterns(&self) -> Result<(Regex, Option<Regex>), BakeError> {
        Ok((
            pattern("--foliage", &self.foliage)?,
            self.wood
                .as_deref()
                .map(|w| pattern("--wood", w))
                .transpose()?,
        ))
    }
}

/// A case-insensitive regular expression on material names, from flag `flag`.
fn pattern(flag: &str, text: &str) -> Result<Regex, BakeError> {
    Regex::new(&format!("(?i){text}")).map_err(|e| {
        // The regex crate explains over several lines; keep its last, the diagnosis.
        let why = e
            .to_string()
            .lines()
            .last()
            .unwrap_or_default()
            .trim_start_matches("error: ")
            .to_string();
        BakeError::Settings(format!(
            "{flag} {text:?} is not a valid regular expression: {why}"
        ))
    })
}

/// Largest texture and fine resolutions accepted: 256^3 cells is 700 MiB of voxels already.
pub const MAX_RESOLUTION: usize = 256;
pub const MAX_FINE: usize = 4096;
/// Most fine cells the occupancy model bakes: its vote keeps three bytes a fine cell (one
/// per axis's scan), 3 GiB here, where `--fine 4096` on a cubic grid would take 200 GB.
const MAX_OCCUPANCY_FINE_CELLS: usize = 1 << 30;
/// Smallest model accepted, metres: below it, extinctions of opaque cells overflow `f32`
/// (and no tree is a tenth of a millimetre tall).
const MIN_MODEL_SIZE: f64 = 1e-4;

/// Bakes an imported model into a texture that records what it was made from: every file the
/// import read, by path relative to `output_dir` (the directory the `.texel` is written to)
/// and SHA-256, and the hash of those hashes (`inputs_sha256`), as `formats/texel.md` asks.
pub fn bake_model(
    model: &Model,
    settings: &BakeSettings,
    output_dir: &Path,
) -> Result<Texel, BakeError> {
    let mut texel = bake(&model.mesh, settings)?;
    (texel.info.sources, texel.info.inputs_sha256) = provenance::record(&model.sources, output_dir);
    Ok(texel)
}

/// What a baked texture lost of its model's silhouette, if it lost much: for each axis where
/// the model blocks at least 2% of the view, the texture's finest level must block at least
/// half as much. Occupancy with too small a `--gamma`, or too coarse a grid for cards, can
/// fall short; the transmittance fit no longer empties cells that a view sees
/// (`bake::tomography`), and this check stands guard over it. The words say what to do
/// instead.
pub fn lost_silhouette(texel: &Texel) -> Option<String> {
    const AXES: [&str; 3] = ["x", "y", "z"];
    let lost: Vec<String> = (0..3)
        .filter_map(|a| {
            let mesh = texel.info.mesh_coverage[a];
            let texture = texel.texture_coverage(a);
            (mesh >= 0.02 && texture < 0.5 * mesh).then(|| {
                format!(
                    "{texture:.3} of the view along {} where the model blocks {mesh:.3}",
                    AXES[a]
                )
            })
        })
        .collect();
    if lost.is_empty() {
        return None;
    }
    let advice = match texel.info.density_model {
        DensityModel::Transmittance => {
            "the transmittance fit could not hold this model's views at once; --density \
             occupancy keeps its surfaces"
        }
        DensityModel::Occupancy => "a finer --resolution, or a --gamma, may keep more of it",
    };
    Some(format!(
        "the texture blocks only {}: {advice}",
        lost.join(", and ")
    ))
}

/// Bakes `mesh` into a texture that records no sources ([`bake_model`] records them): for
/// meshes made in memory, and for measuring the bake alone.
pub fn bake(mesh: &Mesh, settings: &BakeSettings) -> Result<Texel, BakeError> {
    settings.validate()?;
    let grid = fit_grid(mesh, settings)?;
    let (foliage, wood) = settings.patterns()?;
    let materials = classify::material_parts(mesh, &foliage, wood.as_ref());
    let is_foliage = classify::foliage_triangles(mesh, &materials);
    let components = classify::closed_components(mesh);
    let is_closed = components.iter().map(Option::is_some).collect();
    let thick = solid::thick_triangles(mesh, &components, grid.cell);
    let foliage_triangles = is_foliage.iter().filter(|&&f| f).count() as u64;
    let model = ScanModel::new(mesh, grid, is_foliage, is_closed);

    let occupancy = settings.density == DensityModel::Occupancy;
    let fine_cells: usize = grid.fine_dims().iter().product();
    if occupancy && fine_cells > MAX_OCCUPANCY_FINE_CELLS {
        let [x, y, z] = grid.fine_dims();
        return Err(BakeError::Settings(format!(
            "--density occupancy keeps 3 bytes a fine cell, and --fine {} makes this model's \
             grid {x} x {y} x {z} fine cells ({:.1} GiB), over the 2^30 (3 GiB) it may \
             take: lower --fine, or bake by transmittance, which keeps none",
            settings.fine,
            3.0 * fine_cells as f64 / f64::from(1u32 << 30),
        )));
    }
    let scans = scan_all(&model, occupancy)?;
    let rays = (grid.k * grid.k) as f64;
    let mesh_coverage: [f64; 3] = std::array::from_fn(|a| {
        let misses: u64 = scans[a].misses[0].iter().map(|&m| m as u64).sum();
        1.0 - misses as f64 / (rays * scans[a].misses[0].len() as f64)
    });

    let (density, extinction_scale) = match settings.density {
        DensityModel::Transmittance => (transmittance_density(&grid, &scans), 1.0),
        DensityModel::Occupancy => {
            let density = occupancy_density(&grid, &scans);
            let gamma = settings
                .gamma
                .unwrap_or_else(|| fit_gamma(&grid, &density, mesh_coverage));
            (density, gamma)
        }
    };
    // Colour and leaves come from every surface, solid or not: the scan leaves out only
    // those nothing can see.
    let mut level = Level::empty(grid.dims, grid.cell);
    level.albedo = albedo(&grid, &scans);
    level.leaves = normal_moments(&grid, &scans, 1);
    level.wood_normals = normal_moments(&grid, &scans, 0);
    let with_density = |mut level: Level, density: [Vec<f32>; 2]| {
        level.density = density;
        // The paper's occupancy is kept as the paper has it.
        if settings.density == DensityModel::Transmittance {
            refine::refine(mesh, &mut level, grid.origin, extinction_scale);
        }
        for part in 0..2 {
            level.gradient[part] = sobel::gradient(&level.density[part], grid.dims, grid.cell);
        }
        mip_chain(level, extinction_scale)
    };
    let mut levels = with_density(level.clone(), density);
    if thick.iter().any(|&t| t) && fine_cells <= solid::MAX_FINE_CELLS {
        // The thick closed parts as solids, the rest as density (`bake::solid`).
        let thin: Vec<bool> = thick.iter().map(|t| !t).collect();
        let thin_scans = scan_all(&model.only(&thin), occupancy)?;
        let mut thin_density = match settings.density {
            DensityModel::Transmittance => transmittance_density(&grid, &thin_scans),
            DensityModel::Occupancy => occupancy_density(&grid, &thin_scans),
        };
        let split = solid::split(&grid, &scan_all(&model.only(&thick), true)?);
        // What of the thick parts their level set leaves out is density, as the rest is.
        for (density, lost) in thin_density.iter_mut().zip(&split.lost) {
            for (d, &f) in density.iter_mut().zip(lost) {
                if f > 0.0 {
                    *d += solid::lost_density(f, settings.density, grid.k, grid.cell);
                }
            }
        }
        level.solid = split.solid;
        levels = solid::choose(levels, with_density(level, thin_density));
    }
    let forms = calibrate::directional_forms(mesh, &levels, grid.origin, extinction_scale);
    for (level, s) in levels.iter_mut().zip(forms) {
        level.directional = s;
    }
    let (sights, shown) = seen::fit_sight(
        mesh,
        &model.is_foliage,
        &levels,
        grid.origin,
        extinction_scale,
    );
    for ((level, s), shown) in levels.iter_mut().zip(sights).zip(shown) {
        level.wood_weight = s.wood_weight;
        level.self_shadow = s.self_shadow;
        level.wood_shown = shown;
    }

    let (lo, hi) = mesh.bounds().expect("fit_grid checked for triangles");
    Ok(Texel {
        info: TexelInfo {
            generator: concat!("texel-forest ", env!("CARGO_PKG_VERSION")).to_string(),
            model_min: lo.as_dvec3().to_array(),
            model_max: hi.as_dvec3().to_array(),
            origin: grid.origin.to_array(),
            density_model: settings.density,
            extinction_scale,
            triangles: mesh.triangles.len() as u64,
            foliage_triangles,
            mesh_coverage,
            sources: Vec::new(),
            inputs_sha256: [0; 32],
            parameters: BakeParameters {
                resolution: settings.resolution as u32,
                fine: settings.fine as u32,
                foliage_pattern: settings.foliage.clone(),
                requested_gamma: settings.gamma,
                wood_pattern: settings.wood.clone(),
            },
            materials,
        },
        levels,
    })
}

fn scan_all(model: &ScanModel, occupancy: bool) -> Result<Vec<AxisScan>, BakeError> {
    (0..3)
        .map(|axis| scan::scan_axis(model, axis, occupancy))
        .collect::<Result<_, _>>()
        .map_err(|e| BakeError::Model(e.to_string()))
}

/// Which triangles of `mesh` are foliage under the patterns a bake recorded, decided as the
/// bake decided it (the model must be the one baked: its sources' hashes say so).
pub fn foliage_triangles(mesh: &Mesh, parameters: &BakeParameters) -> Result<Vec<bool>, BakeError> {
    let settings = BakeSettings {
        foliage: parameters.foliage_pattern.clone(),
        wood: parameters.wood_pattern.clone(),
        ..BakeSettings::default()
    };
    let (foliage, wood) = settings.patterns()?;
    let parts = classify::material_parts(mesh, &foliage, wood.as_ref());
    Ok(classify::foliage_triangles(mesh, &parts))
}

/// The extinction (1/m, both parts) each axis's rays estimate, before they are combined into
/// one isotropic value: what `formats/texel.md`'s measurement of anisotropy compares against.
pub fn axis_extinctions(
    mesh: &Mesh,
    settings: &BakeSettings,
) -> Result<(Grid, [Vec<f32>; 3]), BakeError> {
    settings.validate()?;
    let grid = fit_grid(mesh, settings)?;
    let (foliage, wood) = settings.patterns()?;
    let parts = classify::material_parts(mesh, &foliage, wood.as_ref());
    let model = ScanModel::new(
        mesh,
        grid,
        classify::foliage_triangles(mesh, &parts),
        classify::closed_triangles(mesh),
    );
    let scans = scan_all(&model, false)?;
    let enclosed = ((2 * grid.k * grid.k) as f64).ln() / grid.cell;
    let per_axis = [0, 1, 2].map(|a| {
        cells(&grid)
            .map(|c| scans[a].sigma[0][scan_index(&grid, a, c)].map_or(enclosed as f32, |s| s))
            .collect()
    });
    Ok((grid, per_axis))
}

/// Level 0 and every coarser level down to one cell (see `formats/texel.md`).
/// The cells, all mip levels, that baking `mesh` with `settings` makes: known before any work,
/// so that a bake can be held to the reader's `--max-cells` before it starts.
pub fn planned_cells(mesh: &Mesh, settings: &BakeSettings) -> Result<u64, BakeError> {
    settings.validate()?;
    let mut dims = fit_grid(mesh, settings)?.dims.map(|d| d as u64);
    let mut cells = dims.iter().product::<u64>();
    while dims.iter().product::<u64>() > 1 {
        dims = dims.map(|d| d.div_ceil(2));
        cells += dims.iter().product::<u64>();
    }
    Ok(cells)
}

pub fn mip_chain(level0: Level, extinction_scale: f64) -> Vec<Level> {
    let mut levels = vec![level0];
    while let Some(last) = levels.last().filter(|l| l.cell_count() > 1) {
        let next = filter::reduce(last, extinction_scale);
        levels.push(next);
    }
    levels
}

fn fit_grid(mesh: &Mesh, settings: &BakeSettings) -> Result<Grid, BakeError> {
    let (res, fine) = (settings.resolution, settings.fine);
    let Some((lo, hi)) = mesh.bounds() else {
        return Err(BakeError::Model("the model has no triangles".into()));
    };
    let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
    let extent = hi - lo;
    if !extent.is_finite() {
        return Err(BakeError::Model(
            "the model's extent overflows (coordinates near the float limit)".into(),
        ));
    }
    let size = extent.max_element();
    // A model whose nodes put it far from its scene's origin has its vertices rounded, as
    // 32-bit floats, to a grid that grows with the distance: a metre-sized model at 1e12 m
    // collapses to a plane or a point, and said only that it was flat or tiny.
    let reach = lo.abs().max(hi.abs()).max_element();
    let spacing = reach * f64::from(f32::EPSILON);
    if spacing > 0.01 * size.max(MIN_MODEL_SIZE) {
        return Err(BakeError::Model(format!(
            "the model reaches {} m from its scene's origin, where 32-bit floats (which hold \
             its vertices) are {} m apart, too coarse for a model {} m across; move it (or its \
             root node) nearer the origin",
            number(reach, 1),
            number(spacing, 3),
            number(size, 3)
        )));
    }
    if size < MIN_MODEL_SIZE {
        return Err(BakeError::Model(format!(
            "the model is {size:e} m across, smaller than {MIN_MODEL_SIZE} m; glTF is in metres: \
             scale the model (its densities would overflow)"
        )));
    }
    for (a, axis) in ['X', 'Y', 'Z'].into_iter().enumerate() {
        if extent[a] <= 1e-6 * extent.max_element() {
            return Err(BakeError::Flat { axis });
        }
    }
    Ok(Grid::fit(lo, hi, res, fine / res))
}

/// Index into an [`AxisScan`]'s `[column][l]` arrays of texture cell `c`.
fn scan_index(grid: &Grid, axis: usize, c: [usize; 3]) -> usize {
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    (c[u] + grid.dims[u] * c[v]) * grid.dims[axis] + c[axis]
}

fn cells(grid: &Grid) -> impl Iterator<Item = [usize; 3]> + '_ {
    let [nx, ny, nz] = grid.dims;
    (0..nz).flat_map(move |z| (0..ny).flat_map(move |y| (0..nx).map(move |x| [x, y, z])))
}

/// Extinction per cell from the three axes' estimates, isotropic (`formats/texel.md` says why).
/// A cell starts from the mean over the axes whose rays reached it (a cell no ray reached from
/// any of the six sides is enclosed by opaque surfaces and gets the largest resolvable
/// extinction); the field is then fitted so its column optical depths along x, y and z agree
/// with the transmittance the rays measured. Wood is fitted to the wood-only measurements, so
/// a leafless render is as accurate as a leafy one; foliage is what the whole tree adds to it.
fn transmittance_density(grid: &Grid, scans: &[AxisScan]) -> [Vec<f32>; 2] {
    let enclosed = ((2 * grid.k * grid.k) as f64).ln() / grid.cell;
    let combine = |set: usize, c: [usize; 3]| -> f64 {
        let (sum, n) = (0..3)
            .filter_map(|a| scans[a].sigma[set][scan_index(grid, a, c)])
            .fold((0.0, 0), |(s, n), x| (s + x as f64, n + 1));
        if n == 0 { enclosed } else { sum / n as f64 }
    };
    let mut all: Vec<f32> = cells(grid).map(|c| combine(0, c) as f32).collect();
    let mut wood: Vec<f32> = cells(grid).map(|c| combine(1, c) as f32).collect();
    let rays = (grid.k * grid.k) as f64;
    for (set, field) in [(0, &mut all), (1, &mut wood)] {
        let targets = [0, 1, 2].map(|a| tomography::Targets {
            depth: scans[a].misses[set]
                .iter()
                .map(|&m| -((m as f64 / rays).max(1.0 / (2.0 * rays))).ln())
                .collect(),
            opaque: scans[a].misses[set].iter().map(|&m| m == 0).collect(),
        });
        tomography::fit(grid, field, &targets);
    }
    let foliage = all
        .iter()
        .zip(&wood)
        .map(|(a, w)| (a - w).max(0.0))
        .collect();
    [wood, foliage]
}

/// The paper's density: the fraction of each texture cell's fine cells that are occupied. A
/// fine cell is occupied when a surface crosses it (on any axis's ray) or when its centre is
/// inside a closed part by the winding count of at least two of the three rays through it (so a
/// leak along one axis does not fill a streak).
fn occupancy_density(grid: &Grid, scans: &[AxisScan]) -> [Vec<f32>; 2] {
    use scan::{INSIDE_ALL, INSIDE_WOOD, SURFACE_ALL, SURFACE_WOOD};
    let k = grid.k;
    let per_cell: Vec<[f32; 2]> = cells(grid)
        .collect::<Vec<_>>()
        .par_iter()
        .map(|&c| {
            let mut count = [0u32; 2];
            for fz in c[2] * k..(c[2] + 1) * k {
                for fy in c[1] * k..(c[1] + 1) * k {
                    for fx in c[0] * k..(c[0] + 1) * k {
                        let f = [fx, fy, fz];
                        let bits = scan::fine_bits(grid, scans, f);
                        let any = |m: u8| bits.iter().any(|b| b & m != 0);
                        let votes = |m: u8| bits.iter().filter(|b| *b & m != 0).count();
                        let all = any(SURFACE_ALL) || votes(INSIDE_ALL) >= 2;
                        let wood = any(SURFACE_WOOD) || votes(INSIDE_WOOD) >= 2;
                        count[0] += (all || wood) as u32;
                        count[1] += wood as u32;
                    }
                }
            }
            let n = (k * k * k) as f32;
            [count[1] as f32 / n, (count[0] - count[1]) as f32 / n]
        })
        .collect();
    [
        per_cell.iter().map(|c| c[0]).collect(),
        per_cell.iter().map(|c| c[1]).collect(),
    ]
}

/// gamma that makes the occupancy texture's silhouettes cover, on average over the three axis
/// views, as much as the mesh does: the paper leaves gamma to the user; fitting it gives the
/// occupancy model its best chance and a meaningful default.
fn fit_gamma(grid: &Grid, density: &[Vec<f32>; 2], mesh_coverage: [f64; 3]) -> f64 {
    let [nx, ny, nz] = grid.dims;
    let occupancy = |x: usize, y: usize, z: usize| {
        let i = x + nx * (y + ny * z);
        (density[0][i] + density[1][i]) as f64
    };
    // Column sums of occupancy x cell along each axis.
    let mut columns: [Vec<f64>; 3] = [vec![0.0; ny * nz], vec![0.0; nx * nz], vec![0.0; nx * ny]];
    for z in 0..nz {
        for y in 0..ny {
            for x in 0..nx {
                let o = occupancy(x, y, z) * grid.cell;
                columns[0][y + ny * z] += o;
                columns[1][x + nx * z] += o;
                columns[2][x + nx * y] += o;
            }
        }
    }
    let target = mesh_coverage.iter().sum::<f64>() / 3.0;
    let coverage = |gamma: f64| {
        columns
            .iter()
            .map(|c| c.iter().map(|&d| 1.0 - (-gamma * d).exp()).sum::<f64>() / c.len() as f64)
            .sum::<f64>()
            / 3.0
    };
    // Coverage grows monotonically with gamma: bisect on a log scale.
    let (mut lo, mut hi) = ((1e-3 / grid.cell).ln(), (1e4 / grid.cell).ln());
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if coverage(mid.exp()) < target {
            lo = mid
        } else {
            hi = mid
        }
    }
    (0.5 * (lo + hi)).exp()
}

/// Mean colour of the surface crossings in each cell, per part, filled in where a part has none.
/// Per cell, the normal moment `E[n n^T]` of a part's surfaces (foliage 1, wood 0) over the
/// three axes' crossings, each weighted so the sum is by area (see `scan`); isotropic where
/// none of the part was crossed.
fn normal_moments(grid: &Grid, scans: &[AxisScan], part: usize) -> Vec<[f32; 6]> {
    cells(grid)
        .map(|c| {
            let (mut sum, mut weight) = ([0.0f64; 6], 0.0f64);
            for (a, scan) in scans.iter().enumerate() {
                let i = scan_index(grid, a, c);
                for (s, m) in sum.iter_mut().zip(scan.normal_sum[part][i]) {
                    *s += f64::from(m);
                }
                weight += f64::from(scan.normal_weight[part][i]);
            }
            if weight > 0.0 {
                unit_moment(sum.map(|s| (s / weight) as f32))
            } else {
                ISOTROPIC_LEAVES
            }
        })
        .collect()
}

fn albedo(grid: &Grid, scans: &[AxisScan]) -> [Vec<[f32; 3]>; 2] {
    [0, 1].map(|part| {
        let mut known = Vec::with_capacity(grid.cell_count());
        let mut albedo: Vec<[f32; 3]> = cells(grid)
            .map(|c| {
                let (mut sum, mut n) = ([0.0f64; 3], 0u32);
                for (a, scan) in scans.iter().enumerate() {
                    let i = scan_index(grid, a, c);
                    for ch in 0..3 {
                        sum[ch] += scan.color_sum[part][i][ch] as f64;
                    }
                    n += scan.crossings[part][i];
                }
                known.push(n > 0);
                if n > 0 {
                    sum.map(|s| (s / n as f64).clamp(0.0, 1.0) as f32)
                } else {
                    [0.0; 3]
                }
            })
            .collect();
        filter::fill_unknown(&mut albedo, &mut known, grid.dims);
        albedo
    })
}

#[cfg(test)]
mod pattern_tests {
    /// The patterns take the regex crate's whole syntax, Unicode classes and scripts
    /// included (`\p{L}` was refused as an unknown property), case-insensitively.
    #[test]
    fn material_patterns_take_unicode_classes() {
        let p = super::pattern("--foliage", r"^\p{L}+$").unwrap();
        assert!(p.is_match("Blätter") && !p.is_match("leaf_01"));
        let p = super::pattern("--foliage", r"\p{Greek}").unwrap();
        assert!(p.is_match("φύλλα"));
        assert!(
            super::pattern("--foliage", "LEAF")
                .unwrap()
                .is_match("leaf")
        );
    }
}
