//! `texel animate`: a frame sequence's PNG previews as one animated PNG, to look at a fly-in
//! without a video tool.

use anyhow::{Context, bail};

use texel_forest::input::{self, MAX_IMAGE};
use texel_forest::limits::{Limits, check_memory};
use texel_forest::output::Outputs;

use crate::cli::AnimateArgs;

pub fn run(args: &AnimateArgs, limits: &Limits, quiet: bool) -> anyhow::Result<()> {
    let inputs: Vec<&std::path::Path> = args.frames.iter().map(|p| p.as_path()).collect();
    let mut outputs = Outputs::new(&inputs);
    let id = outputs.add("-o", &args.output)?;
    let mut frames = Vec::with_capacity(args.frames.len());
    let mut bytes_held = 0u64;
    // The first frame's size, as read: every frame must have it.
    let mut size: Option<(u32, u32)> = None;
    for path in &args.frames {
        let bytes = input::read_bounded(path, MAX_IMAGE, "PNG frame")
            .with_context(|| format!("{}: cannot read", path.display()))?;
        let format = image::guess_format(&bytes).ok();
        if format != Some(image::ImageFormat::Png) {
            bail!("{}: not a PNG", path.display());
        }
        let mut reader =
            image::ImageReader::with_format(std::io::Cursor::new(&bytes), image::ImageFormat::Png);
        let (w, h) = reader
            .into_dimensions()
            .with_context(|| format!("{}: cannot read the PNG header", path.display()))?;
        limits.check_pixels(
            u64::from(w) * u64::from(h),
            &format!("{}'s pixel count", path.display()),
        )?;
        let first = *size.get_or_insert((w, h));
        if first != (w, h) {
            bail!(
                "{}: is {w}x{h}, but {} is {}x{}: every frame must be the same size",
                path.display(),
                args.frames[0].display(),
                first.0,
                first.1
            );
        }
        // The size the frame is kept at, checked before it is decoded or scaled.
        let (kept_w, kept_h) = match args.width {
            Some(width) if width != w => {
                let height = scaled_height(w, h, width);
                limits.check_pixels(
                    u64::from(width) * u64::from(height),
                    &format!("the frames' pixel count at --width {width} ({width}x{height})"),
                )?;
                (width, height)
            }
            _ => (w, h),
        };
        bytes_held += 3 * u64::from(kept_w) * u64::from(kept_h);
        // Decoding holds up to 8 bytes a pixel (16-bit RGBA), then the 3 of its RGB copy.
        check_memory(
            bytes_held + 11 * u64::from(w) * u64::from(h),
            &format!("{} frames of {kept_w}x{kept_h}", frames.len() + 1),
        )?;
        reader =
            image::ImageReader::with_format(std::io::Cursor::new(&bytes), image::ImageFormat::Png);
        // Pixels and memory are judged above, by --max-pixels and what the machine has; the
        // decoder's own fixed allowance (512 MB) would refuse a frame they allow.
        reader.no_limits();
        let frame = reader
            .decode()
            .with_context(|| format!("{}: cannot decode", path.display()))?
            .into_rgb8();
        let frame = match args.width {
            // A triangle filter over the whole footprint of each new pixel: no aliasing of
            // the canopy's fine detail when shrinking, and the same bytes every time.
            Some(width) if width != w => image::imageops::resize(
                &frame,
                kept_w,
                kept_h,
                image::imageops::FilterType::Triangle,
            ),
            _ => frame,
        };
        frames.push(frame);
    }
    let png = texel_forest::png::encode_animation(&frames, args.fps)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.output.display()))?;
    let bytes = png.len();
    outputs.set(id, png);
    outputs.commit()?;
    if !quiet {
        super::summary(&format!(
            "{} frames at {} fps -> {} ({} KiB)",
            frames.len(),
            args.fps,
            args.output.display(),
            bytes >> 10
        ));
    }
    Ok(())
}

/// The height a `w` x `h` frame keeps its shape at when scaled to `width`, rounded.
fn scaled_height(w: u32, h: u32, width: u32) -> u32 {
    ((u64::from(h) * u64::from(width) + u64::from(w) / 2) / u64::from(w)).clamp(1, 65535) as u32
}
