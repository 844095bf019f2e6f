//! Why a forest came out empty or one-sided, in words a user can act on.

use super::Placement;
use crate::species::SpeciesFile;
use crate::terrain::survey;

/// An empty forest, or one species taking every tree, usually means the species file's
/// habitats do not fit this terrain (a coarse DEM's slopes and wetness differ from a fine
/// one's): what the terrain offers and what each species asks for, as a warning to print;
/// `None` when the forest looks as a species file meant it to.
pub fn diagnosis(forest: &Placement, species: &SpeciesFile) -> Option<String> {
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
    let why = if n == 0 && !suited {
        "no ground in the region suits any species: the forest is empty".to_string()
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
