//! TIFF and GeoTIFF heightmaps through the `tiff` crate: one grey channel of 8/16-bit
//! unsigned integers (scaled by `--height-range`), 16-bit signed integers or 32/64-bit floats
//! (metres as stored). The GeoTIFF tags, where present, give the ground spacing; units that
//! are not metres are refused unless `--terrain-size` says the extent instead.

use std::io::Cursor;
use std::path::Path;

use tiff::decoder::{Decoder, DecodingResult};
use tiff::tags::Tag;

use super::{HeightmapError, HeightmapOptions, Raster, Samples, check_size, error};
use crate::limits::Limits;

/// Where the samples lie, from the GeoTIFF tags: spacing east and south (m) and the
/// north-west sample's offset from the raster's north-west corner (x = 0, z = 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Placement {
    pub spacing: [f64; 2],
    pub first: [f64; 2],
}

/// GeoKey ids this reader looks at (GeoTIFF 1.1, section 7).
const MODEL_TYPE: u16 = 1024;
const RASTER_TYPE: u16 = 1025;
const PROJ_LINEAR_UNITS: u16 = 3076;
const VERTICAL_UNITS: u16 = 4099;
/// EPSG's metre (Linear_Meter).
const METRE: u16 = 9001;
/// GTModelTypeGeoKey: geographic latitude-longitude.
const GEOGRAPHIC: u16 = 2;
/// GTRasterTypeGeoKey: RasterPixelIsPoint (1 is RasterPixelIsArea, the default).
const PIXEL_IS_POINT: u16 = 2;
/// GDAL's no-data value, an ASCII number (how GDAL and the GIS tools built on it mark the
/// samples a DEM has no height for).
const GDAL_NODATA: u16 = 42113;

pub(crate) fn read(
    file: &Path,
    bytes: &[u8],
    options: &HeightmapOptions,
    limits: &Limits,
) -> Result<Raster, HeightmapError> {
    let bad = |e: tiff::TiffError| error(file, "", format!("not a readable TIFF: {e}"));
    let mut tiff_limits = tiff::decoder::Limits::default();
    // Our pixel limit decides; tiff's own 256 MiB buffer limit would refuse first.
    tiff_limits.decoding_buffer_size = usize::MAX;
    tiff_limits.intermediate_buffer_size = usize::MAX;
    let mut d = Decoder::new(Cursor::new(bytes))
        .map_err(bad)?
        .with_limits(tiff_limits);
    let (width, height) = d.dimensions().map_err(bad)?;
    match d.colortype().map_err(bad)? {
        tiff::ColorType::Gray(_) => {}
        other => {
            return Err(error(
                file,
                "PhotometricInterpretation",
                format!("{other:?}: a heightmap TIFF must be one grey channel"),
            ));
        }
    }
    check_size(file, width as u64, height as u64, limits)?;
    let mut notes = vec![];
    let geo = georeference(file, &mut d, options, &mut notes)?;
    let nodata = no_data(file, &mut d)?;
    let samples = match d.read_image().map_err(bad)? {
        DecodingResult::U8(v) => Samples::Integer(v.into_iter().map(u16::from).collect(), 255),
        DecodingResult::U16(v) => Samples::Integer(v, 65535),
        DecodingResult::I16(v) => Samples::Metres(v.into_iter().map(f32::from).collect()),
        DecodingResult::F32(v) => Samples::Metres(v),
        DecodingResult::F64(v) => Samples::Metres(v.into_iter().map(|h| h as f32).collect()),
        _ => {
            return Err(error(
                file,
                "SampleFormat",
                "unsupported sample type: a heightmap TIFF holds 8 or 16-bit unsigned integers, \
                 16-bit signed integers or 32/64-bit floats",
            ));
        }
    };
    if let Some(nodata) = nodata {
        refuse_nodata(file, &samples, width as usize, nodata)?;
    }
    Ok(Raster {
        width: width as usize,
        height: height as usize,
        samples,
        geo,
        notes,
    })
}

