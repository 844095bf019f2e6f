//! `place`: which tree grows where (the paper's section 4).
//!
//! The passes: resample the terrain into a height raster over the region, derive its
//! attributes, turn them into a suitability map per species, throw darts (maximal Poisson-disk
//! sampling, radius by species and size, species chosen by suitability), then give every tree
//! its exact ground height, a rotation, a scale and a variation seed, and order the trees along
//! a Z-order curve so neighbours in the file are neighbours on the ground.

pub mod diagnosis;
pub mod inputs;
pub mod poisson;

use rayon::prelude::*;

pub use crate::formats::instances::Instance;
use crate::formats::instances::{QUANTUM, SCALE_STEPS};
use crate::rng;
use crate::species::SpeciesFile;
use crate::terrain::{Attributes, Heightfield, Terrain};

/// Largest ratio of the largest tree radius to the smallest: the background grid's cells are
/// sized by the smallest and its neighbourhood scans by the largest.
const MAX_RADIUS_RATIO: f64 = 64.0;

/// Smallest and largest disc radius any tree of `species` may have (as the sampler keeps it).
fn radius_range(species: &SpeciesFile) -> (f64, f64) {
    species
        .species
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), s| {
            (
                a.min(stored_radius_guard(s.radius(s.height.min))),
                b.max(stored_radius_guard(s.radius(s.height.max))),
            )
        })
}

/// Largest height raster accepted (cells); pass a coarser `--cell` beyond it.
const MAX_RASTER_CELLS: usize = 25_000_000;

#[derive(Clone, Debug)]
pub struct PlaceSettings {
    pub seed: u64,
    pub max_count: usize,
    /// x0, z0, x1, z1 in world metres; `None` = the whole terrain.
    pub region: Option<[f64; 4]>,
    /// Raster cell (m); `None` = the mesh's own resolution.
    pub cell: Option<f64>,
    /// Nothing grows where the ground is lower (m); `None` = no limit.
    pub sea_level: Option<f64>,
}

impl Default for PlaceSettings {
    fn default() -> Self {
        PlaceSettings {
            seed: 1,
            max_count: usize::MAX,
            region: None,
            cell: None,
            sea_level: None,
        }
    }
}

/// The result of placement, with what was derived on the way (for pictures and reports).
pub struct Placement {
    pub region: [f64; 4],
    pub raster: Heightfield,
    pub attributes: Attributes,
    /// Per species, suitability on the raster.
    pub suitability: Vec<Vec<f32>>,
    pub instances: Vec<Instance>,
    /// Whether `max_count` cut placement short.
    pub truncated: bool,
}

