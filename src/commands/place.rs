//! `texel place`: terrain + species -> `.instances`.

use std::time::Instant;

use anyhow::Context;

use texel_forest::formats::instances;
use texel_forest::limits::Limits;
use texel_forest::output::{Outputs, depfile};
use texel_forest::place::{self, PlaceSettings};

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
    let out_dir = super::directory_of(&args.output);
    let inputs = place::inputs::load(
        &args.terrain,
        &args.heightmap.options(),
        &args.species,
        &out_dir,
        limits,
    )?;
    for w in &inputs.terrain.model.warnings {
        super::warn(w);
    }
    outputs.add_inputs(&inputs.dependencies)?;

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
    // Placement's errors name the flag or the species setting at fault; a region too large
    // to sample is the terrain's, and radii it cannot mix the species file's, each named.
    let placement = place::place(
        &inputs.terrain,
        &inputs.species,
        &inputs.model_heights,
        &settings,
    )
    .map_err(|e| match e {
        place::PlaceError::Sampling(_) => anyhow::anyhow!("{}: {e}", args.terrain.display()),
        place::PlaceError::Species(_) => anyhow::anyhow!("{}: {e}", args.species.display()),
        other => other.into(),
    })?;
    limits.check_trees(placement.instances.len() as u64, "the forest's tree count")?;
    if placement.truncated && args.max_count.is_some() {
        super::warn(&format!(
            "--max-count {} reached: the forest does not fill the region",
            settings.max_count
        ));
    }
    if let Some(why) = place::diagnosis::diagnosis(&placement, &inputs.species, args.sea_level) {
        super::warn(&why);
    }
    let file = place::inputs::forest_file(&inputs, placement, args.seed, args.max_count, &out_dir);
    let bytes = instances::encode(&file).with_context(|| args.output.display().to_string())?;
    let size = bytes.len();
    outputs.set(forest_out, bytes);
    if let Some(dep) = dep_out {
        outputs.set(
            dep,
            depfile(&args.output, &inputs.dependencies)?.into_bytes(),
        );
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
        let per_tree = if n == 0 {
            "no trees".to_string()
        } else {
            format!("{:.2} bytes per tree", size as f64 / n as f64)
        };
        super::summary(&format!(
            "placed {n} trees ({}) on {:.1} ha -> {}, {per_tree}, in {:.2} s",
            per_species.join(", "),
            (r[2] - r[0]) * (r[3] - r[1]) / 1e4,
            args.output.display(),
            start.elapsed().as_secs_f64()
        ));
    }
    Ok(())
}
