//! What `texel inspect FILE.instances` reports, and its map.

use std::fmt::Write as _;

use image::RgbImage;
use serde::Serialize;

use super::printable;
use crate::formats::instances::StoredForest;
use crate::hex::hex;
use crate::number::{number, shortest};
use crate::provenance::SourceFile;
use crate::terrain::{Heightfield, Terrain, hillshade};

/// Map colours of species 0, 1, ... (ColorBrewer "Dark2", then repeating).
const PALETTE: [[u8; 3]; 8] = [
    [27, 158, 119],
    [217, 95, 2],
    [117, 112, 179],
    [231, 41, 138],
    [102, 166, 30],
    [230, 171, 2],
    [166, 118, 29],
    [102, 102, 102],
];

pub fn color(species: usize) -> [u8; 3] {
    PALETTE[species % PALETTE.len()]
}

#[derive(Serialize, Debug)]
pub struct ForestSummary {
    /// Format name and version, e.g. `instances 1.0`.
    pub format: String,
    pub generator: String,
    pub file_bytes: u64,
    /// The payload before compression, as the file declares it.
    pub raw_bytes: u64,
    /// File bytes per tree; absent for an empty forest.
    pub bytes_per_tree: Option<f64>,
    pub trees: usize,
    pub region: [f64; 4],
    pub hectares: f64,
    pub seed: u64,
    pub truncated: bool,
    pub species: Vec<SpeciesSummary>,
    /// Smallest distance between two trees (m), and smallest ratio of a distance to the
    /// larger of the two trees' radii (the placement rule keeps it >= 1); absent with fewer
    /// than two trees.
    pub min_distance: Option<f64>,
    pub min_distance_ratio: Option<f64>,
    /// Tree heights (m): ten equal bins between the smallest and the largest.
    pub height_bins: Vec<(f64, f64, usize)>,
    pub terrain: Vec<SourceFile>,
    /// How the terrain image became a mesh, when it is a heightmap.
    pub heightmap: Option<crate::formats::instances::HeightmapOptions>,
    pub species_file: SourceFile,
}

#[derive(Serialize, Debug)]
pub struct SpeciesSummary {
    pub name: String,
    pub trees: usize,
    pub per_hectare: f64,
    pub map_color: String,
    pub texel: String,
    /// Shortest and tallest tree (m); absent when the species has none.
    pub height_range: Option<[f64; 2]>,
}

/// Tree height (m) of tree `i`.
fn height(f: &StoredForest, i: usize) -> f64 {
    f.trees.scale(i) as f64 * f.info.species[f.trees.species(i) as usize].model_height
}

/// Smallest distance and smallest distance-to-radius ratio over all pairs that could hold
/// either (`None` with fewer than two trees), by a plane sweep: trees in order of x, and for
/// each only the earlier trees within the current best reach in x and z. A pair's ratio is at
/// least its distance over the largest radius, so the reach is the larger of the best distance
/// and the best ratio times that radius; it shrinks as better pairs are found, which keeps
/// clustered forests fast, and coincident trees end the sweep at once.
fn spacing(f: &StoredForest) -> Option<(f64, f64)> {
    let t = &f.trees;
    let radius = |i: usize| f.info.species[t.species(i) as usize].radius(t.scale(i) as f64);
    let n = t.len();
    if n < 2 {
        return None;
    }
    let r_max = (0..n).map(radius).fold(0.0, f64::max).max(1e-6);
    // One coordinate at a time: the sort compares x some n log n times.
    let (x, z) = (|i: usize| t.coordinate(0, i), |i: usize| t.coordinate(2, i));
    // u32 indices, half the memory of usize: a file holds at most 113 million trees.
    let mut order: Vec<u32> = (0..n as u32).collect();
    order.sort_by(|&a, &b| x(a as usize).total_cmp(&x(b as usize)));
    // Trees within reach in x, by (z in millimetres, index).
    let key = |i: usize| ((z(i) * 1000.0).round() as i64, i);
    let mut active: std::collections::BTreeSet<(i64, usize)> = Default::default();
    let (mut distance, mut ratio) = (f64::INFINITY, f64::INFINITY);
    let mut left = 0;
    for i in order.iter().map(|&i| i as usize) {
        if distance == 0.0 {
            break;
        }
        let reach = distance.max(ratio * r_max);
        while x(order[left] as usize) < x(i) - reach {
            active.remove(&key(order[left] as usize));
            left += 1;
        }
        let lo = if reach.is_finite() {
            ((z(i) - reach) * 1000.0).floor() as i64
        } else {
            i64::MIN
        };
        let hi = if reach.is_finite() {
            ((z(i) + reach) * 1000.0).ceil() as i64
        } else {
            i64::MAX
        };
        for &(_, j) in active.range((lo, 0)..=(hi, usize::MAX)) {
            let (p, q) = (t.position(i), t.position(j));
            let d = (p[0] - q[0]).hypot(p[2] - q[2]);
            distance = distance.min(d);
            ratio = ratio.min(d / radius(i).max(radius(j)));
        }
        active.insert(key(i));
    }
    Some((distance, ratio))
}

