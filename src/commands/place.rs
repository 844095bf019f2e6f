//! `texel place`: terrain + species -> `.instances`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;

use texel_forest::formats::container;
use texel_forest::formats::instances::{self, ForestInfo, SpeciesRecord};
use texel_forest::formats::texel;
use texel_forest::input::{self, MAX_SPECIES};
use texel_forest::limits::Limits;
use texel_forest::output::{Outputs, depfile};
use texel_forest::place::{self, PlaceSettings};
use texel_forest::provenance;
use texel_forest::species::SpeciesFile;
use texel_forest::terrain::{Terrain, survey};

use crate::cli::PlaceArgs;

pub fn run(args: &PlaceArgs, limits: &Limits, quiet: bool) -> anyhow::Result<()> {
    let start = Instant::now();
    let mut outputs = Outputs::new(&[&args.terrain, &args.species]);
    let forest_out = outputs.add("-o", &args.output)?;
    let dep_out = args
        .depfile
        .as_ref()
        .map(|d| outputs.add("--depfile", d))
        .transpose()?;
    if let Some(m) = args.max_count {
        limits.check_trees(m, "--max-count")?;
    }

    let species_bytes = input::read_bounded(&args.species, MAX_SPECIES, "species file")?;
    let species = SpeciesFile::parse(&species_bytes).map_err(|(field, message)| {
        anyhow::anyhow!(
            "{}: {}{message}",
            args.species.display(),
            if field.is_empty() {
                String::new()
            } else {
                format!("{field}: ")
            }
        )
    })?;
    let species_dir = args.species.parent().unwrap_or(Path::new("")).to_path_buf();

    // Every texel the species name must exist: its model's height turns tree heights into
    // scales.
    let out_dir = super::directory_of(&args.output);
    let mut dependencies: Vec<PathBuf> = Vec::new();
    let mut records = Vec::new();
    let mut model_heights = Vec::new();
    for (i, s) in species.species.iter().enumerate() {
        let mut read = |field: &str, rel: &Path| -> anyhow::Result<_> {
            let path = species_dir.join(rel);
            let context = || {
                format!(
                    "{}: species[{i}].{field}: {}",
                    args.species.display(),
                    path.display()
                )
            };
            let bytes = container::read_file(&path).with_context(context)?;
            let info = texel::read_info(&bytes).with_context(context)?;
            let source = provenance::source(&path, &bytes, &out_dir);
            dependencies.push(path);
            Ok((source, info))
        };
        let (texel_source, info) = read("texel", &s.texel)?;
        let height = info.model_max[1] - info.model_min[1];
        let leafless = match &s.leafless_texel {
            Some(rel) => Some(read("leafless_texel", rel)?.0),
            None => None,
        };
        model_heights.push(height);
        records.push(SpeciesRecord {
            name: s.name.clone(),
            texel: texel_source.path,
            texel_sha256: texel_source.sha256,
            leafless_texel: leafless.as_ref().map(|l| l.path.clone()),
            leafless_sha256: leafless.map(|l| l.sha256),
            model_height: height,
            spacing: s.spacing,
            height_min: s.height.min,
            height_max: s.height.max,
            traits: s.traits,
            seasons: s.seasons.clone(),
        });
    }
    outputs.add_inputs(&dependencies)?;

    let terrain = Terrain::load(&args.terrain, limits)?;
    for w in &terrain.model.warnings {
        super::warn(w);
    }
    let terrain_files: Vec<PathBuf> = terrain
        .model
        .sources
        .iter()
        .map(|s| s.path.clone())
        .collect();
    outputs.add_inputs(&terrain_files)?;
    // Placement stops one tree past the limit, so a species file that asks for billions of
    // trees fails in seconds, not after filling memory.
    let cap = args.max_count.unwrap_or(limits.trees.saturating_add(1));
    let settings = PlaceSettings {
        seed: args.seed,
        max_count: usize::try_from(cap).unwrap_or(usize::MAX),
        region: args.region,
        cell: args.cell,
        sea_level: args.sea_level,
    };
    // Placement's errors name the flag or the species setting at fault.
    let forest = place::place(&terrain, &species, &model_heights, &settings)?;
    limits.check_trees(forest.instances.len() as u64, "the forest's tree count")?;
    if forest.truncated && args.max_count.is_some() {
        super::warn(&format!(
            "--max-count {} reached: the forest does not fill the region",
            settings.max_count
        ));
    }
    warn_if_lopsided(&forest, &species);

    let (terrain_records, _) = provenance::record(&terrain.model.sources, &out_dir);
    let file = instances::Forest {
        info: ForestInfo {
            generator: concat!("texel-forest ", env!("CARGO_PKG_VERSION")).to_string(),
            terrain: terrain_records,
            species_file: provenance::source(&args.species, &species_bytes, &out_dir),
            seed: args.seed,
            region: forest.region,
            raster_cell: forest.raster.cell,
            max_count: args.max_count.unwrap_or(u64::MAX),
            truncated: forest.truncated,
            terrain_min: terrain.lo.to_array(),
            terrain_max: terrain.hi.to_array(),
            origin: place::quantisation_origin(&forest.instances),
            species: records,
        },
        instances: forest.instances,
    };
    let bytes = instances::encode(&file).with_context(|| args.output.display().to_string())?;
    let size = bytes.len();
    outputs.set(forest_out, bytes);
    if let Some(dep) = dep_out {
        let mut deps = terrain_files;
        deps.push(args.species.clone());
        for d in dependencies {
            if !deps.contains(&d) {
                deps.push(d);
            }
        }
        outputs.set(dep, depfile(&args.output, &deps).into_bytes());
    }
    outputs.commit()?;
    if !quiet {
        let n = file.instances.len();
        let mut counts = vec![0usize; file.info.species.len()];
        for p in &file.instances {
            counts[p.species as usize] += 1;
        }
        let per_species: Vec<String> = file
            .info
            .species
            .iter()
            .zip(&counts)
            .map(|(s, c)| format!("{} {c}", s.name))
            .collect();
        let r = file.info.region;
        eprintln!(
            "texel: placed {n} trees ({}) on {:.1} ha -> {}, {:.2} bytes per tree, in {:.2} s",
            per_species.join(", "),
            (r[2] - r[0]) * (r[3] - r[1]) / 1e4,
            args.output.display(),
            size as f64 / n.max(1) as f64,
            start.elapsed().as_secs_f64()
        );
    }
    Ok(())
}