/// The GDAL_NODATA value, where the tag is present. A value that is no number is refused:
/// the file says some samples are holes, and which they are cannot be known. "nan" is a
/// number here (GDAL writes it for float rasters), and NaN samples are refused as not finite.
fn no_data(file: &Path, d: &mut Decoder<Cursor<&[u8]>>) -> Result<Option<f64>, HeightmapError> {
    const FIELD: &str = "GDAL_NODATA (42113)";
    let Some(value) = d
        .find_tag(Tag::Unknown(GDAL_NODATA))
        .map_err(|e| error(file, FIELD, e))?
    else {
        return Ok(None);
    };
    let text = value
        .into_string()
        .map_err(|e| error(file, FIELD, format!("not ASCII text: {e}")))?;
    let trimmed = text.trim().trim_end_matches('\0').trim();
    trimmed.parse::<f64>().map(Some).map_err(|_| {
        error(
            file,
            FIELD,
            format!("{trimmed:?} is not a number, so which samples are holes is unknown"),
        )
    })
}

/// Refuses a raster with a sample equal to its GDAL_NODATA value: a hole would become a pit
/// (or a spike) as deep as the sentinel, and trees would be placed down it.
fn refuse_nodata(
    file: &Path,
    samples: &Samples,
    width: usize,
    nodata: f64,
) -> Result<(), HeightmapError> {
    let found = match samples {
        Samples::Integer(values, _) => values.iter().position(|&v| f64::from(v) == nodata),
        Samples::Metres(values) => values.iter().position(|&v| f64::from(v) == nodata),
    };
    match found {
        None => Ok(()),
        Some(k) => Err(error(
            file,
            format!("pixel (column {}, row {})", k % width, k / width),
            format!(
                "{nodata} is the file's no-data value (GDAL_NODATA, tag {GDAL_NODATA}): the \
                 terrain has a hole there; fill no-data before use (e.g. gdal_fillnodata)"
            ),
        )),
    }
}

/// The GeoKeys stored in the directory itself (`TIFFTagLocation` 0), by id; `None` when the
/// directory is shorter than its header (4 shorts) and the key count it declares (4 shorts
/// each) need.
fn geokeys(directory: &[u16]) -> Option<Vec<(u16, u16)>> {
    let count = *directory.get(3)? as usize;
    let keys = directory.get(4..4 + 4 * count)?;
    Some(
        keys.chunks_exact(4)
            .filter(|k| k[1] == 0)
            .map(|k| (k[0], k[3]))
            .collect(),
    )
}

fn unit_name(code: u16) -> &'static str {
    match code {
        9001 => "metre",
        9002 => "international foot",
        9003 => "US survey foot",
        9101 => "radian",
        9102 => "degree",
        _ => "EPSG unit",
    }
}

