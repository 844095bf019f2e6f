//! `texel inspect`: a summary of any texel-forest file, or a picture of it.

use std::path::Path;

use anyhow::{Context, bail};

use texel_forest::formats::{container, instances, texel};
use texel_forest::input::{self, MAX_GLTF};
use texel_forest::inspect::{FileFacts, Kind};
use texel_forest::inspect::{
    frame as frame_view, instances as forest_view, pictures, terrain as terrain_view,
    texel as summary,
};
use texel_forest::limits::Limits;
use texel_forest::output::{OutputId, Outputs};
use texel_forest::place::PlaceSettings;
use texel_forest::provenance::{self, Check};
use texel_forest::species::SpeciesFile;
use texel_forest::terrain::Terrain;

use crate::cli::InspectArgs;

/// The picture a forest or a terrain (`kind`) is asked for, if any: `--map` with `-o`, never
/// one without the other, and none of the texture's pictures.
fn map_output(
    args: &InspectArgs,
    picture: Option<OutputId>,
    kind: &str,
) -> anyhow::Result<Option<OutputId>> {
    if args.slice.is_some() || args.projection.is_some() {
        bail!(
            "--slice and --projection draw .texel files; {} is {kind} (use --map)",
            args.file.display()
        );
    }
    match (picture, args.map) {
        (None, true) => bail!("--map writes a picture: give -o FILE.png"),
        (Some(_), false) => bail!("-o names a picture: give --map with it"),
        (picture, _) => Ok(picture),
    }
}

/// A summary as JSON or as text.
fn print_summary<S: serde::Serialize>(
    summary: &S,
    json: bool,
    text: fn(&S) -> String,
) -> anyhow::Result<()> {
    let out = if json {
        serde_json::to_string_pretty(summary)? + "\n"
    } else {
        text(summary)
    };
    super::print(&out)
}

/// Writes the picture to `-o` (planned before the work, so a bad path fails first).
fn write_png(mut outputs: Outputs, id: OutputId, image: &image::RgbImage) -> anyhow::Result<()> {
    outputs.set(id, texel_forest::png::encode(image));
    Ok(outputs.commit()?)
}

/// A frame `texel render` wrote: its summary (it has no picture but itself).
fn run_frame(args: &InspectArgs, limits: &Limits, picture: Option<OutputId>) -> anyhow::Result<()> {
    let file = &args.file;
    if args.slice.is_some() || args.projection.is_some() || args.map || picture.is_some() {
        bail!(
            "{} is a frame texel render wrote: it is its own picture (--slice, --projection and --map draw other files)",
            file.display()
        );
    }
    if args.species.is_some()
        || args.cell.is_some()
        || args.region.is_some()
        || args.sea_level.is_some()
    {
        bail!(
            "{} is a frame texel render wrote: --species, --cell, --region and --sea-level judge terrains",
            file.display()
        );
    }
    let summary = frame_view::summarize(file, limits)?;
    print_summary(&summary, args.json, frame_view::to_text)
}

/// What a file is: by its magic, else by its name.
pub fn run(args: &InspectArgs, limits: &Limits) -> anyhow::Result<()> {
    let file = &args.file;
    let mut outputs = Outputs::new(&[file]);
    let picture = args
        .output
        .as_ref()
        .map(|o| outputs.add("-o", o))
        .transpose()?;
    let head = input::read_framed(file, 16, |_| None)?;
    match Kind::of(&head, file.extension())
        .with_context(|| format!("{}: not a .texel, .instances or glTF terrain file, nor a heightmap image or a rendered frame (its first bytes match none of them)", file.display()))?
    {
        Kind::Texel => run_texel(args, limits, outputs, picture),
        Kind::Instances => run_instances(args, limits, outputs, picture),
        // An OpenEXR is a heightmap unless `texel render` wrote it (and no heightmap flag
        // says to read it as one).
        Kind::Terrain
            if head.starts_with(&texel_forest::terrain::heightmap::EXR_MAGIC)
                && args.heightmap.terrain_size.is_none()
                && args.heightmap.height_range.is_none()
                && frame_view::written_by_texel(file) =>
        {
            run_frame(args, limits, picture)
        }
        Kind::Terrain => run_terrain(args, limits, outputs, picture),
    }
}

