//! Readers of the plain heightmap images: grey PNG (8 or 16 bits), OpenEXR (one float
//! channel) and raw `.r16`. Each checks the size its header claims before decoding pixels.

use std::io::Cursor;
use std::path::Path;

use super::{HeightmapError, Raster, Samples, check_size, error};
use crate::limits::Limits;

/// A PNG of one grey channel, 8 or 16 bits (16-bit samples are big-endian in the file).
pub(crate) fn png(file: &Path, bytes: &[u8], limits: &Limits) -> Result<Raster, HeightmapError> {
    let bad = |e: png::DecodingError| error(file, "", format!("not a readable PNG: {e}"));
    // The project's own pixel limit decides the size; png's byte limit would refuse first
    // with a less helpful message.
    let mut decoder =
        png::Decoder::new_with_limits(Cursor::new(bytes), png::Limits { bytes: usize::MAX });
    decoder.set_transformations(png::Transformations::IDENTITY);
    let mut reader = decoder.read_info().map_err(bad)?;
    let info = reader.info();
    let (width, height) = (info.width as usize, info.height as usize);
    let (color, depth) = (info.color_type, info.bit_depth);
    if color != png::ColorType::Grayscale {
        return Err(error(
            file,
            "colour type",
            format!(
                "{color:?} with {} channel(s): a heightmap PNG must be one grey channel",
                color.samples()
            ),
        ));
    }
    let max = match depth {
        png::BitDepth::Eight => 255,
        png::BitDepth::Sixteen => 65535,
        d => {
            return Err(error(
                file,
                "bit depth",
                format!("{} bits: a heightmap PNG must have 8 or 16", d as u8),
            ));
        }
    };
    check_size(file, width as u64, height as u64, limits)?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| error(file, "", "the image is too large to decode"))?;
    let mut buf = vec![0u8; size];
    let frame = reader.next_frame(&mut buf).map_err(bad)?;
    let line = frame.line_size;
    let values = if max == 255 {
        (0..height)
            .flat_map(|r| buf[r * line..r * line + width].iter().map(|&v| v as u16))
            .collect()
    } else {
        (0..height)
            .flat_map(|r| {
                buf[r * line..r * line + 2 * width]
                    .chunks_exact(2)
                    .map(|b| u16::from_be_bytes([b[0], b[1]]))
            })
            .collect()
    };
    Ok(Raster {
        width,
        height,
        samples: Samples::Integer(values, max),
        geo: None,
        notes: vec![],
    })
}

/// An OpenEXR's first layer: the channel `Y`, else `R`, else the first (channels are listed in
/// name order), as metres.
pub(crate) fn exr(file: &Path, bytes: &[u8], limits: &Limits) -> Result<Raster, HeightmapError> {
    let bad = |e: exr::error::Error| error(file, "", format!("not a readable OpenEXR: {e}"));
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(bad)?;
    let header = meta
        .headers
        .first()
        .ok_or_else(|| error(file, "", "it has no layers"))?;
    let size = header.layer_size;
    check_size(file, size.width() as u64, size.height() as u64, limits)?;
    let channels = header.channels.list.len() as u64;
    crate::limits::check_memory(
        (size.area() as u64).saturating_mul(4 * channels),
        "the heightmap's channels",
    )
    .map_err(|e| error(file, "", e))?;
    use exr::prelude::{ReadChannels, ReadLayers};
    let image = exr::image::read::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        // On this thread, as `compare` reads: a panic inside exr unwinds to us.
        .non_parallel()
        .from_buffered(Cursor::new(bytes))
        .map_err(bad)?;
    let layer = image.layer_data;
    let list = &layer.channel_data.list;
    let names: Vec<String> = list.iter().map(|c| c.name.to_string()).collect();
    let pick = ["Y", "R"]
        .iter()
        .find_map(|n| names.iter().position(|c| c == n))
        .unwrap_or(0);
    let channel = list
        .get(pick)
        .ok_or_else(|| error(file, "channels", "the layer has no channels"))?;
    let mut notes = vec![];
    if names.len() > 1 {
        notes.push(format!(
            "{}: heights from channel {} of {}",
            file.display(),
            names[pick],
            names.join(", ")
        ));
    }
    let values: Vec<f32> = channel.sample_data.values_as_f32().collect();
    Ok(Raster {
        width: layer.size.width(),
        height: layer.size.height(),
        samples: Samples::Metres(values),
        geo: None,
        notes,
    })
}

/// Raw little-endian u16 samples of a square heightmap (Unreal and Unity's `.r16`), its side
/// the square root of the sample count.
pub(crate) fn r16(file: &Path, bytes: &[u8], limits: &Limits) -> Result<Raster, HeightmapError> {
    let n = bytes.len() as u64 / 2;
    let side = n.isqrt();
    if !bytes.len().is_multiple_of(2) || side * side != n {
        return Err(error(
            file,
            "",
            format!(
                "{} bytes is not a square of 16-bit samples (a raw heightmap has no header: \
                 its side is found from its length)",
                bytes.len()
            ),
        ));
    }
    check_size(file, side, side, limits)?;
    let values = bytes
        .chunks_exact(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]))
        .collect();
    Ok(Raster {
        width: side as usize,
        height: side as usize,
        samples: Samples::Integer(values, 65535),
        geo: None,
        notes: vec![],
    })
}
