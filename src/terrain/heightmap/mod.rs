//! Heightmap terrains: a grey image (PNG, OpenEXR, TIFF/GeoTIFF, raw `.r16`) as exported by
//! terrain tools and GIS, triangulated into the same [`Model`] a glTF terrain imports to, so
//! placement and rendering never know the difference (formats/heightmap.md).
//!
//! Conventions: x east, z south, +Y up. Row 0 is the north edge (smallest z), column 0 the
//! west edge (smallest x). Every pixel is one sample (a vertex): for plain images and for
//! `--terrain-size` the first and last columns lie on the west and east edges of the extent,
//! so sample (col, row) is at x = col * X / (width - 1), z = row * Z / (height - 1), and the
//! north-west sample is at x = 0, z = 0. GeoTIFF spacing comes from its tags, with the raster's
//! north-west corner at x = 0, z = 0 (samples half a pixel in for RasterPixelIsArea).

mod geotiff;
mod read;
#[cfg(test)]
mod tests;

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3, Vec4};

use crate::import::{Material, Mesh, Model, Triangle};
use crate::input::{self, MAX_GLTF};
use crate::limits::Limits;
use crate::provenance::{Source, sha256};

/// What `--terrain-size` and `--height-range` say; a format type, as forests record it.
pub use crate::formats::instances::HeightmapOptions;

/// Why a heightmap could not become a terrain: the file, the flag, tag or pixel at fault (may
/// be empty), and what is wrong.
#[derive(Debug, thiserror::Error)]
#[error("{}: {}{message}", file.display(), crate::import::field_prefix(field))]
pub struct HeightmapError {
    pub file: PathBuf,
    pub field: String,
    pub message: String,
}

pub(crate) fn error(
    file: &Path,
    field: impl std::fmt::Display,
    message: impl std::fmt::Display,
) -> HeightmapError {
    HeightmapError {
        file: file.to_path_buf(),
        field: field.to_string(),
        message: message.to_string(),
    }
}

/// The file formats read as heightmaps.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Png,
    Exr,
    Tiff,
    /// Little-endian u16, square, no header (Unreal, Unity).
    R16,
}

/// The first bytes of every OpenEXR file.
pub const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

impl Format {
    /// The heightmap format of a file from its first bytes (8 suffice) and its name, or `None`
    /// for anything else (a glTF). A damaged file named like a heightmap is taken for one, so
    /// its reader reports the damage.
    pub fn of(head: &[u8], path: &Path) -> Option<Format> {
        if head.starts_with(b"\x89PNG") {
            return Some(Format::Png);
        }
        if head.starts_with(&EXR_MAGIC) {
            return Some(Format::Exr);
        }
        if [b"II*\0", b"MM\0*", b"II+\0", b"MM\0+"]
            .iter()
            .any(|m| head.starts_with(*m))
        {
            return Some(Format::Tiff);
        }
        let extension = path.extension()?.to_string_lossy().to_ascii_lowercase();
        match extension.as_str() {
            "png" => Some(Format::Png),
            "exr" => Some(Format::Exr),
            "tif" | "tiff" => Some(Format::Tiff),
            "r16" | "raw" => Some(Format::R16),
            _ => None,
        }
    }

    /// [`Format::of`] the file at `path` (its first 8 bytes; `None` if it cannot be read, for
    /// the glTF importer to report).
    pub fn of_file(path: &Path) -> Option<Format> {
        use std::io::Read;
        let mut head = Vec::new();
        let file = std::fs::File::open(path).ok()?;
        file.take(8).read_to_end(&mut head).ok()?;
        Format::of(&head, path)
    }
}

/// Samples as read: integers to scale by `--height-range`, or metres as stored.
pub(crate) enum Samples {
    /// Integer samples and the type's largest value (255, 65535).
    Integer(Vec<u16>, u16),
    Metres(Vec<f32>),
}

/// One image of samples, row 0 north, with what the file says about its ground spacing.
pub(crate) struct Raster {
    pub width: usize,
    pub height: usize,
    pub samples: Samples,
    /// GeoTIFF's spacing and where the first sample lies from the north-west corner (m).
    pub geo: Option<geotiff::Placement>,
    /// Things the user may want to know (which channel was read).
    pub notes: Vec<String>,
}

/// Refuses rasters too small to triangulate or too large for `limits`, before the pixels are
/// decoded: every reader calls this with the size its header claims.
pub(crate) fn check_size(
    file: &Path,
    width: u64,
    height: u64,
    limits: &Limits,
) -> Result<(), HeightmapError> {
    if width < 2 || height < 2 {
        return Err(error(
            file,
            "",
            format!(
                "{width}x{height} pixels: a heightmap needs at least 2x2 samples to make a surface"
            ),
        ));
    }
    let refuse = |e: &dyn std::fmt::Display| error(file, "", e);
    limits
        .check_pixels(width * height, "the heightmap's pixel count")
        .map_err(|e| refuse(&e))?;
    limits
        .check_triangles(
            2 * (width - 1) * (height - 1),
            "the heightmap's triangle count (2 per square of 4 samples)",
        )
        .map_err(|e| refuse(&e))?;
    // The mesh: a position, uv and colour a vertex, 8 bytes a triangle index... and the samples.
    crate::limits::check_memory(width * height * 48, "the heightmap's mesh").map_err(|e| refuse(&e))
}

