//! `texel bake`: glTF tree -> `.texel`.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;

use texel_forest::bake::{self, BakeSettings};
use texel_forest::formats::texel;
use texel_forest::import;
use texel_forest::limits::Limits;
use texel_forest::number::number;
use texel_forest::output::{Outputs, depfile};
use texel_forest::volume::DensityModel;

use crate::cli::{BakeArgs, DensityArg};

pub fn run(args: &BakeArgs, limits: &Limits, quiet: bool) -> anyhow::Result<()> {
    let start = Instant::now();
    let settings = BakeSettings {
        resolution: args.resolution,
        fine: args.fine,
        density: match args.density {
            DensityArg::Transmittance => DensityModel::Transmittance,
            DensityArg::Occupancy => DensityModel::Occupancy,
        },
        gamma: args.gamma,
        foliage: args.foliage.clone(),
        wood: args.wood.clone(),
    };
    if args.gamma.is_some() && settings.density != DensityModel::Occupancy {
        anyhow::bail!("--gamma applies to --density occupancy only");
    }
    settings.validate()?;
    let mut outputs = Outputs::new(&[&args.input]);
    let texel_out = outputs.add("-o", &args.output)?;
    let dep_out = args
        .depfile
        .as_ref()
        .map(|d| outputs.add("--depfile", d))
        .transpose()?;

    let model = import::load_surface(&args.input, "to bake", limits)?;
    for w in &model.warnings {
        super::warn(w);
    }
    let read: Vec<PathBuf> = model.sources.iter().map(|s| s.path.clone()).collect();
    outputs.add_inputs(&read)?;
    // A texture the readers would refuse is refused before it is baked.
    let cells = bake::planned_cells(&model.mesh, &settings)
        .with_context(|| args.input.display().to_string())?;
    limits
        .check_cells(
            cells,
            &format!(
                "--resolution {}: the texture's cell count (all levels)",
                args.resolution
            ),
        )
        .with_context(|| args.input.display().to_string())?;
    let baked = bake::bake_model(&model, &settings, &super::directory_of(&args.output))
        .with_context(|| args.input.display().to_string())?;
    if let Some(why) = bake::lost_silhouette(&baked) {
        super::warn(&format!("{}: {why}", args.input.display()));
    }

    let bytes = texel::encode(&baked).with_context(|| args.output.display().to_string())?;
    let size = bytes.len();
    outputs.set(texel_out, bytes);
    if let Some(dep) = dep_out {
        outputs.set(dep, depfile(&args.output, &read)?.into_bytes());
    }
    outputs.commit()?;
    if !quiet {
        let l = &baked.levels[0];
        super::summary(&format!(
            "baked {} ({} triangles, {} foliage) -> {} {}x{}x{} cells of {} m, {} levels, {}, {:.1} KiB in {:.2} s",
            args.input.display(),
            baked.info.triangles,
            baked.info.foliage_triangles,
            args.output.display(),
            l.dims[0],
            l.dims[1],
            l.dims[2],
            number(l.cell, 3),
            baked.levels.len(),
            baked.info.density_model.name(),
            size as f64 / 1024.0,
            start.elapsed().as_secs_f64()
        ));
    }
    Ok(())
}
