//! What `texel inspect FRAME.exr` reports of a frame `texel render` wrote: its size and where
//! it lies in the full frame, what wrote it, the camera it was seen from, and per channel the
//! range and mean of its values, with those that are not finite counted (a compositor's
//! filters spread a NaN over its neighbours, so a frame must have none).

use std::fmt::Write as _;
use std::path::Path;

use exr::image::FlatSamples;
use exr::meta::attribute::AttributeValue;
use glam::{Mat3, Vec3};
use serde::Serialize;

use super::printable;
use crate::compare::{CompareError, ExrLayer};
use crate::limits::Limits;
use crate::number::number;
use crate::render::film::SOFTWARE;

/// Whether the OpenEXR file at `path` was written by texel-forest (its first part's
/// `software` attribute says so): such a file is a frame, any other a heightmap. Reads the
/// headers alone; a file they cannot be read from is not a frame (its reader reports why).
pub fn written_by_texel(path: &Path) -> bool {
    let Ok(meta) = exr::meta::MetaData::read_from_file(path, false) else {
        return false;
    };
    meta.headers.first().is_some_and(|h| {
        h.own_attributes
            .software_name
            .as_ref()
            .is_some_and(|s| s.to_string().starts_with(SOFTWARE))
    })
}

#[derive(Serialize, Debug)]
pub struct FrameSummary {
    pub format: &'static str,
    /// The `software` attribute, if any.
    pub software: Option<String>,
    pub bytes: u64,
    /// The pixels the file holds (its data window): their top-left corner in the frame, and
    /// their size.
    pub origin: [i32; 2],
    pub width: usize,
    pub height: usize,
    /// The whole frame (the display window) the pixels are part of.
    pub frame_origin: [i32; 2],
    pub frame_width: usize,
    pub frame_height: usize,
    pub compression: String,
    /// Where the camera was and where it looked, from `worldToCamera`, if the file has it
    /// and it is invertible.
    pub camera: Option<CameraSummary>,
    pub channels: Vec<ChannelSummary>,
    /// The header's other attributes (Cryptomatte's among them), as text, each at most
    /// [`SHOWN`] characters.
    pub attributes: Vec<(String, String)>,
}

#[derive(Serialize, Debug)]
pub struct CameraSummary {
    pub eye: [f32; 3],
    /// Unit vector along the camera's +Z (OpenEXR's camera looks along it).
    pub forward: [f32; 3],
}

#[derive(Serialize, Debug)]
pub struct ChannelSummary {
    pub name: String,
    /// `half`, `float` or `uint`.
    pub sample_type: &'static str,
    /// Whether the channel holds Cryptomatte's object ids (hashes stored as float bits, whose
    /// range and mean mean nothing): its layer is one the header's Cryptomatte attributes
    /// name, and it is the layer's R or B.
    pub ids: bool,
    /// Over the finite values; `None` where there are none, and for ids.
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub mean: Option<f64>,
    /// Values that are NaN; `None` for ids, whose bits may read as NaN.
    pub nan: Option<u64>,
    /// Values that are infinite (depth `Z` is +infinity where nothing covers the pixel);
    /// `None` for ids.
    pub infinite: Option<u64>,
}

/// Characters of an attribute's value shown (a Cryptomatte manifest can run to megabytes).
pub const SHOWN: usize = 72;

/// The frame at `path`, read within `limits`.
pub fn summarize(path: &Path, limits: &Limits) -> Result<FrameSummary, CompareError> {
    let bytes = std::fs::metadata(path).map_or(0, |m| m.len());
    let exr = ExrLayer::read(path, limits, 0)?;
    let layer = exr.layer();
    let ([fx, fy], [frame_width, frame_height]) = exr.display_window();
    let attributes = &layer.attributes;
    let mut other: Vec<(String, String)> = attributes
        .other
        .iter()
        .map(|(k, v)| (printable(&k.to_string()), shown(v)))
        .collect();
    other.sort();
    // Cryptomatte's layers, by the names its attributes give them (`cryptomatte/<key>/name`).
    let mattes: Vec<String> = attributes
        .other
        .iter()
        .filter(|(k, _)| {
            let k = k.to_string();
            k.starts_with("cryptomatte/") && k.ends_with("/name")
        })
        .filter_map(|(_, v)| match v {
            AttributeValue::Text(t) => Some(t.to_string()),
            _ => None,
        })
        .collect();
    let channels = layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            let name = c.name.to_string();
            let ids = (name.ends_with(".R") || name.ends_with(".B"))
                && mattes.iter().any(|m| {
                    name.strip_prefix(m.as_str()).is_some_and(|rank| {
                        rank.len() == 4 && rank[..2].bytes().all(|b| b.is_ascii_digit())
                    })
                });
            channel(&name, &c.sample_data, ids)
        })
        .collect();
    Ok(FrameSummary {
        format: "OpenEXR frame",
        software: attributes
            .software_name
            .as_ref()
            .map(|s| printable(&s.to_string())),
        bytes,
        origin: [attributes.layer_position.x(), attributes.layer_position.y()],
        width: layer.size.width(),
        height: layer.size.height(),
        frame_origin: [fx, fy],
        frame_width,
        frame_height,
        compression: format!("{:?}", layer.encoding.compression),
        camera: attributes.world_to_camera.and_then(camera),
        channels,
        attributes: other,
    })
}