/// An empty forest, or one species taking every tree, usually means the species file's
/// habitats do not fit this terrain (a coarse DEM's slopes and wetness differ from a fine
/// one's): say what the terrain offers and what each species asks for.
fn warn_if_lopsided(forest: &place::Placement, species: &SpeciesFile) {
    let n = forest.instances.len();
    let mut counts = vec![0usize; species.species.len()];
    for p in &forest.instances {
        counts[p.species as usize] += 1;
    }
    let lopsided = species.species.len() > 1 && counts.contains(&n);
    if n > 0 && !lopsided {
        return;
    }
    let s = survey::survey(
        &forest.raster,
        &forest.attributes,
        species.analysis.tpi_radius,
        forest.region,
        Some((species, &forest.suitability)),
    );
    let suited = s.species.iter().any(|f| f.suitable_share > 0.0);
    let why = if n == 0 && !suited {
        "no ground in the region suits any species: the forest is empty".to_string()
    } else if n == 0 {
        let r = forest.region;
        format!(
            "no tree was placed, though some ground suits a species: check that the species' \
             spacing fits the region ({:.0} m x {:.0} m) and their heights the terrain",
            r[2] - r[0],
            r[3] - r[1]
        )
    } else {
        let only = counts.iter().position(|&c| c == n).unwrap_or_default();
        format!(
            "every tree is {:?}: no ground in the region suits the other species",
            species.species[only].name
        )
    };
    super::warn(&format!(
        "{why}. What the terrain offers and what the species ask for (`texel inspect TERRAIN` shows more):\n{}",
        survey::to_text(&s).trim_end()
    ));
}