/// The sample placement the GeoTIFF tags give, `None` without a pixel scale (or when
/// `--terrain-size` replaces it). Units other than metres are refused unless `--terrain-size`
/// is given, which then says the extent (and a note says so).
fn georeference(
    file: &Path,
    d: &mut Decoder<Cursor<&[u8]>>,
    options: &HeightmapOptions,
    notes: &mut Vec<String>,
) -> Result<Option<Placement>, HeightmapError> {
    // A tag's values, if present, converted; an unreadable one is refused by name.
    let mut tag =
        |t: Tag, name: &str| -> Result<Option<tiff::decoder::ifd::Value>, HeightmapError> {
            d.find_tag(t).map_err(|e| error(file, name, e))
        };
    let f64s = |v: Option<tiff::decoder::ifd::Value>, name: &str| {
        v.map(|v| v.into_f64_vec())
            .transpose()
            .map_err(|e| error(file, name, e))
    };
    const SCALE: &str = "ModelPixelScaleTag (33550)";
    const TIEPOINT: &str = "ModelTiepointTag (33922)";
    const KEYS: &str = "GeoKeyDirectoryTag (34735)";
    let scale = f64s(tag(Tag::ModelPixelScaleTag, SCALE)?, SCALE)?;
    let tiepoint = f64s(tag(Tag::ModelTiepointTag, TIEPOINT)?, TIEPOINT)?;
    let keys = tag(Tag::GeoKeyDirectoryTag, KEYS)?
        .map(|v| v.into_u16_vec())
        .transpose()
        .map_err(|e| error(file, KEYS, e))?
        .map(|k| {
            geokeys(&k).ok_or_else(|| {
                error(
                    file,
                    KEYS,
                    format!(
                        "{} shorts cannot hold the header and the {} keys it declares (4 \
                         shorts each)",
                        k.len(),
                        k.get(3).map_or("?".to_string(), |c| c.to_string())
                    ),
                )
            })
        })
        .transpose()?
        .unwrap_or_default();
    let key = |id: u16| keys.iter().find(|k| k.0 == id).map(|k| k.1);
    let vertical = key(VERTICAL_UNITS);
    if let Some(u) = vertical.filter(|&u| u != METRE) {
        return Err(error(
            file,
            "VerticalUnitsGeoKey (4099)",
            format!(
                "heights are in unit {u} ({}), not metres (9001): convert them to metres first",
                unit_name(u)
            ),
        ));
    }
    // What keeps the tags' pixel size from being metres, if anything.
    let not_metres = if key(MODEL_TYPE) == Some(GEOGRAPHIC) {
        Some((
            "GTModelTypeGeoKey (1024)",
            "is 2, a geographic CRS: the pixel size is in degrees, not metres".to_string(),
        ))
    } else {
        key(PROJ_LINEAR_UNITS).filter(|&u| u != METRE).map(|u| {
            (
                "ProjLinearUnitsGeoKey (3076)",
                format!(
                    "is {u} ({}): the pixel size is not in metres (9001)",
                    unit_name(u)
                ),
            )
        })
    };
    if let Some([x, z]) = options.size {
        if let Some((field, why)) = &not_metres {
            notes.push(format!(
                "{}: {field} {why}; using --terrain-size {x},{z} m as the extent instead",
                file.display()
            ));
        } else if scale.is_some() {
            notes.push(format!(
                "{}: using --terrain-size {x},{z} m as the extent instead of the GeoTIFF's \
                 pixel size",
                file.display()
            ));
        }
        return Ok(None);
    }
    if let Some((field, why)) = not_metres {
        return Err(error(
            file,
            field,
            format!(
                "{why}; reproject it to a metric CRS (e.g. UTM) or give --terrain-size X,Z \
                 (the extent in metres)"
            ),
        ));
    }
    let Some(scale) = scale else {
        return Ok(None);
    };
    let (sx, sz) = match scale[..] {
        [sx, sz, ..] if sx.is_finite() && sz.is_finite() && sx > 0.0 && sz > 0.0 => (sx, sz),
        _ => {
            return Err(error(
                file,
                "ModelPixelScaleTag (33550)",
                format!("{scale:?} is not two positive finite pixel sizes"),
            ));
        }
    };
    let point = key(RASTER_TYPE) == Some(PIXEL_IS_POINT);
    if let Some(&[i, j, _, x, y, ..]) = tiepoint.as_deref() {
        notes.push(format!(
            "{}: x = 0, z = 0 is the raster's north-west {} at easting {:.3}, northing {:.3} \
             of its CRS",
            file.display(),
            if point { "sample" } else { "corner" },
            x - i * sx,
            y + j * sz
        ));
    }
    // Pixel-is-area: a sample stands for its pixel's square, so it lies at the square's
    // centre, half a pixel in from the corner the tiepoint names.
    let first = if point {
        [0.0, 0.0]
    } else {
        [0.5 * sx, 0.5 * sz]
    };
    Ok(Some(Placement {
        spacing: [sx, sz],
        first,
    }))
}