/// The eye and view direction of an OpenEXR `worldToCamera` (for row vectors, p' = p M).
fn camera(m: [f32; 16]) -> Option<CameraSummary> {
    // As column vectors, p' = A p + t, A the transpose of M's upper 3 x 3: its columns are
    // M's rows.
    let row = |i: usize| Vec3::new(m[4 * i], m[4 * i + 1], m[4 * i + 2]);
    let a = Mat3::from_cols(row(0), row(1), row(2));
    let t = row(3);
    let det = a.determinant();
    if !(det.is_finite() && det.abs() > 1e-12) {
        return None;
    }
    let inverse = a.inverse();
    let eye = -(inverse * t);
    let forward = (inverse * Vec3::Z).try_normalize()?;
    (eye.is_finite()).then(|| CameraSummary {
        eye: eye.to_array(),
        forward: forward.to_array(),
    })
}

fn channel(name: &str, samples: &FlatSamples, ids: bool) -> ChannelSummary {
    let sample_type = match samples {
        FlatSamples::F16(_) => "half",
        FlatSamples::F32(_) => "float",
        FlatSamples::U32(_) => "uint",
    };
    let (mut min, mut max, mut sum, mut n) = (f64::INFINITY, f64::NEG_INFINITY, 0.0f64, 0u64);
    let (mut nan, mut infinite) = (0u64, 0u64);
    for v in samples.values_as_f32() {
        if v.is_nan() {
            nan += 1;
        } else if v.is_infinite() {
            infinite += 1;
        } else {
            let v = f64::from(v);
            min = min.min(v);
            max = max.max(v);
            sum += v;
            n += 1;
        }
    }
    // Ids are bit patterns: some read as NaN or infinite, and none is a measurement.
    let (stats, nan, infinite) = if ids {
        (false, None, None)
    } else {
        (n > 0, Some(nan), Some(infinite))
    };
    ChannelSummary {
        name: printable(name),
        sample_type,
        ids,
        min: stats.then_some(min),
        max: stats.then_some(max),
        mean: stats.then(|| sum / n as f64),
        nan,
        infinite,
    }
}

/// An attribute's value as text, cut at [`SHOWN`] characters.
fn shown(value: &AttributeValue) -> String {
    let text = match value {
        AttributeValue::Text(t) => t.to_string(),
        other => format!("{other:?}"),
    };
    let text = printable(&text);
    match text.char_indices().nth(SHOWN) {
        Some((cut, _)) => format!("{}... ({} characters)", &text[..cut], text.chars().count()),
        None => text,
    }
}

pub fn to_text(s: &FrameSummary) -> String {
    let mut o = String::new();
    let by = s
        .software
        .as_ref()
        .map_or(String::new(), |w| format!(" (written by {w})"));
    let _ = writeln!(o, "format        {}{by}", s.format);
    let _ = writeln!(o, "size          {} bytes on disk", s.bytes);
    let _ = writeln!(
        o,
        "pixels        {} x {} at ({}, {}) of the frame {} x {} at ({}, {})",
        s.width,
        s.height,
        s.origin[0],
        s.origin[1],
        s.frame_width,
        s.frame_height,
        s.frame_origin[0],
        s.frame_origin[1]
    );
    let _ = writeln!(o, "compression   {}", s.compression);
    if let Some(c) = &s.camera {
        let v = |p: [f32; 3], digits| p.map(|x| number(x, digits).to_string()).join(", ");
        let _ = writeln!(
            o,
            "camera        eye ({}), looking along ({})",
            v(c.eye, 2),
            v(c.forward, 4)
        );
    }
    let _ = writeln!(
        o,
        "channels      {:<24} {:<6} {:>12} {:>12} {:>12} {:>8} {:>8}",
        "name", "type", "min", "max", "mean", "NaN", "infinite"
    );
    let value = |x: Option<f64>| x.map_or("-".to_string(), |x| number(x, 6).to_string());
    for c in &s.channels {
        let numbers = if c.ids {
            format!("{:>38} {:>8} {:>8}", "(Cryptomatte ids)", "-", "-")
        } else {
            format!(
                "{:>12} {:>12} {:>12} {:>8} {:>8}",
                value(c.min),
                value(c.max),
                value(c.mean),
                c.nan.unwrap_or(0),
                c.infinite.unwrap_or(0)
            )
        };
        let _ = writeln!(
            o,
            "              {:<24} {:<6} {numbers}",
            c.name, c.sample_type
        );
    }
    for (i, (k, v)) in s.attributes.iter().enumerate() {
        let label = if i == 0 { "attributes" } else { "" };
        let _ = writeln!(o, "{label:<14}{k} = {v}");
    }
    o
}