fn run_texel(
    args: &InspectArgs,
    limits: &Limits,
    outputs: Outputs,
    picture: Option<OutputId>,
) -> anyhow::Result<()> {
    let file = &args.file;
    if args.map {
        bail!(
            "--map draws forests and terrains; {} is a texture (use --projection)",
            file.display()
        );
    }
    let bytes = container::read_file(file)?;
    let texel = texel::decode_with(&bytes, limits).with_context(|| file.display().to_string())?;
    let wants_picture = args.slice.is_some() || args.projection.is_some();
    let Some(out) = picture else {
        if wants_picture {
            bail!("--slice and --projection write a picture: give -o FILE.png");
        }
        let s = summary::summarize(&texel, FileFacts::of(&bytes));
        return print_summary(&s, args.json, summary::to_text);
    };
    if args.level >= texel.levels.len() {
        bail!(
            "--level {}: {} has levels 0 to {}",
            args.level,
            file.display(),
            texel.levels.len() - 1
        );
    }
    let image = match (args.slice, args.projection) {
        (Some((axis, index)), _) => {
            let n = texel.levels[args.level].dims[axis];
            if index >= n {
                bail!(
                    "--slice {}={index}: level {} has cells 0 to {} along {}",
                    ["x", "y", "z"][axis],
                    args.level,
                    n - 1,
                    ["x", "y", "z"][axis]
                );
            }
            pictures::slice(&texel, args.level, axis, index)
        }
        (None, Some(axis)) => pictures::projection(&texel, args.level, axis.index()),
        (None, None) => bail!("-o names a picture: give --slice or --projection with it"),
    };
    write_png(outputs, out, &image)
}

fn run_instances(
    args: &InspectArgs,
    limits: &Limits,
    outputs: Outputs,
    picture: Option<OutputId>,
) -> anyhow::Result<()> {
    let file = &args.file;
    let picture = map_output(args, picture, "a forest")?;
    let bytes = container::read_file(file)?;
    let forest = instances::decode_stored_with(&bytes, limits)
        .with_context(|| file.display().to_string())?;
    // The file is not needed once decoded, and it can be half the size of the trees.
    let facts = FileFacts::of(&bytes);
    drop(bytes);
    let Some(out) = picture else {
        let s = forest_view::summarize(&forest, facts);
        return print_summary(&s, args.json, forest_view::to_text);
    };
    // The terrain, found relative to the forest file, shades the map; a missing or changed
    // terrain is worth a warning, not a failure.
    let dir = file.parent().unwrap_or(Path::new(""));
    let recorded = &forest.info.terrain[0];
    let path = dir.join(&recorded.path);
    let options = forest.heightmap.unwrap_or_default();
    let terrain = match provenance::check(&path, &recorded.sha256, "placement", MAX_GLTF) {
        Check::Unreadable(e) => {
            super::warn(&format!("{}: {e}; map without relief", file.display()));
            None
        }
        Check::Changed(e) => {
            super::warn(&format!("{}: terrain {e}", file.display()));
            Some(Terrain::load_with(&path, &options, limits)?)
        }
        Check::Same => Some(Terrain::load_with(&path, &options, limits)?),
    };
    write_png(
        outputs,
        out,
        &forest_view::map(&forest, terrain.as_ref(), 1024),
    )
}

fn run_terrain(
    args: &InspectArgs,
    limits: &Limits,
    outputs: Outputs,
    picture: Option<OutputId>,
) -> anyhow::Result<()> {
    let file = &args.file;
    let picture = map_output(args, picture, "a terrain")?;
    let species = args.species.as_deref().map(SpeciesFile::load).transpose()?;
    let terrain = Terrain::load_with(file, &args.heightmap.options(), limits)?;
    for w in &terrain.model.warnings {
        super::warn(w);
    }
    let settings = PlaceSettings {
        region: args.region,
        cell: args.cell,
        sea_level: args.sea_level,
        ..PlaceSettings::default()
    };
    let base = super::directory_of(file);
    let (sources, _) = provenance::record(&terrain.model.sources, &base);
    let (summary, ground) =
        terrain_view::summarize(&terrain, species.as_ref(), &settings, sources)?;
    match picture {
        None => print_summary(&summary, args.json, terrain_view::to_text),
        Some(out) => write_png(outputs, out, &terrain_view::attribute_maps(&ground)),
    }
}
