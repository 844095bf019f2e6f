//! `texel compare --temporal`: the flicker of a frame sequence, as text or JSON.

use std::path::{Path, PathBuf};

use serde::Serialize;
use texel_forest::limits::Limits;
use texel_forest::temporal::{Change, Mask, Pair, measure_files};

use crate::cli::CompareArgs;

/// A pair's measures in JSON, beside the files they come from.
#[derive(Serialize)]
struct PairEntry<'a> {
    from: &'a Path,
    to: &'a Path,
    #[serde(flatten)]
    pair: &'a Pair,
}

pub fn run(frames: &[PathBuf], args: &CompareArgs, limits: &Limits) -> anyhow::Result<()> {
    let mask = args.mask_channel.as_deref();
    let outside = args.exclude_channel.as_deref();
    let sequence = measure_files(
        frames,
        Mask {
            inside: mask,
            outside,
        },
        args.depth_tolerance,
        limits,
    )?;
    if args.json {
        let pairs: Vec<PairEntry> = sequence
            .pairs
            .iter()
            .zip(frames.windows(2))
            .map(|(pair, files)| PairEntry {
                from: &files[0],
                to: &files[1],
                pair,
            })
            .collect();
        let json = serde_json::json!({
            "frames": frames,
            "mask_channel": mask,
            "exclude_channel": outside,
            "depth_tolerance": args.depth_tolerance,
            "pairs": pairs,
            "total": sequence.total,
        });
        super::print(&format!("{}\n", serde_json::to_string_pretty(&json)?))?;
        return Ok(());
    }
    let mut text = format!(
        "change of R, G, B from frame to frame, {} frames, {} (depth tolerance {})\n",
        frames.len(),
        match (mask, outside) {
            (None, None) => "every pixel".to_string(),
            (Some(m), None) => format!("inside {m} > 0.5"),
            (None, Some(o)) => format!("outside {o} > 0.5"),
            (Some(m), Some(o)) => format!("inside {m} > 0.5 and outside {o} > 0.5"),
        },
        args.depth_tolerance
    );
    for (pair, files) in sequence.pairs.iter().zip(frames.windows(2)) {
        text += &format!(
            "{} -> {}, {}:\n",
            files[0].display(),
            files[1].display(),
            if pair.camera_moved {
                "camera moved (reprojected)"
            } else {
                "same camera (pixel for pixel)"
            }
        );
        text += &describe(&pair.change);
    }
    let n = sequence.pairs.len();
    text += &format!("all {n} pair{}:\n", if n == 1 { "" } else { "s" });
    text += &describe(&sequence.total);
    super::print(&text)
}

fn describe(c: &Change) -> String {
    let r = &c.rejected;
    let mut s = match (c.mean_absolute, c.rms) {
        (Some(mean), Some(rms)) => format!(
            "  mean |change| {mean:.6}, rms {rms:.6} over {} of {} pixels\n",
            c.measured, c.inside_mask
        ),
        _ => format!(
            "  no pixel measured (of {}): no change to report\n",
            c.inside_mask
        ),
    };
    if r.total() > 0 {
        s += &format!(
            "  rejected: {} no depth (sky), {} outside the next frame, {} depth mismatch \
             (hidden or uncovered), {} not finite\n",
            r.no_depth, r.outside_frame, r.depth_mismatch, r.non_finite
        );
    }
    s
}