pub fn summarize(f: &StoredForest, file: super::FileFacts) -> ForestSummary {
    let file_bytes = file.bytes;
    let n = f.trees.len();
    let r = f.info.region;
    let hectares = (r[2] - r[0]) * (r[3] - r[1]) / 1e4;
    // Counts and height ranges in passes over the trees: a list of the heights would add 8
    // bytes a tree to the trees' own 19.
    let mut counted = vec![(0, f64::INFINITY, 0.0f64); f.info.species.len()];
    for i in 0..n {
        let (h, c) = (height(f, i), &mut counted[f.trees.species(i) as usize]);
        *c = (c.0 + 1, c.1.min(h), c.2.max(h));
    }
    let species = f
        .info
        .species
        .iter()
        .zip(&counted)
        .enumerate()
        .map(|(i, (s, &(trees, low, high)))| SpeciesSummary {
            name: s.name.clone(),
            trees,
            per_hectare: trees as f64 / hectares,
            map_color: format!("#{}", hex(&color(i))),
            texel: s.texel.clone(),
            height_range: (trees > 0).then_some([low, high]),
        })
        .collect();
    let (lo, hi) = (0..n)
        .map(|i| height(f, i))
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), h| {
            (lo.min(h), hi.max(h))
        });
    let width = ((hi - lo) / 10.0).max(1e-9);
    let mut bins: Vec<(f64, f64, usize)> = (0..10)
        .map(|b| (lo + b as f64 * width, lo + (b + 1) as f64 * width, 0))
        .collect();
    if n > 0 {
        for h in (0..n).map(|i| height(f, i)) {
            bins[(((h - lo) / width) as usize).min(9)].2 += 1;
        }
    } else {
        bins.clear();
    }
    let closest = spacing(f);
    ForestSummary {
        format: format!("instances 1.{}", file.minor),
        generator: f.info.generator.clone(),
        file_bytes,
        raw_bytes: file.raw_bytes,
        bytes_per_tree: (n > 0).then(|| file_bytes as f64 / n as f64),
        trees: n,
        region: r,
        hectares,
        seed: f.info.seed,
        truncated: f.info.truncated,
        species,
        min_distance: closest.map(|c| c.0),
        min_distance_ratio: closest.map(|c| c.1),
        height_bins: bins,
        terrain: f.info.terrain.clone(),
        heightmap: f.heightmap,
        species_file: f.info.species_file.clone(),
    }
}

pub fn to_text(s: &ForestSummary) -> String {
    let mut o = String::new();
    let _ = writeln!(
        o,
        "format        {} (written by {})",
        s.format,
        printable(&s.generator)
    );
    let per_tree = s
        .bytes_per_tree
        .map_or(String::new(), |b| format!(", {b:.2} per tree"));
    let _ = writeln!(
        o,
        "size          {} bytes on disk{per_tree} ({} raw)",
        s.file_bytes, s.raw_bytes
    );
    let r = s.region;
    let _ = writeln!(
        o,
        "region        x {} .. {}, z {} .. {} m ({} ha), seed {}",
        number(r[0], 1),
        number(r[2], 1),
        number(r[1], 1),
        number(r[3], 1),
        number(s.hectares, 1),
        s.seed
    );
    let cut = if s.truncated {
        " (stopped by --max-count)"
    } else {
        ""
    };
    if s.trees == 0 {
        let _ = writeln!(o, "trees         no trees{cut}");
    } else {
        let _ = writeln!(
            o,
            "trees         {}{cut}, {} per hectare",
            s.trees,
            number(s.trees as f64 / s.hectares, 1)
        );
    }
    let _ = writeln!(
        o,
        "species       {:<14} {:>8} {:>9} {:>15}  map      texel",
        "", "trees", "per ha", "height m"
    );
    for sp in &s.species {
        let heights = sp.height_range.map_or(format!("{:>15}", "-"), |h| {
            format!("{:>6} .. {:>5}", number(h[0], 1), number(h[1], 1))
        });
        let _ = writeln!(
            o,
            "              {:<14} {:>8} {:>9} {heights}  {}  {}",
            printable(&sp.name),
            sp.trees,
            number(sp.per_hectare, 1),
            sp.map_color,
            printable(&sp.texel)
        );
    }
    match (s.min_distance, s.min_distance_ratio) {
        (Some(d), Some(r)) => {
            let _ = writeln!(
                o,
                "spacing       closest pair {} m; closest relative to the larger radius {} (the rule keeps it >= 1)",
                number(d, 2),
                number(r, 3)
            );
        }
        _ => {
            let _ = writeln!(o, "spacing       fewer than two trees");
        }
    }
    let most = s.height_bins.iter().map(|b| b.2).max().unwrap_or(1).max(1);
    let _ = writeln!(o, "heights");
    for (lo, hi, count) in &s.height_bins {
        let bar = "#".repeat((40 * count).div_ceil(most));
        let _ = writeln!(
            o,
            "  {:>6} .. {:>5} m {count:>8} {bar}",
            number(*lo, 1),
            number(*hi, 1)
        );
    }
    for (i, t) in s.terrain.iter().enumerate() {
        let label = if i == 0 { "terrain" } else { "" };
        let _ = writeln!(
            o,
            "{label:<13} {}  {} bytes  sha256 {}",
            printable(&t.path),
            t.bytes,
            hex(&t.sha256)
        );
    }
    if let Some(h) = &s.heightmap {
        let size = h
            .size
            .map_or("from its GeoTIFF tags".to_string(), |[x, z]| {
                format!("{} x {} m (--terrain-size)", shortest(x), shortest(z))
            });
        let heights = h.height_range.map_or("as stored".to_string(), |[lo, hi]| {
            format!("{} .. {} m (--height-range)", shortest(lo), shortest(hi))
        });
        let _ = writeln!(o, "heightmap     {size}, heights {heights}");
    }
    let sf = &s.species_file;
    let _ = writeln!(
        o,
        "species file  {}  sha256 {}",
        printable(&sf.path),
        hex(&sf.sha256)
    );
    o
}

