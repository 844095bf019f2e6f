//! `texel inspect`: a summary of any texel-forest file, or a picture of it.

use std::path::Path;

use anyhow::{Context, bail};
use sha2::{Digest, Sha256};

use texel_forest::formats::{container, instances, texel};
use texel_forest::inspect::{instances as forest_view, pictures, texel as summary};
use texel_forest::output::write_atomic;
use texel_forest::terrain::Terrain;

use crate::cli::{AxisArg, InspectArgs};

fn axis_index(a: AxisArg) -> usize {
    match a {
        AxisArg::X => 0,
        AxisArg::Y => 1,
        AxisArg::Z => 2,
    }
}

/// `y=16` -> (1, 16).
fn parse_slice(s: &str) -> anyhow::Result<(usize, usize)> {
    let bad = || anyhow::anyhow!("--slice {s:?}: expected AXIS=INDEX such as y=16");
    let (axis, index) = s.split_once('=').ok_or_else(bad)?;
    let axis = match axis.trim().to_ascii_lowercase().as_str() {
        "x" => 0,
        "y" => 1,
        "z" => 2,
        _ => return Err(bad()),
    };
    Ok((axis, index.trim().parse().map_err(|_| bad())?))
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

fn write_png(out: &Path, image: &image::RgbImage) -> anyhow::Result<()> {
    write_atomic(out, &pictures::png_bytes(image))
        .with_context(|| format!("cannot write {}", out.display()))
}

pub fn run(args: &InspectArgs) -> anyhow::Result<()> {
    let file = &args.file;
    let bytes = std::fs::read(file).with_context(|| format!("cannot read {}", file.display()))?;
    if bytes.starts_with(instances::MAGIC) {
        return run_instances(args, &bytes);
    }
    if args.map {
        bail!(
            "--map draws .instances files; {} is not one",
            file.display()
        );
    }
    let texel = texel::decode(&bytes).with_context(|| file.display().to_string())?;
    let wants_picture = args.slice.is_some() || args.projection.is_some();
    if !wants_picture {
        if args.output.is_some() {
            bail!("-o names a picture: give --slice or --projection with it");
        }
        let preamble = container::preamble(&bytes).unwrap_or(container::Preamble {
            major: texel::MAJOR,
            minor: texel::MINOR,
            header_len: 0,
            raw_len: 0,
            stored_len: 0,
        });
        let facts = summary::FileFacts {
            bytes: bytes.len() as u64,
            minor: preamble.minor,
            raw_bytes: preamble.raw_len,
        };
        let s = summary::summarize(&texel, facts);
        return print_summary(&s, args.json, summary::to_text);
    }
    let Some(out) = &args.output else {
        bail!("--slice and --projection write a picture: give -o FILE.png");
    };
    if args.level >= texel.levels.len() {
        bail!(
            "--level {}: {} has levels 0 to {}",
            args.level,
            file.display(),
            texel.levels.len() - 1
        );
    }
    let image = match (&args.slice, args.projection) {
        (Some(s), _) => {
            let (axis, index) = parse_slice(s)?;
            let n = texel.levels[args.level].dims[axis];
            if index >= n {
                bail!(
                    "--slice {s}: level {} has cells 0 to {} along {}",
                    args.level,
                    n - 1,
                    ["x", "y", "z"][axis]
                );
            }
            pictures::slice(&texel, args.level, axis, index)
        }
        (None, Some(axis)) => pictures::projection(&texel, args.level, axis_index(axis)),
        (None, None) => bail!("--slice or --projection names the picture to draw"),
    };
    write_png(out, &image)
}

fn run_instances(args: &InspectArgs, bytes: &[u8]) -> anyhow::Result<()> {
    let file = &args.file;
    if args.slice.is_some() || args.projection.is_some() {
        bail!(
            "--slice and --projection draw .texel files; {} is a forest (use --map)",
            file.display()
        );
    }
    let forest = instances::decode(bytes).with_context(|| file.display().to_string())?;
    if !args.map {
        if args.output.is_some() {
            bail!("-o names a picture: give --map with it");
        }
        let s = forest_view::summarize(&forest, bytes.len() as u64);
        return print_summary(&s, args.json, forest_view::to_text);
    }
    let Some(out) = &args.output else {
        bail!("--map writes a picture: give -o FILE.png");
    };
    // The terrain, found relative to the forest file, shades the map; a missing or changed
    // terrain is worth a warning, not a failure.
    let recorded = &forest.info.terrain[0];
    let path = file.parent().unwrap_or(Path::new("")).join(&recorded.path);
    let terrain = match std::fs::read(&path) {
        Err(e) => {
            super::warn(&format!(
                "{}: terrain {} unreadable ({e}); map without relief",
                file.display(),
                path.display()
            ));
            None
        }
        Ok(b) => {
            if <[u8; 32]>::from(Sha256::digest(&b)) != recorded.sha256 {
                super::warn(&format!(
                    "{}: terrain {} changed since placement",
                    file.display(),
                    path.display()
                ));
            }
            Some(Terrain::load(&path)?)
        }
    };
    write_png(out, &forest_view::map(&forest, terrain.as_ref(), 1024))
}
