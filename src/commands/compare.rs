//! `texel compare`: the error of a render against a reference, as text or JSON, with an
//! optional false-colour picture of where it lies.

use texel_forest::compare::{Rgba, block_mask, check_same_window, compare, heatmap, read_mask};
use texel_forest::limits::Limits;
use texel_forest::output::Outputs;

use crate::cli::CompareArgs;

/// Status when `--fail-above` is exceeded: distinct from 1 (bad input) and 2 (bad flags).
pub const TOO_DIFFERENT: u8 = 3;

/// Returned (as an error) when the images differ by more than `--fail-above` allows.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct TooDifferent(pub String);

pub fn run(args: &CompareArgs, limits: &Limits) -> anyhow::Result<()> {
    let (image, reference) = match (&args.temporal, &args.image, &args.reference) {
        (Some(frames), _, _) => return super::temporal::run(frames, args, limits),
        (None, Some(image), Some(reference)) => (image, reference),
        // clap requires both images unless --temporal is given.
        _ => anyhow::bail!("compare needs two images, or --temporal and two or more frames"),
    };
    let mut inputs = vec![image.as_path(), reference.as_path()];
    inputs.extend(args.mask.as_deref());
    let mut outputs = Outputs::new(&inputs);
    let heatmap_out = args
        .heatmap
        .as_ref()
        .map(|h| outputs.add("--heatmap", h))
        .transpose()?;
    let a = Rgba::read(image, limits)?;
    let b = Rgba::read(reference, limits)?;
    check_same_window(&a, image, &b, reference)?;
    let all = compare(&a, &b, |_| true);
    let masked = match &args.mask {
        Some(path) => {
            let inside = read_mask(
                path,
                (a.width, a.height),
                args.mask_channel.as_deref().unwrap_or("A"),
                limits,
            )?;
            let inside = block_mask(&inside, (a.width, a.height), args.mask_block as usize);
            Some(compare(&a, &b, |i| inside[i]))
        }
        None => None,
    };
    let scale = args.scale.map_or(all.heatmap_scale(), |s| {
        s.clamp(0.0, f32::MAX as f64) as f32
    });
    if let Some(id) = heatmap_out {
        // A zero scale (identical images) draws everything black rather than dividing by 0.
        let picture = heatmap(&a, &b, scale.max(f32::MIN_POSITIVE));
        outputs.set(id, texel_forest::png::encode(&picture));
        outputs.commit()?;
    }
    if args.json {
        let json = serde_json::json!({
            "image": image,
            "reference": reference,
            "width": a.width,
            "height": a.height,
            "all": all,
            "mask": masked,
            "heatmap_scale": args.heatmap.as_ref().map(|_| scale),
        });
        super::print(&format!("{}\n", serde_json::to_string_pretty(&json)?))?;
    } else {
        let mut text = format!(
            "{} against the reference {}: {}x{}\n",
            image.display(),
            reference.display(),
            a.width,
            a.height
        );
        text += &all.to_text("all");
        if let Some(m) = &masked {
            text += &m.to_text("inside the mask");
        }
        if let Some(path) = &args.heatmap {
            text += &format!(
                "heatmap: {} (brightest = error {scale:.6} or more)\n",
                path.display()
            );
        }
        super::print(&text)?;
    }
    if let Some(limit) = args.fail_above
        && let Some(why) = all.fails(limit)
    {
        return Err(TooDifferent(format!(
            "{} against {}: {why} (--fail-above)",
            image.display(),
            reference.display()
        ))
        .into());
    }
    Ok(())
}
