//! What a terrain offers trees: the distribution of each attribute over a region, and how much
//! of it suits each species. What a user needs to write a species file for a terrain, and what
//! `place` prints when a forest comes out empty or lopsided.

use std::fmt::Write as _;

use serde::Serialize;

use super::{Attributes, Heightfield, TERRAIN_ATTRIBUTES};
use crate::number::{number, shortest};
use crate::species::{Band, Habitat, Preference, SpeciesFile};

/// Units of the attributes, in [`TERRAIN_ATTRIBUTES`] order.
pub const UNITS: [&str; 5] = ["m", "degrees", "degrees", "m", "index"];

/// Percentiles of one attribute over the raster cells that have terrain.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct AttributeStats {
    pub name: &'static str,
    pub unit: &'static str,
    pub min: f64,
    pub p5: f64,
    pub p25: f64,
    pub p50: f64,
    pub p75: f64,
    pub p95: f64,
    pub max: f64,
}

/// How much of the surveyed ground suits a species, and what its habitat asks for.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct SpeciesFit {
    pub name: String,
    /// Share of the cells with terrain where its suitability reaches `min_suitability`.
    pub suitable_share: f64,
    /// The habitat's terms, as text (`slope 0..35 (margin 10) degrees`).
    pub asks: Vec<String>,
}

#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Survey {
    /// Raster cell (m), the region surveyed and the raster's extent: x0, z0, x1, z1 (m). The
    /// raster reaches the topographic-position radius beyond the region, where there is
    /// terrain, so that attributes at the region's edge see their whole neighbourhood.
    pub cell: f64,
    pub region: [f64; 4],
    pub extent: [f64; 4],
    /// Raster cells in the region surveyed, and those of them with terrain beneath (the
    /// raster itself reaches the topographic-position radius beyond the region).
    pub cells: usize,
    pub cells_with_terrain: usize,
    pub tpi_radius: f64,
    pub attributes: Vec<AttributeStats>,
    pub species: Vec<SpeciesFit>,
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let at = q * (sorted.len() - 1) as f64;
    let (i, f) = (at.floor() as usize, at.fract());
    let j = (i + 1).min(sorted.len() - 1);
    sorted[i] + (sorted[j] - sorted[i]) * f
}

fn stats(name: &'static str, unit: &'static str, values: &[f32]) -> AttributeStats {
    let mut v: Vec<f64> = values
        .iter()
        .filter(|x| x.is_finite())
        .map(|&x| x as f64)
        .collect();
    v.sort_by(f64::total_cmp);
    let p = |q| percentile(&v, q);
    AttributeStats {
        name,
        unit,
        min: p(0.0),
        p5: p(0.05),
        p25: p(0.25),
        p50: p(0.5),
        p75: p(0.75),
        p95: p(0.95),
        max: p(1.0),
    }
}

fn band(name: &str, unit: &str, b: &Band) -> String {
    let edge = |v: f64| {
        if v.is_finite() {
            format!("{v}")
        } else {
            String::new()
        }
    };
    format!(
        "{name} {}..{} (margin {}) {unit}",
        edge(b.min),
        edge(b.max),
        b.margin
    )
}

fn preference(name: &str, unit: &str, p: &Preference) -> String {
    format!(
        "{name} near {} (tolerance {}) {unit}",
        p.preferred, p.tolerance
    )
    .trim_end()
    .to_string()
}

/// The habitat's terms, as text.
pub fn asks(h: &Habitat) -> Vec<String> {
    let mut out = Vec::new();
    if let Some(b) = &h.elevation {
        out.push(band("elevation", "m", b));
    }
    if let Some(b) = &h.slope {
        out.push(band("slope", "degrees", b));
    }
    if let Some(p) = &h.aspect {
        out.push(preference("aspect", "degrees", p));
    }
    if let Some(p) = &h.topographic_position {
        out.push(preference("topographic_position", "m", p));
    }
    if let Some(p) = &h.wetness {
        out.push(preference("wetness", "", p));
    }
    if out.is_empty() {
        out.push("anywhere".into());
    }
    out
}

