//! What placement reads and what it writes: the species file and every texture it names (a
//! texture's model height turns tree heights into scales), the terrain, and the `.instances`
//! file a placement becomes, with every input recorded by path and hash.

use std::path::{Path, PathBuf};

use super::{Placement, quantisation_origin};
use crate::formats::instances::{self, ForestInfo, MAX_SCALE, MIN_SCALE, SpeciesRecord};
use crate::formats::{container, texel};
use crate::limits::Limits;
use crate::provenance::{self, SourceFile};
use crate::species::{Species, SpeciesError, SpeciesFile};
use crate::terrain::{HeightmapOptions, Terrain, TerrainError};

/// Everything placement needs, read and checked.
pub struct PlaceInputs {
    pub terrain: Terrain,
    pub species: SpeciesFile,
    /// The species file as the forest records it.
    pub species_source: SourceFile,
    /// Per species, its record for the forest file (textures relative to the output).
    pub records: Vec<SpeciesRecord>,
    /// Per species, the height of its texture's model in model units.
    pub model_heights: Vec<f64>,
    /// Every file read: the terrain's, the species file, the textures.
    pub dependencies: Vec<PathBuf>,
}

#[derive(Debug, thiserror::Error)]
pub enum InputsError {
    /// A file could not be read or decoded; `what` says where it was named.
    #[error("{what}")]
    File {
        what: String,
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    #[error(transparent)]
    Terrain(#[from] TerrainError),
    #[error(transparent)]
    Species(#[from] SpeciesError),
}

fn file_error(what: String, e: impl std::error::Error + Send + Sync + 'static) -> InputsError {
    InputsError::File {
        what,
        source: Box::new(e),
    }
}

/// Reads the species file at `species`, every texture it names and the terrain at `terrain`
/// (a heightmap converted with `heightmap`); paths are recorded relative to `out_dir`, where
/// the forest file will be.
pub fn load(
    terrain: &Path,
    heightmap: &HeightmapOptions,
    species: &Path,
    out_dir: &Path,
    limits: &Limits,
) -> Result<PlaceInputs, InputsError> {
    let name = species.display().to_string();
    let (species_bytes, file) = SpeciesFile::read(species)?;
    let species_dir = species.parent().unwrap_or(Path::new(""));

    let mut dependencies: Vec<PathBuf> = Vec::new();
    let mut records = Vec::new();
    let mut model_heights = Vec::new();
    for (i, s) in file.species.iter().enumerate() {
        let mut read = |field: &str, rel: &Path| {
            let path = species_dir.join(rel);
            let what = format!("{name}: species[{i}].{field}: {}", path.display());
            let bytes = container::read_file(&path).map_err(|e| file_error(what.clone(), e))?;
            let info = texel::read_info(&bytes).map_err(|e| file_error(what, e))?;
            let source = provenance::source(&path, &bytes, out_dir);
            dependencies.push(path);
            Ok::<_, InputsError>((source, info))
        };
        let (texel_source, info) = read("texel", &s.texel)?;
        let leafless = match &s.leafless_texel {
            Some(rel) => Some(read("leafless_texel", rel)?.0),
            None => None,
        };
        // A tree's scale, its height over its model's, must fit the forest's scale codes.
        let height = info.model_max[1] - info.model_min[1];
        let (lo, hi) = (s.height.min / height, s.height.max / height);
        if !(height > 0.0 && lo >= MIN_SCALE && hi < MAX_SCALE) {
            use crate::number::{number, shortest};
            let (field, why) = if height > 0.0 && height.is_finite() {
                let (h0, h1) = (shortest(s.height.min), shortest(s.height.max));
                (
                    "height",
                    format!(
                        "trees {h0} to {h1} m tall from a model {} units tall are scales {} to \
                         {}; a forest stores scales from 2^-16 to 2^16 (check the height's \
                         units, and the model's)",
                        number(height, 3),
                        number(lo, 6),
                        number(hi, 6)
                    ),
                )
            } else {
                (
                    "texel",
                    format!(
                        "{} records a model {} units tall (model_min.y to model_max.y): a tree \
                         needs a positive height",
                        species_dir.join(&s.texel).display(),
                        shortest(height)
                    ),
                )
            };
            return Err(InputsError::File {
                what: format!("{name}: species[{i}].{field}"),
                source: why.into(),
            });
        }
        model_heights.push(height);
        records.push(species_record(s, texel_source, leafless, height));
    }
    let terrain = Terrain::load_with(terrain, heightmap, limits)?;
    let mut all: Vec<PathBuf> = terrain
        .model
        .sources
        .iter()
        .map(|s| s.path.clone())
        .collect();
    all.push(species.to_path_buf());
    for d in dependencies {
        if !all.contains(&d) {
            all.push(d);
        }
    }
    Ok(PlaceInputs {
        terrain,
        species_source: provenance::source(species, &species_bytes, out_dir),
        species: file,
        records,
        model_heights,
        dependencies: all,
    })
}

/// How the forest file records species `s`: its textures (`texel`, and `leafless` where it has
/// one) as found from the forest, and the height of the texture's model.
pub fn species_record(
    s: &Species,
    texel: SourceFile,
    leafless: Option<SourceFile>,
    model_height: f64,
) -> SpeciesRecord {
    SpeciesRecord {
        name: s.name.clone(),
        texel: texel.path,
        texel_sha256: texel.sha256,
        leafless_texel: leafless.as_ref().map(|l| l.path.clone()),
        leafless_sha256: leafless.map(|l| l.sha256),
        model_height,
        spacing: s.spacing,
        height_min: s.height.min,
        height_max: s.height.max,
        traits: s.traits,
        seasons: s.seasons.clone(),
    }
}

/// The forest file of `placement`, made from `inputs` with `seed` (and `max_count`, where one
/// was asked for); the terrain's files are recorded relative to `out_dir`.
pub fn forest_file(
    inputs: &PlaceInputs,
    placement: Placement,
    seed: u64,
    max_count: Option<u64>,
    out_dir: &Path,
) -> instances::Forest {
    let (terrain_records, _) = provenance::record(&inputs.terrain.model.sources, out_dir);
    instances::Forest {
        info: ForestInfo {
            generator: concat!("texel-forest ", env!("CARGO_PKG_VERSION")).to_string(),
            terrain: terrain_records,
            species_file: inputs.species_source.clone(),
            seed,
            region: placement.region,
            raster_cell: placement.raster.cell,
            max_count: max_count.unwrap_or(u64::MAX),
            truncated: placement.truncated,
            terrain_min: inputs.terrain.lo.to_array(),
            terrain_max: inputs.terrain.hi.to_array(),
            origin: quantisation_origin(&placement.instances),
            species: inputs.records.clone(),
        },
        instances: placement.instances,
        heightmap: inputs.terrain.heightmap,
    }
}
