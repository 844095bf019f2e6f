//! Why a forest came out empty or one-sided, in words a user can act on.

use super::Placement;
use crate::species::SpeciesFile;
use crate::terrain::survey;

/// An empty forest, or one species taking every tree, usually means the species file's
/// habitats do not fit this terrain (a coarse DEM's slopes and wetness differ from a fine
/// one's): what the terrain offers and what each species asks for, as a warning to print;
/// `None` when the forest looks as a species file meant it to.
pub fn diagnosis(
    forest: &Placement,
    species: &SpeciesFile,
    sea_level: Option<f64>,
) -> Option<String> {
    let n = forest.instances.len();
    let mut counts = vec![0usize; species.species.len()];
    for p in &forest.instances {
        counts[p.species as usize] += 1;
    }
    let lopsided = species.species.len() > 1 && counts.contains(&n);
    if n > 0 && !lopsided {
        return None;
    }
    let s = survey::survey(
        &forest.raster,
        &forest.attributes,
        species.analysis.tpi_radius,
        forest.region,
        Some((species, &forest.suitability)),
    );
    let suited = s.species.iter().any(|f| f.suitable_share > 0.0);
    // The ground --sea-level leaves dry, of the region's raster cells that have terrain (the
    // raster reaches a topographic-position radius beyond the region).
    let r = &forest.raster;
    let [x0, z0, x1, z1] = forest.region;
    let heights = || {
        r.height.iter().enumerate().filter_map(move |(k, h)| {
            let x = r.x0 + ((k % r.nx) as f64 + 0.5) * r.cell;
            let z = r.z0 + ((k / r.nx) as f64 + 0.5) * r.cell;
            (h.is_finite() && (x0..=x1).contains(&x) && (z0..=z1).contains(&z)).then_some(h)
        })
    };
    let dry = sea_level.map(|sea| {
        let ground = heights().count().max(1);
        heights().filter(|&&h| f64::from(h) >= sea).count() as f64 / ground as f64
    });
    let why = if let (0, false, Some(sea), Some(0.0)) = (n, suited, sea_level, dry) {
        let top = heights().fold(f32::NEG_INFINITY, |a, &h| a.max(h));
        format!(
            "--sea-level {sea} m lies above all the ground (its highest point is {top:.1} m): \
             the forest is empty"
        )
    } else if n == 0 && !suited {
        let flooded = match (sea_level, dry) {
            (Some(sea), Some(d)) if d < 1.0 => format!(
                " (--sea-level {sea} m floods {:.0}% of it)",
                100.0 * (1.0 - d)
            ),
            _ => String::new(),
        };
        format!("no ground in the region suits any species{flooded}: the forest is empty")
    } else if n == 0 {
        let r = forest.region;
        format!(
            "no tree was placed, though some ground suits a species: check that the species' \
             spacing fits the region ({:.0} m x {:.0} m) and their heights the terrain",
            r[2] - r[0],
            r[3] - r[1]
        )
    } else {
        let only = counts.iter().position(|&c| c == n).unwrap_or_default();
        format!(
            "every tree is {:?}: no ground in the region suits the other species",
            species.species[only].name
        )
    };
    Some(format!(
        "{why}. What the terrain offers and what the species ask for (`texel inspect TERRAIN` shows more):\n{}",
        survey::to_text(&s).trim_end()
    ))
}
