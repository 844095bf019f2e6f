//! `texel inspect`: a summary of any texel-forest file, or a picture of it.

use anyhow::{Context, bail};

use texel_forest::formats::texel;
use texel_forest::inspect::{pictures, texel as summary};
use texel_forest::output::write_atomic;

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

pub fn run(args: &InspectArgs) -> anyhow::Result<()> {
    let file = &args.file;
    let bytes = std::fs::read(file).with_context(|| format!("cannot read {}", file.display()))?;
    let texel = texel::decode(&bytes).with_context(|| file.display().to_string())?;

    let wants_picture = args.slice.is_some() || args.projection.is_some();
    if !wants_picture {
        if args.output.is_some() {
            bail!("-o names a picture: give --slice or --projection with it");
        }
        let s = summary::summarize(&texel, bytes.len() as u64);
        let text = if args.json {
            serde_json::to_string_pretty(&s)? + "\n"
        } else {
            summary::to_text(&s)
        };
        return super::print(&text);
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
    let image = if let Some(s) = &args.slice {
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
    } else {
        pictures::projection(
            &texel,
            args.level,
            axis_index(args.projection.expect("checked above")),
        )
    };
    write_atomic(out, &pictures::png_bytes(&image))
        .with_context(|| format!("cannot write {}", out.display()))
}
