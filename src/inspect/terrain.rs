//! What `texel inspect TERRAIN.glb` reports: the terrain's extent and mesh resolution, the
//! distribution of every attribute placement judges ground by, how much of it suits each
//! species of a species file, and pictures of the attributes. What a user needs to write (or
//! fix) a species file for a terrain.

use std::fmt::Write as _;

use image::RgbImage;
use serde::Serialize;

use super::printable;
use crate::color::ramp;
use crate::number::number;
use crate::place::{self, Ground, PlaceError, PlaceSettings};
use crate::provenance::SourceFile;
use crate::species::SpeciesFile;
use crate::terrain::survey::{self, Survey};
use crate::terrain::{Terrain, hillshade};

#[derive(Serialize, Debug)]
pub struct TerrainSummary {
    pub format: &'static str,
    pub triangles: usize,
    /// Bounds of the surface (m).
    pub min: [f64; 3],
    pub max: [f64; 3],
    /// The cell of a regular grid with as many triangles over the same ground (m): the raster
    /// cell `place` uses unless `--cell` says otherwise.
    pub natural_cell: f64,
    pub survey: Survey,
    pub sources: Vec<SourceFile>,
}

/// The terrain judged as `place` would with `species` (or with default analysis settings and
/// no species) and `settings`' region, cell and sea level.
pub fn summarize(
    terrain: &Terrain,
    species: Option<&SpeciesFile>,
    settings: &PlaceSettings,
    sources: Vec<SourceFile>,
) -> Result<(TerrainSummary, Ground), PlaceError> {
    let default_file;
    let file = match species {
        Some(f) => f,
        None => {
            default_file = SpeciesFile {
                format: crate::species::FORMAT.into(),
                analysis: Default::default(),
                species: Vec::new(),
            };
            &default_file
        }
    };
    let ground = place::ground(terrain, file, settings)?;
    let (raster, region) = (&ground.raster, ground.region);
    let survey = survey::survey(
        raster,
        &ground.attributes,
        file.analysis.tpi_radius,
        region,
        species.map(|f| (f, ground.suitability.as_slice())),
    );
    let summary = TerrainSummary {
        format: "glTF terrain",
        triangles: terrain.model.mesh.triangles.len(),
        min: terrain.lo.to_array(),
        max: terrain.hi.to_array(),
        natural_cell: terrain.natural_cell(),
        survey,
        sources,
    };
    Ok((summary, ground))
}

pub fn to_text(s: &TerrainSummary) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "format        {}, {} triangles (a regular grid of as many would have {} m cells)",
        s.format,
        s.triangles,
        number(s.natural_cell, 2)
    );
    let _ = writeln!(
        o,
        "bounds        x {} .. {}, y {} .. {}, z {} .. {} m",
        number(s.min[0], 1),
        number(s.max[0], 1),
        number(s.min[1], 1),
        number(s.max[1], 1),
        number(s.min[2], 1),
        number(s.max[2], 1)
    );
    o += &survey::to_text(&s.survey);
    for (i, src) in s.sources.iter().enumerate() {
        let label = if i == 0 { "sources" } else { "" };
        let _ = writeln!(
            o,
            "{label:<13} {}  {} bytes  sha256 {}",
            printable(&src.path),
            src.bytes,
            crate::hex::hex(&src.sha256)
        );
    }
    o
}

/// Pictures of the attributes, north up, in a grid of panels: hillshade, elevation, slope,
/// aspect (a hue circle: north red, east yellow-green, south cyan, west purple), topographic
/// position and wetness, each on the colour ramp from its 2nd to its 98th percentile over the
/// raster. Cells without terrain are white.
pub fn attribute_maps(ground: &Ground) -> RgbImage {
    let raster = &ground.raster;
    let (w, h) = (raster.nx as u32, raster.nz as u32);
    // Panels of at least 256 pixels across: coarse rasters are drawn with square pixels.
    let zoom = (256 / w.max(h)).max(1);
    let (pw, ph) = (w * zoom, h * zoom);
    let gap = 4;
    let mut img = RgbImage::from_pixel(3 * pw + 2 * gap, 2 * ph + gap, image::Rgb([255; 3]));
    let shade = hillshade(raster);
    for panel in 0..6 {
        let values: Vec<f32> = match panel {
            0 => shade.clone(),
            a => ground.attributes.get(raster, a - 1).to_vec(),
        };
        let mut sorted: Vec<f32> = values.iter().copied().filter(|v| v.is_finite()).collect();
        sorted.sort_by(f32::total_cmp);
        let at = |q: f32| {
            sorted
                .get(((sorted.len().max(1) - 1) as f32 * q) as usize)
                .copied()
                .unwrap_or(0.0)
        };
        let (lo, hi) = if panel == 0 {
            (0.0, 1.0)
        } else {
            (at(0.02), at(0.98))
        };
        let (ox, oy) = (
            (panel as u32 % 3) * (pw + gap),
            (panel as u32 / 3) * (ph + gap),
        );
        for j in 0..h {
            for i in 0..w {
                let v = values[(i + w * j) as usize];
                let color = if !v.is_finite() || (panel == 3 && v < 0.0) {
                    [255, 255, 255]
                } else if panel == 0 {
                    [(255.0 * v.clamp(0.0, 1.0)) as u8; 3]
                } else if panel == 3 {
                    hue(v / 360.0)
                } else {
                    ramp(((v - lo) / (hi - lo).max(1e-9)).clamp(0.0, 1.0))
                };
                for dy in 0..zoom {
                    for dx in 0..zoom {
                        img.put_pixel(ox + i * zoom + dx, oy + j * zoom + dy, image::Rgb(color));
                    }
                }
            }
        }
    }
    img
}

/// A fully saturated colour at hue `t` turns around the circle (0 red).
fn hue(t: f32) -> [u8; 3] {
    let h = t.rem_euclid(1.0) * 6.0;
    let x = 1.0 - (h % 2.0 - 1.0).abs();
    let (r, g, b) = match h as u32 {
        0 => (1.0, x, 0.0),
        1 => (x, 1.0, 0.0),
        2 => (0.0, 1.0, x),
        3 => (0.0, x, 1.0),
        4 => (x, 0.0, 1.0),
        _ => (1.0, 0.0, x),
    };
    [r, g, b].map(|c: f32| (200.0 * c + 40.0) as u8)
}