#[derive(Debug, thiserror::Error)]
pub enum PlaceError {
    #[error("{0}")]
    Settings(String),
    /// The species file asks for what placement cannot do (the caller names the file).
    #[error("{0}")]
    Species(String),
    #[error(transparent)]
    Sampling(#[from] poisson::PoissonError),
}

/// The terrain's ground rectangle, or the part of it `region` asks for.
pub fn region_of(terrain: &Terrain, region: Option<[f64; 4]>) -> Result<[f64; 4], PlaceError> {
    let (lo, hi) = (terrain.lo, terrain.hi);
    let Some([x0, z0, x1, z1]) = region else {
        return Ok([lo.x, lo.z, hi.x, hi.z]);
    };
    if ![x0, z0, x1, z1].iter().all(|v| v.is_finite()) || x0 >= x1 || z0 >= z1 {
        return Err(PlaceError::Settings(format!(
            "--region {x0},{z0},{x1},{z1}: needs x0 < x1 and z0 < z1"
        )));
    }
    let clipped = [x0.max(lo.x), z0.max(lo.z), x1.min(hi.x), z1.min(hi.z)];
    if clipped[0] >= clipped[2] || clipped[1] >= clipped[3] {
        return Err(PlaceError::Settings(format!(
            "--region {x0},{z0},{x1},{z1} lies outside the terrain (x {:.1} to {:.1}, z {:.1} to {:.1})",
            lo.x, hi.x, lo.z, hi.z
        )));
    }
    Ok(clipped)
}

/// The ground as placement judges it: the height raster over the region (and a
/// topographic-position radius around it), its attributes, and each species' suitability.
pub struct Ground {
    pub region: [f64; 4],
    pub raster: Heightfield,
    pub attributes: Attributes,
    /// Per species, suitability on the raster (0 below `sea_level`).
    pub suitability: Vec<Vec<f32>>,
}

/// Judges the ground of `terrain` for `species` with `settings`' region, cell and sea level.
pub fn ground(
    terrain: &Terrain,
    species: &SpeciesFile,
    settings: &PlaceSettings,
) -> Result<Ground, PlaceError> {
    let region = region_of(terrain, settings.region)?;
    let cell = settings.cell.unwrap_or_else(|| terrain.natural_cell());
    if !(cell.is_finite() && cell > 0.0) {
        return Err(PlaceError::Settings(format!(
            "--cell {cell} must be a positive number of metres"
        )));
    }
    // The raster reaches a topographic-position radius beyond the region (where there is
    // terrain), so attributes at the region's edge see their whole neighbourhood.
    let margin = species.analysis.tpi_radius;
    let (lo, hi) = (terrain.lo, terrain.hi);
    let extent = [
        (region[0] - margin).max(lo.x),
        (region[1] - margin).max(lo.z),
        (region[2] + margin).min(hi.x),
        (region[3] + margin).min(hi.z),
    ];
    let cells = ((extent[2] - extent[0]) / cell).ceil() * ((extent[3] - extent[1]) / cell).ceil();
    if cells > MAX_RASTER_CELLS as f64 {
        return Err(PlaceError::Settings(format!(
            "a raster of {cell} m cells over the region has {cells:.0} cells (at most {MAX_RASTER_CELLS}); give a larger --cell"
        )));
    }
    let raster = Heightfield::sample(terrain, extent[0], extent[1], extent[2], extent[3], cell);
    let attributes = Attributes::compute(&raster, species.analysis.tpi_radius);
    let above_sea = |h: f64| settings.sea_level.is_none_or(|sea| h >= sea);
    let suitability: Vec<Vec<f32>> = species
        .species
        .iter()
        .map(|s| {
            (0..raster.height.len())
                .into_par_iter()
                .map(|k| {
                    let a = [0, 1, 2, 3, 4].map(|n| attributes.get(&raster, n)[k] as f64);
                    if above_sea(a[0]) {
                        s.habitat.suitability(a) as f32
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    Ok(Ground {
        region,
        raster,
        attributes,
        suitability,
    })
}

/// Places trees of `species` (whose texel models are `model_heights` tall, in model units) on
/// `terrain`.
pub fn place(
    terrain: &Terrain,
    species: &SpeciesFile,
    model_heights: &[f64],
    settings: &PlaceSettings,
) -> Result<Placement, PlaceError> {
    let (r_min, r_max) = radius_range(species);
    // Written so that a ratio of NaN or infinite radii fails too.
    if r_max / r_min > MAX_RADIUS_RATIO || !r_max.is_finite() {
        return Err(PlaceError::Species(format!(
            "tree radii range from {r_min:.2} m to {r_max:.2} m; placement needs the largest within \
             {MAX_RADIUS_RATIO} times the smallest (check the species' spacing and height)"
        )));
    }
    let Ground {
        region,
        raster,
        attributes,
        suitability,
    } = ground(terrain, species, settings)?;
    let chooser = Chooser::new(&raster, &suitability, species);
    let samples = poisson::sample(
        region,
        r_min,
        r_max,
        settings.seed,
        settings.max_count,
        |rect| chooser.may_take(rect),
        |x, z, key| chooser.propose(x, z, key),
    )?;
    let truncated = samples.len() >= settings.max_count;

    let mut instances: Vec<Instance> = samples
        .par_iter()
        .filter_map(|(disc, choice)| stand(terrain, species, settings, model_heights, disc, choice))
        .collect();
    let morton_key = |p: &Instance| {
        let q = |v: f64, o: f64| (((v - o) * 100.0).round().max(0.0) as u64).min(u32::MAX as u64);
        morton(q(p.position[0], region[0]), q(p.position[2], region[1]))
    };
    instances.sort_by_cached_key(morton_key);
    Ok(Placement {
        region,
        raster,
        attributes,
        suitability,
        instances,
        truncated,
    })
}

/// A dart's species and height, chosen by the suitability rasters.
struct Chooser<'a> {
    raster: &'a Heightfield,
    suitability: &'a [Vec<f32>],
    species: &'a SpeciesFile,
    min_suitability: f64,
    /// Raster nodes that suit at least one species.
    habitable: Vec<bool>,
}

/// A chosen dart: species index, height (m) and its random key.
type Choice = (u8, f64, u64);

impl<'a> Chooser<'a> {
    fn new(raster: &'a Heightfield, suitability: &'a [Vec<f32>], species: &'a SpeciesFile) -> Self {
        let min_suitability = species.analysis.min_suitability.max(1e-6);
        let habitable = (0..raster.height.len())
            .map(|k| suitability.iter().any(|s| s[k] >= min_suitability as f32))
            .collect();
        Chooser {
            raster,
            suitability,
            species,
            min_suitability,
            habitable,
        }
    }

    /// Whether any tree may stand in the rectangle `[x0, z0, x1, z1]`. Bilinear suitability is
    /// a blend of four raster nodes, so a point can suit a species only next to a node that
    /// does: darts and the gap scan skip ground with no such node about.
    fn may_take(&self, [a, b, c, d]: [f64; 4]) -> bool {
        let r = self.raster;
        let node =
            |v: f64, o: f64, n: usize| ((v - o) / r.cell - 0.5).clamp(0.0, (n - 1) as f64) as usize;
        let (i0, i1) = (node(a, r.x0, r.nx), (node(c, r.x0, r.nx) + 1).min(r.nx - 1));
        let (j0, j1) = (node(b, r.z0, r.nz), (node(d, r.z0, r.nz) + 1).min(r.nz - 1));
        (j0..=j1).any(|j| (i0..=i1).any(|i| self.habitable[i + r.nx * j]))
    }

    /// The tree a dart at (`x`, `z`) would be, with its disc radius, or `None` where no
    /// species suits the ground. Species are drawn in proportion to suitability, so stands mix
    /// where habitats overlap.
    fn propose(&self, x: f64, z: f64, key: u64) -> Option<(f64, Choice)> {
        let (cells, bilinear) = self.raster.bilinear(x, z);
        if !cells.iter().any(|&c| self.habitable[c]) {
            return None;
        }
        let n_species = self.species.species.len();
        let weight = |i: usize| {
            let s: f64 = (0..4)
                .map(|k| (self.suitability[i][cells[k]] * bilinear[k]) as f64)
                .sum();
            if s >= self.min_suitability { s } else { 0.0 }
        };
        let mut weights = [0.0f64; 256];
        for (i, w) in weights[..n_species].iter_mut().enumerate() {
            *w = weight(i);
        }
        let total: f64 = weights[..n_species].iter().sum();
        if total <= 0.0 {
            return None;
        }
        let mut u = rng::unit(rng::hash3(key, rng::purpose::SPECIES, 0)) * total;
        let mut chosen = n_species - 1;
        for (i, &w) in weights[..n_species].iter().enumerate() {
            if u < w {
                chosen = i;
                break;
            }
            u -= w;
        }
        let s = &self.species.species[chosen];
        let height = s.height.min
            + (s.height.max - s.height.min) * rng::unit(rng::hash3(key, rng::purpose::HEIGHT, 0));
        Some((
            stored_radius_guard(s.radius(height)),
            (chosen as u8, height, key),
        ))
    }
}

/// The tree for an accepted dart, standing on the exact ground, or `None` where that ground
/// is below the sea or outside its species' elevation band: the raster judged habitat at its
/// cells' centres only.
fn stand(
    terrain: &Terrain,
    species: &SpeciesFile,
    settings: &PlaceSettings,
    model_heights: &[f64],
    disc: &poisson::Disc,
    &(species_index, height, key): &Choice,
) -> Option<Instance> {
    let y = terrain.height_at(disc.x, disc.z)?;
    let band = species.species[species_index as usize].habitat.elevation;
    let above_sea = settings.sea_level.is_none_or(|sea| y >= sea);
    if !above_sea || band.is_some_and(|b| b.factor(y) <= 0.0) {
        return None;
    }
    Some(Instance {
        species: species_index,
        position: [disc.x, y, disc.z],
        rotation: (rng::unit(rng::hash3(key, rng::purpose::ROTATION, 0)) * std::f64::consts::TAU)
            as f32,
        scale: (height / model_heights[species_index as usize]) as f32,
        variation: (rng::hash3(key, rng::purpose::VARIATION, 0) >> 48) as u16,
    })
}

/// The `.instances` quantisation origin for `trees`: the whole metres at or below their
/// smallest coordinates, so stored centimetres are small and non-negative (0 for no trees).
pub fn quantisation_origin(trees: &[Instance]) -> [f64; 3] {
    if trees.is_empty() {
        return [0.0; 3];
    }
    let lo = trees.iter().fold([f64::INFINITY; 3], |a, p| {
        std::array::from_fn(|c| a[c].min(p.position[c]))
    });
    lo.map(f64::floor)
}

/// The radius the sampler keeps, a little larger than the tree's: positions are stored to the
/// centimetre and scales in steps of 2^(1/SCALE_STEPS), and the trees as stored must keep the spacing
/// rule, not only the trees as placed.
fn stored_radius_guard(r: f64) -> f64 {
    r * 2f64.powf(1.0 / SCALE_STEPS) + QUANTUM * std::f64::consts::SQRT_2
}

/// Interleaves the bits of two 32-bit coordinates (x in the even bits).
pub fn morton(x: u64, z: u64) -> u64 {
    fn spread(mut v: u64) -> u64 {
        v &= 0xffff_ffff;
        v = (v | (v << 16)) & 0x0000_ffff_0000_ffff;
        v = (v | (v << 8)) & 0x00ff_00ff_00ff_00ff;
        v = (v | (v << 4)) & 0x0f0f_0f0f_0f0f_0f0f;
        v = (v | (v << 2)) & 0x3333_3333_3333_3333;
        (v | (v << 1)) & 0x5555_5555_5555_5555
    }
    spread(x) | (spread(z) << 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn morton_interleaves() {
        assert_eq!(morton(0b11, 0b00), 0b0101);
        assert_eq!(morton(0b00, 0b11), 0b1010);
        assert_eq!(morton(u32::MAX as u64, u32::MAX as u64), u64::MAX);
    }
}