/// Reads the heightmap at `path` (its `format`) and triangulates it into a terrain model, with
/// the file recorded as its one source.
pub fn load(
    path: &Path,
    format: Format,
    options: &HeightmapOptions,
    limits: &Limits,
) -> Result<Model, HeightmapError> {
    options
        .validate()
        .map_err(|(field, message)| error(path, field, message))?;
    let bytes = input::read_bounded(path, MAX_GLTF, "heightmap")
        .map_err(|e| error(path, "", strip_path(&e.to_string(), path)))?;
    let raster = match format {
        Format::Png => read::png(path, &bytes, limits)?,
        Format::Exr => read::exr(path, &bytes, limits)?,
        Format::Tiff => geotiff::read(path, &bytes, options, limits)?,
        Format::R16 => read::r16(path, &bytes, limits)?,
    };
    let source = Source {
        path: path.to_path_buf(),
        sha256: sha256(&bytes),
        bytes: bytes.len() as u64,
    };
    let n = match &raster.samples {
        Samples::Integer(v, _) => v.len(),
        Samples::Metres(v) => v.len(),
    };
    if n != raster.width * raster.height {
        return Err(error(
            path,
            "",
            format!(
                "{n} samples for {}x{} pixels: a heightmap is one sample a pixel (no \
                 subsampled or extra channels)",
                raster.width, raster.height
            ),
        ));
    }
    let heights = heights(path, &raster, options)?;
    let (spacing, first) = spacing(path, &raster, options)?;
    let mesh = triangulate(raster.width, raster.height, &heights, spacing, first);
    Ok(Model {
        mesh,
        cameras: vec![],
        orthographic: vec![],
        suns: vec![],
        sources: vec![source],
        warnings: raster.notes,
    })
}

/// An I/O error's message without the path it starts with (ours names the file once).
fn strip_path(message: &str, path: &Path) -> String {
    let p = path.display().to_string();
    message
        .strip_prefix(&format!("{p}: "))
        .unwrap_or(message)
        .to_string()
}

/// Every sample in metres: integers scaled by `--height-range`, floats as stored (and then
/// `--height-range` is refused: it would have to guess what the floats' range is).
fn heights(
    file: &Path,
    raster: &Raster,
    options: &HeightmapOptions,
) -> Result<Vec<f32>, HeightmapError> {
    match &raster.samples {
        Samples::Integer(values, max) => {
            let Some([lo, hi]) = options.height_range else {
                return Err(error(
                    file,
                    "--height-range",
                    format!(
                        "the samples are integers (0 to {max}) with no unit: give \
                         --height-range LO,HI, the heights in metres of 0 and {max}"
                    ),
                ));
            };
            let step = (hi - lo) / *max as f64;
            Ok(values
                .iter()
                .map(|&v| (lo + v as f64 * step) as f32)
                .collect())
        }
        Samples::Metres(values) => {
            if options.height_range.is_some() {
                return Err(error(
                    file,
                    "--height-range",
                    "the samples are floating-point heights in metres, used as stored; \
                     --height-range scales integer samples only",
                ));
            }
            if let Some(k) = values.iter().position(|v| !v.is_finite()) {
                return Err(error(
                    file,
                    format!(
                        "pixel (column {}, row {})",
                        k % raster.width,
                        k / raster.width
                    ),
                    format!(
                        "height {} is not a finite number (no-data samples must be filled \
                         before the heightmap is used)",
                        values[k]
                    ),
                ));
            }
            Ok(values.clone())
        }
    }
}

/// The ground spacing between samples (x, z; m) and where the north-west sample lies.
fn spacing(
    file: &Path,
    raster: &Raster,
    options: &HeightmapOptions,
) -> Result<([f64; 2], [f64; 2]), HeightmapError> {
    if let Some([x, z]) = options.size {
        let cells = [(raster.width - 1) as f64, (raster.height - 1) as f64];
        return Ok(([x / cells[0], z / cells[1]], [0.0, 0.0]));
    }
    match &raster.geo {
        Some(g) => Ok((g.spacing, g.first)),
        None => Err(error(
            file,
            "--terrain-size",
            "the image does not say how large the ground is: give --terrain-size X,Z, its \
             extent in metres east-west and north-south",
        )),
    }
}

/// The terrain's colour, as the fixture mountain's (a dark green-brown ground).
const GROUND: Vec4 = Vec4::new(0.16, 0.2, 0.09, 1.0);

/// A regular grid of `width` x `height` vertices, row 0 north, `spacing` apart from `first`,
/// two triangles a square, counter-clockwise seen from above (+Y).
pub(crate) fn triangulate(
    width: usize,
    height: usize,
    heights: &[f32],
    spacing: [f64; 2],
    first: [f64; 2],
) -> Mesh {
    let mut positions = Vec::with_capacity(width * height);
    let mut uvs = Vec::with_capacity(width * height);
    for row in 0..height {
        for col in 0..width {
            let x = first[0] + col as f64 * spacing[0];
            let z = first[1] + row as f64 * spacing[1];
            positions.push(Vec3::new(x as f32, heights[col + width * row], z as f32));
            uvs.push(Vec2::new(
                col as f32 / (width - 1) as f32,
                row as f32 / (height - 1) as f32,
            ));
        }
    }
    let v = |col: usize, row: usize| (col + width * row) as u32;
    let mut triangles = Vec::with_capacity(2 * (width - 1) * (height - 1));
    for row in 0..height - 1 {
        for col in 0..width - 1 {
            for vertices in [
                [v(col, row), v(col, row + 1), v(col + 1, row)],
                [v(col + 1, row), v(col, row + 1), v(col + 1, row + 1)],
            ] {
                triangles.push(Triangle {
                    vertices,
                    material: 0,
                });
            }
        }
    }
    Mesh {
        colors: vec![Vec4::ONE; positions.len()],
        positions,
        uvs,
        triangles,
        materials: vec![Material {
            name: "ground".into(),
            base_color: GROUND,
            ..Material::default()
        }],
        textures: vec![],
    }
}
