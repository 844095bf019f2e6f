//! `texel place`: terrain + species -> `.instances`.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use sha2::{Digest, Sha256};

use texel_forest::formats::instances::{self, ForestInfo, SpeciesRecord};
use texel_forest::formats::texel;
use texel_forest::output::{depfile, relative_path, write_atomic};
use texel_forest::place::{self, PlaceSettings};
use texel_forest::species::SpeciesFile;
use texel_forest::terrain::Terrain;
use texel_forest::volume::SourceFile;

use crate::cli::PlaceArgs;

/// `x0,z0,x1,z1` -> the four numbers.
fn parse_region(s: &str) -> anyhow::Result<[f64; 4]> {
    let v: Vec<f64> = s
        .split(',')
        .map(|p| p.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .unwrap_or_default();
    match v.as_slice() {
        &[a, b, c, d] => Ok([a, b, c, d]),
        _ => bail!("--region {s:?}: expected four numbers X0,Z0,X1,Z1 (metres)"),
    }
}

fn source(path: &Path, bytes: &[u8], out_dir: &Path) -> SourceFile {
    SourceFile {
        path: relative_path(path, out_dir),
        sha256: Sha256::digest(bytes).into(),
        bytes: bytes.len() as u64,
    }
}

pub fn run(args: &PlaceArgs, quiet: bool) -> anyhow::Result<()> {
    let start = Instant::now();
    let region = args.region.as_deref().map(parse_region).transpose()?;
    if args.max_count == Some(0) {
        bail!("--max-count must be at least 1");
    }
    let species_bytes = std::fs::read(&args.species)
        .with_context(|| format!("cannot read {}", args.species.display()))?;
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
    let out_dir = super::output_dir(&args.output)?;
    let mut dependencies: Vec<PathBuf> = Vec::new();
    let mut records = Vec::new();
    let mut model_heights = Vec::new();
    for (i, s) in species.species.iter().enumerate() {
        let read = |field: &str,
                    rel: &Path|
         -> anyhow::Result<(PathBuf, Vec<u8>, texel_forest::volume::TexelInfo)> {
            let path = species_dir.join(rel);
            let bytes = std::fs::read(&path).with_context(|| {
                format!(
                    "{}: species[{i}].{field}: cannot read {}",
                    args.species.display(),
                    path.display()
                )
            })?;
            let info = texel::read_info(&bytes).with_context(|| {
                format!(
                    "{}: species[{i}].{field}: {}",
                    args.species.display(),
                    path.display()
                )
            })?;
            Ok((path, bytes, info))
        };
        let (path, bytes, info) = read("texel", &s.texel)?;
        let height = info.model_max[1] - info.model_min[1];
        let texel_source = source(&path, &bytes, &out_dir);
        dependencies.push(path);
        let leafless = match &s.leafless_texel {
            Some(rel) => {
                let (path, bytes, _) = read("leafless_texel", rel)?;
                let src = source(&path, &bytes, &out_dir);
                dependencies.push(path);
                Some(src)
            }
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

    let terrain = Terrain::load(&args.terrain)?;
    for w in &terrain.model.warnings {
        super::warn(w);
    }
    let settings = PlaceSettings {
        seed: args.seed,
        max_count: args.max_count.unwrap_or(usize::MAX),
        region,
        cell: args.cell,
    };
    // Placement's errors name the flag or the species setting at fault.
    let forest = place::place(&terrain, &species, &model_heights, &settings)?;
    if forest.truncated {
        super::warn(&format!(
            "--max-count {} reached: the forest does not fill the region",
            settings.max_count
        ));
    }
    if forest.instances.is_empty() {
        super::warn("no ground in the region suits any species: the forest is empty");
    }

    let terrain_sources: Vec<SourceFile> = terrain
        .model
        .sources
        .iter()
        .map(|s| SourceFile {
            path: relative_path(&s.path, &out_dir),
            sha256: s.sha256,
            bytes: s.bytes,
        })
        .collect();
    let lo = forest.instances.iter().fold([f64::INFINITY; 3], |a, p| {
        std::array::from_fn(|c| a[c].min(p.position[c]))
    });
    let origin = if forest.instances.is_empty() {
        [0.0; 3]
    } else {
        lo.map(f64::floor)
    };
    let info = ForestInfo {
        generator: concat!("texel-forest ", env!("CARGO_PKG_VERSION")).to_string(),
        terrain: terrain_sources,
        species_file: source(&args.species, &species_bytes, &out_dir),
        seed: args.seed,
        region: forest.region,
        raster_cell: forest.raster.cell,
        max_count: args.max_count.map_or(u64::MAX, |m| m as u64),
        truncated: forest.truncated,
        terrain_min: terrain.lo.to_array(),
        terrain_max: terrain.hi.to_array(),
        origin,
        species: records,
    };
    let file = instances::Forest {
        info,
        instances: forest.instances,
    };
    let bytes = instances::encode(&file).with_context(|| args.output.display().to_string())?;
    write_atomic(&args.output, &bytes)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    if let Some(dep) = &args.depfile {
        let mut deps: Vec<PathBuf> = terrain
            .model
            .sources
            .iter()
            .map(|s| s.path.clone())
            .collect();
        deps.push(args.species.clone());
        for d in dependencies {
            if !deps.contains(&d) {
                deps.push(d);
            }
        }
        write_atomic(dep, depfile(&args.output, &deps).as_bytes())
            .with_context(|| format!("cannot write {}", dep.display()))?;
    }
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
            bytes.len() as f64 / n.max(1) as f64,
            start.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
