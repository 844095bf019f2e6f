//! `texel bake`: glTF tree -> `.texel`.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use sha2::{Digest, Sha256};

use texel_forest::bake::{self, BakeSettings};
use texel_forest::formats::texel;
use texel_forest::import;
use texel_forest::output::{depfile, relative_path, write_atomic};
use texel_forest::volume::{DensityModel, SourceFile};

use crate::cli::{BakeArgs, DensityArg};

pub fn run(args: &BakeArgs, quiet: bool) -> anyhow::Result<()> {
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
    let model = import::load_surface(&args.input, "to bake")?;
    for w in &model.warnings {
        super::warn(w);
    }
    let mut baked =
        bake::bake(&model.mesh, &settings).with_context(|| args.input.display().to_string())?;

    let out_dir = super::output_dir(&args.output)?;
    let mut all = Sha256::new();
    baked.info.sources = model
        .sources
        .iter()
        .map(|s| {
            all.update(s.sha256);
            SourceFile {
                path: relative_path(&s.path, &out_dir),
                sha256: s.sha256,
                bytes: s.bytes,
            }
        })
        .collect();
    baked.info.inputs_sha256 = all.finalize().into();

    let bytes = texel::encode(&baked).with_context(|| args.output.display().to_string())?;
    write_atomic(&args.output, &bytes)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    if let Some(dep) = &args.depfile {
        let deps: Vec<PathBuf> = model.sources.iter().map(|s| s.path.clone()).collect();
        write_atomic(dep, depfile(&args.output, &deps).as_bytes())
            .with_context(|| format!("cannot write {}", dep.display()))?;
    }
    if !quiet {
        let l = &baked.levels[0];
        eprintln!(
            "texel: baked {} ({} triangles, {} foliage) -> {} {}x{}x{} cells of {:.3} m, {} levels, {}, {:.1} KiB in {:.2} s",
            args.input.display(),
            baked.info.triangles,
            baked.info.foliage_triangles,
            args.output.display(),
            l.dims[0],
            l.dims[1],
            l.dims[2],
            l.cell,
            baked.levels.len(),
            baked.info.density_model.name(),
            bytes.len() as f64 / 1024.0,
            start.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