/// Surveys `raster` and its `attributes` over the cells whose centres lie in `region`; with
/// `species`, how much of it suits each (suitability per cell as `place` computes it,
/// `suitability[s][cell]`).
pub fn survey(
    raster: &Heightfield,
    attributes: &Attributes,
    tpi_radius: f64,
    region: [f64; 4],
    species: Option<(&SpeciesFile, &[Vec<f32>])>,
) -> Survey {
    let inside = |k: usize| {
        let x = raster.x0 + ((k % raster.nx) as f64 + 0.5) * raster.cell;
        let z = raster.z0 + ((k / raster.nx) as f64 + 0.5) * raster.cell;
        (region[0]..=region[2]).contains(&x) && (region[1]..=region[3]).contains(&z)
    };
    let in_region = (0..raster.height.len()).filter(|&k| inside(k)).count();
    let cells: Vec<usize> = (0..raster.height.len())
        .filter(|&k| inside(k) && raster.height[k].is_finite())
        .collect();
    let attributes = (0..5)
        .map(|a| {
            let field = attributes.get(raster, a);
            let mut values: Vec<f32> = cells.iter().map(|&k| field[k]).collect();
            if a == 2 {
                // Flats have no aspect (-1): leave them out of the bearing's distribution.
                values.retain(|&v| v >= 0.0);
            }
            stats(TERRAIN_ATTRIBUTES[a], UNITS[a], &values)
        })
        .collect();
    let species = species
        .map(|(file, suitability)| {
            let min = file.analysis.min_suitability.max(1e-6) as f32;
            file.species
                .iter()
                .zip(suitability)
                .map(|(s, suit)| SpeciesFit {
                    name: s.name.clone(),
                    suitable_share: cells.iter().filter(|&&k| suit[k] >= min).count() as f64
                        / cells.len().max(1) as f64,
                    asks: asks(&s.habitat),
                })
                .collect()
        })
        .unwrap_or_default();
    Survey {
        cell: raster.cell,
        region,
        extent: [
            raster.x0,
            raster.z0,
            raster.x0 + raster.nx as f64 * raster.cell,
            raster.z0 + raster.nz as f64 * raster.cell,
        ],
        cells: in_region,
        cells_with_terrain: cells.len(),
        tpi_radius,
        attributes,
        species,
    }
}

/// The survey as text: a table of percentiles, then each species' share and terms.
pub fn to_text(s: &Survey) -> String {
    let mut o = String::new();
    let r = s.region;
    let _ = writeln!(
        o,
        "region        x {} to {}, z {} to {} m ({} km x {} km)",
        number(r[0], 1),
        number(r[2], 1),
        number(r[1], 1),
        number(r[3], 1),
        number((r[2] - r[0]) / 1e3, 2),
        number((r[3] - r[1]) / 1e3, 2),
    );
    let _ = writeln!(
        o,
        "raster        {} m cells; {} of the region's {} cells have terrain",
        number(s.cell, 2),
        s.cells_with_terrain,
        s.cells
    );
    let _ = writeln!(
        o,
        "attribute (topographic position over {} m)      min       5%      25%      50%      75%      95%      max",
        shortest(s.tpi_radius)
    );
    for a in &s.attributes {
        let _ = writeln!(
            o,
            "  {:<22} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8} {:>8}",
            a.name,
            a.unit,
            number(a.min, 1),
            number(a.p5, 1),
            number(a.p25, 1),
            number(a.p50, 1),
            number(a.p75, 1),
            number(a.p95, 1),
            number(a.max, 1)
        );
    }
    for f in &s.species {
        let _ = writeln!(
            o,
            "species {:?}: suits {:.1}% of the ground; asks for {}",
            f.name,
            100.0 * f.suitable_share,
            f.asks.join(", ")
        );
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_interpolate_between_ranks() {
        let v: Vec<f64> = (0..=100).map(f64::from).collect();
        assert_eq!(percentile(&v, 0.05), 5.0);
        assert_eq!(percentile(&v, 0.5), 50.0);
        assert_eq!(percentile(&[1.0, 3.0], 0.5), 2.0);
        assert!(percentile(&[], 0.5).is_nan());
    }
}