/// The forest from above over its hillshaded terrain (north up), `long_side` pixels across
/// the longer side of the region; trees are discs of 0.4 of their spacing radius in their
/// species' colour. Without a terrain the ground is plain grey.
pub fn map(f: &StoredForest, terrain: Option<&Terrain>, long_side: usize) -> RgbImage {
    let r = f.info.region;
    let pixel = (r[2] - r[0]).max(r[3] - r[1]) / long_side as f64;
    let (w, h) = (
        (((r[2] - r[0]) / pixel).ceil() as usize).max(1),
        (((r[3] - r[1]) / pixel).ceil() as usize).max(1),
    );
    let shade = terrain.map(|t| {
        hillshade(&Heightfield::sample(
            t,
            r[0],
            r[1],
            r[0] + w as f64 * pixel,
            r[1] + h as f64 * pixel,
            pixel,
        ))
    });
    let mut img = RgbImage::new(w as u32, h as u32);
    for y in 0..h {
        for x in 0..w {
            let s = shade.as_ref().map_or(0.75, |s| s[x + w * y]);
            let c = if s.is_nan() {
                [255, 255, 255]
            } else {
                [0.80f32, 0.78, 0.70].map(|b| (255.0 * b * (0.3 + 0.7 * s)) as u8)
            };
            img.put_pixel(x as u32, y as u32, image::Rgb(c));
        }
    }
    for p in f.trees.iter() {
        let species = &f.info.species[p.species as usize];
        let radius = (0.4 * species.radius(p.scale as f64) / pixel).max(0.6);
        let (cx, cz) = (
            (p.position[0] - r[0]) / pixel,
            (p.position[2] - r[1]) / pixel,
        );
        let col = color(p.species as usize);
        // The pixels the disc can cover (centres within radius + 0.5), and only those in the
        // map: a valid file's disc may be far larger than the map, even infinite.
        let span = |c: f64, n: usize| {
            let lo = (c - radius - 1.0).floor().max(0.0);
            let hi = (c + radius + 1.0).ceil().min(n as f64 - 1.0);
            (lo <= hi).then_some(lo as usize..=hi as usize)
        };
        let (Some(xs), Some(ys)) = (span(cx, w), span(cz, h)) else {
            continue;
        };
        for py in ys {
            for px in xs.clone() {
                let d = ((px as f64 + 0.5 - cx).powi(2) + (py as f64 + 0.5 - cz).powi(2)).sqrt();
                // Antialiased edge: coverage falls off over one pixel.
                let a = (radius + 0.5 - d).clamp(0.0, 1.0) as f32 * 0.9;
                if a > 0.0 {
                    let px_ = img.get_pixel_mut(px as u32, py as u32);
                    for c in 0..3 {
                        px_.0[c] = (px_.0[c] as f32 * (1.0 - a) + col[c] as f32 * a) as u8;
                    }
                }
            }
        }
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::instances::{Forest, decode_stored, encode, tests};

    fn sample_forest(n: usize) -> StoredForest {
        stored(&tests::sample_forest(n))
    }

    fn stored(f: &Forest) -> StoredForest {
        decode_stored(&encode(f).unwrap()).unwrap()
    }

    #[test]
    fn a_tree_larger_than_the_map_covers_it_without_visiting_pixels_outside() {
        // Any positive finite spacing is valid: a tree's disc may be infinite, and the map
        // visits the pixels of its disc (this test never finished when it visited them all).
        let mut f = tests::sample_forest(1);
        f.info.species[0].spacing = 1e300;
        let img = map(&stored(&f), None, 64);
        let tree = color(0);
        let grey = map(&sample_forest(0), None, 64).get_pixel(0, 0).0;
        for p in img.pixels() {
            for c in 0..3 {
                let blend = grey[c] as f32 * 0.1 + tree[c] as f32 * 0.9;
                assert!((p.0[c] as f32 - blend).abs() <= 1.0, "{p:?}");
            }
        }
        // A disc of ordinary size still draws as before: its centre pixel in the tree's
        // colour, the far corner grey.
        let f = sample_forest(1);
        let img = map(&f, None, 64);
        assert_eq!(img.get_pixel(63, 63).0, grey);
        assert_ne!(img.get_pixel(0, 0).0, grey);
    }
}
