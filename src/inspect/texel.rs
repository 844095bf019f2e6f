//! What `texel inspect FILE.texel` reports.

use std::fmt::Write as _;

use serde::Serialize;

use super::{FileFacts, printable};
use crate::hex::hex;
use crate::number::{number, shortest};
use crate::provenance::SourceFile;
use glam::Vec3;

use crate::volume::{BakeParameters, DensityModel, Level, MaterialPart, Texel};

#[derive(Serialize, Debug)]
pub struct Summary {
    /// Format name and version, e.g. `texel 1.2`.
    pub format: String,
    pub generator: String,
    pub file_bytes: u64,
    /// The payload before compression, as the file declares it.
    pub raw_bytes: u64,
    pub density_model: DensityModel,
    /// gamma: extinction (1/m) per unit density.
    pub extinction_scale: f64,
    pub model_min: [f64; 3],
    pub model_max: [f64; 3],
    pub origin: [f64; 3],
    pub levels: Vec<LevelSummary>,
    /// Level 0, per channel.
    pub channels: Vec<ChannelStats>,
    /// Fraction of level-0 cells with any extinction.
    pub fill_ratio: f64,
    /// Of the level-0 cells with extinction, the fraction whose density gradient vanishes
    /// (uniform interiors) so that they have no normal.
    pub filled_without_normal: f64,
    pub triangles: u64,
    pub foliage_triangles: u64,
    /// Where each material went, wood or foliage, and why (files before v1.1 do not say).
    pub materials: Vec<MaterialPart>,
    /// Silhouette coverage along x, y, z: of the mesh (measured at bake) and as the texture's
    /// optical depth predicts it, 1 - mean exp(-tau) over level-0 columns.
    pub coverage_mesh: [f64; 3],
    pub coverage_texture: [f64; 3],
    pub sources: Vec<SourceFile>,
    #[serde(serialize_with = "crate::hex::hex32")]
    pub inputs_sha256: [u8; 32],
    pub parameters: BakeParameters,
}

#[derive(Serialize, Debug)]
pub struct LevelSummary {
    pub dims: [usize; 3],
    pub cell: f64,
    /// The level's directional extinction form `[S_xx, S_yy, S_zz, S_xy, S_xz, S_yz, c]`.
    pub directional: [f32; 7],
    /// Its factor along x, y and z, and the least and greatest over the sphere (sampled).
    pub factor_axes: [f32; 3],
    pub factor_range: [f32; 2],
    /// The factors on the tree's own extinction along a foliage sample's shadow ray, at the
    /// angles of [`crate::volume::SELF_SHADOW_ANGLES`] between eye and sun: pooled over suns
    /// of every height (what readers before texel 1.5 use), and one row per sun height of
    /// [`crate::volume::SUN_HEIGHTS`] (all the pooled row in files before 1.5), and rows by
    /// the eye's height and the sun's turn about the eye, `[eye height][sun turn]`, of
    /// [`crate::volume::EYE_HEIGHTS`] and [`crate::volume::SUN_TURNS`] (texel 1.6; `None`
    /// before, when a renderer reads the rows by sun height).
    pub self_shadow: [f32; 6],
    pub self_shadow_by_sun_height: [[f32; 6]; crate::volume::SUN_HEIGHTS.len()],
    pub self_shadow_by_view: Option<crate::volume::ByView>,
    /// The weight on the wood's extinction in choosing which part scatters (what readers
    /// before texel 1.7 use).
    pub wood_weight: f32,
    /// Where the level has the wood's shown density per cell (texel 1.7): the 10th, 50th and
    /// 90th percentiles of its weight (shown over stored density) over the cells holding both
    /// parts; `None` where it has none, or no such cell.
    pub wood_shown: Option<[f32; 3]>,
    /// Where the level draws solids (texel 1.3): the share of its cells whose centre is
    /// inside them, full foliage; `None` where it draws none.
    pub solid: Option<f64>,
}

#[derive(Serialize, Debug)]
pub struct ChannelStats {
    pub name: String,
    pub unit: String,
    /// The cells the figures are over: `all` cells, or only those with density of the
    /// channel's part (`wood` or `foliage`), where its albedo was measured rather than filled.
    pub over: &'static str,
    pub min: f64,
    pub max: f64,
    pub mean: f64,
}

fn stats(
    name: &str,
    unit: &str,
    over: &'static str,
    values: impl Iterator<Item = f64>,
) -> ChannelStats {
    let (mut min, mut max, mut sum, mut n) = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0usize);
    for v in values {
        min = min.min(v);
        max = max.max(v);
        sum += v;
        n += 1;
    }
    if n == 0 {
        (min, max) = (0.0, 0.0);
    }
    ChannelStats {
        name: name.into(),
        unit: unit.into(),
        over,
        min,
        max,
        mean: sum / n.max(1) as f64,
    }
}

/// Level 0's channels: densities and extinction, gradient magnitudes, and each part's albedo
/// over the cells that hold that part.
fn channel_stats(texel: &Texel) -> Vec<ChannelStats> {
    let (info, l0) = (&texel.info, &texel.levels[0]);
    let (density_unit, gradient_unit) = match info.density_model {
        DensityModel::Occupancy => ("1", "1/m"),
        DensityModel::Transmittance => ("1/m", "1/m^2"),
    };
    let mut channels = Vec::new();
    for part in 0..2 {
        let name = ["wood", "foliage"][part];
        channels.push(stats(
            &format!("density_{name}"),
            density_unit,
            "all",
            l0.density[part].iter().map(|&d| d as f64),
        ));
    }
    let scale = info.extinction_scale;
    channels.push(stats(
        "extinction (total)",
        "1/m",
        "all",
        (0..l0.cell_count()).map(|i| scale * (l0.density[0][i] + l0.density[1][i]) as f64),
    ));
    for part in 0..2 {
        let name = ["wood", "foliage"][part];
        channels.push(stats(
            &format!("|gradient_{name}|"),
            gradient_unit,
            "all",
            l0.gradient[part]
                .iter()
                .map(|g| (g[0] as f64).hypot(g[1] as f64).hypot(g[2] as f64)),
        ));
    }
    for part in 0..2 {
        let name = ["wood", "foliage"][part];
        for (c, ch) in ["r", "g", "b"].iter().enumerate() {
            // Only where the part is present: elsewhere albedo is a fill-in.
            let present = (0..l0.cell_count()).filter(|&i| l0.density[part][i] > 0.0);
            channels.push(stats(
                &format!("albedo_{name}.{ch}"),
                "linear",
                name,
                present.map(|i| l0.albedo[part][i][c] as f64),
            ));
        }
    }
    channels
}

/// A level's grid and its directional form, with the factors it gives along the axes and
/// their range over the sphere.
fn level_summary(l: &Level) -> LevelSummary {
    let factors: Vec<f32> = crate::geom::sphere_lattice(500)
        .map(|w| l.directional_factor(w))
        .collect();
    LevelSummary {
        dims: l.dims,
        cell: l.cell,
        directional: l.directional,
        self_shadow: l.self_shadow.pooled,
        self_shadow_by_sun_height: l.self_shadow.by_height,
        self_shadow_by_view: l.self_shadow.by_view,
        wood_weight: l.wood_weight,
        wood_shown: shown_percentiles(l),
        factor_axes: [Vec3::X, Vec3::Y, Vec3::Z].map(|w| l.directional_factor(w)),
        solid: l.has_solid().then(|| {
            let inside = (0..l.cell_count())
                .filter(|&i| l.solid[0][i] + l.solid[1][i] >= crate::volume::SOLID_LEVEL)
                .count();
            inside as f64 / l.cell_count() as f64
        }),
        factor_range: [
            factors.iter().copied().fold(f32::INFINITY, f32::min),
            factors.iter().copied().fold(0.0, f32::max),
        ],
    }
}

pub fn summarize(texel: &Texel, file: FileFacts) -> Summary {
    let info = &texel.info;
    let l0 = &texel.levels[0];
    let channels = channel_stats(texel);
    let n = l0.cell_count() as f64;
    let filled = (0..l0.cell_count())
        .filter(|&i| l0.density[0][i] + l0.density[1][i] > 0.0)
        .count();
    let without_normal = (0..l0.cell_count())
        .filter(|&i| l0.density[0][i] + l0.density[1][i] > 0.0)
        .filter(|&i| {
            let g = [0, 1, 2].map(|c| l0.gradient[0][i][c] + l0.gradient[1][i][c]);
            crate::volume::normal(g).is_none()
        })
        .count();
    let coverage_texture = [0, 1, 2].map(|a| texel.texture_coverage(a));
    Summary {
        format: format!("texel 1.{}", file.minor),
        generator: info.generator.clone(),
        file_bytes: file.bytes,
        raw_bytes: file.raw_bytes,
        density_model: info.density_model,
        extinction_scale: info.extinction_scale,
        model_min: info.model_min,
        model_max: info.model_max,
        origin: info.origin,
        levels: texel.levels.iter().map(level_summary).collect(),
        channels,
        fill_ratio: filled as f64 / n,
        filled_without_normal: without_normal as f64 / filled.max(1) as f64,
        triangles: info.triangles,
        foliage_triangles: info.foliage_triangles,
        materials: info.materials.clone(),
        coverage_mesh: info.mesh_coverage,
        coverage_texture,
        sources: info.sources.clone(),
        inputs_sha256: info.inputs_sha256,
        parameters: info.parameters.clone(),
    }
}

/// The summary as the lines `texel inspect` prints: the grid, the materials, what the
/// channels hold, and how the file was made.
pub fn to_text(s: &Summary) -> String {
    let mut o = String::new();
    write_grid(&mut o, s);
    write_materials(&mut o, s);
    write_contents(&mut o, s);
    write_provenance(&mut o, s);
    o
}

/// Format, size, resolution, levels, bounds and the density model.
fn write_grid(o: &mut String, s: &Summary) {
    let l0 = &s.levels[0];
    let _ = writeln!(
        o,
        "format        {} (written by {})",
        s.format,
        printable(&s.generator)
    );
    let _ = writeln!(
        o,
        "size          {} bytes on disk, {} raw ({:.1}x compression)",
        s.file_bytes,
        s.raw_bytes,
        s.raw_bytes as f64 / s.file_bytes.max(1) as f64
    );
    let _ = writeln!(
        o,
        "resolution    {} x {} x {} cells of {} m",
        l0.dims[0],
        l0.dims[1],
        l0.dims[2],
        number(l0.cell, 4)
    );
    let chain: Vec<String> = s
        .levels
        .iter()
        .map(|l| format!("{}x{}x{}", l.dims[0], l.dims[1], l.dims[2]))
        .collect();
    let _ = writeln!(o, "levels        {}: {}", s.levels.len(), chain.join(" "));
    let factors: Vec<String> = s
        .levels
        .iter()
        .map(|l| {
            let [x, y, z] = l.factor_axes;
            let [lo, hi] = l.factor_range;
            let [x, y, z, lo, hi] = [x, y, z, lo, hi].map(|v| number(v, 2));
            format!("{x}/{y}/{z} ({lo}..{hi})")
        })
        .collect();
    let _ = writeln!(
        o,
        "directional   extinction factor along x/y/z (range), per level: {}",
        factors.join("  ")
    );
    let solids: Vec<String> = s
        .levels
        .iter()
        .map(|l| {
            l.solid
                .map_or("-".to_string(), |v| number(v, 3).to_string())
        })
        .collect();
    if s.levels.iter().any(|l| l.solid.is_some()) {
        let _ = writeln!(
            o,
            "solids        share of cells inside the thick closed parts, drawn as surfaces, per level (-: none, density alone): {}",
            solids.join(" ")
        );
    }
    let angles: Vec<String> = crate::volume::SELF_SHADOW_ANGLES
        .iter()
        .map(|a| format!("{a}"))
        .collect();
    let _ = writeln!(
        o,
        "self-shadow   own-extinction factor of a leaf's shadow ray at {} degrees from the eye, per level: pooled over every sun, then per sun height where they differ (what 1.5 readers use), then per eye height and turn of the sun about the line of sight (1.6; what texel draws with where present)",
        angles.join("/")
    );
    let row = |r: &[f32; 6]| {
        r.iter()
            .map(|&k| number(k, 2).to_string())
            .collect::<Vec<_>>()
            .join(" ")
    };
    for (n, l) in s.levels.iter().enumerate() {
        let shown = match l.wood_shown {
            Some(p) => format!(
                "wood shown x {} / {} / {} per cell, 10th / 50th / 90th percentile; x {} to 1.6",
                number(p[0], 2),
                number(p[1], 2),
                number(p[2], 2),
                number(l.wood_weight, 2)
            ),
            None => format!("wood shown x {}", number(l.wood_weight, 2)),
        };
        let _ = writeln!(
            o,
            "              level {n}: {}   ({shown})",
            row(&l.self_shadow),
        );
        if l.self_shadow_by_sun_height
            .iter()
            .any(|r| *r != l.self_shadow)
        {
            for (r, h) in l
                .self_shadow_by_sun_height
                .iter()
                .zip(crate::volume::SUN_HEIGHTS)
            {
                let _ = writeln!(o, "                sun {h:>2} degrees high: {}", row(r));
            }
        }
        for (rows, e) in l
            .self_shadow_by_view
            .iter()
            .flatten()
            .zip(crate::volume::EYE_HEIGHTS)
        {
            // The turns of SUN_TURNS: 0, 90 and 180 degrees.
            for (r, turn) in rows.iter().zip(["above", "beside", "below"]) {
                let _ = writeln!(
                    o,
                    "                eye {e:>2} degrees high, sun {turn:<6} its line of sight: {}",
                    row(r)
                );
            }
        }
    }
    let f = |v: [f64; 3]| {
        let [x, y, z] = v.map(|c| number(c, 3));
        format!("({x}, {y}, {z})")
    };
    let _ = writeln!(
        o,
        "model bounds  {} .. {} m",
        f(s.model_min),
        f(s.model_max)
    );
    let _ = writeln!(o, "grid origin   {} m", f(s.origin));
    let model = match s.density_model {
        DensityModel::Occupancy => format!(
            "occupancy, extinction = {} /m x occupancy",
            number(s.extinction_scale, 4)
        ),
        DensityModel::Transmittance => "transmittance-calibrated extinction (1/m)".to_string(),
    };
    let _ = writeln!(o, "density       {model}");
    let _ = writeln!(
        o,
        "triangles     {} ({} foliage)",
        s.triangles, s.foliage_triangles
    );
}

/// Each material's part (wood or foliage) and why.
fn write_materials(o: &mut String, s: &Summary) {
    if s.materials.is_empty() {
        let _ = writeln!(o, "materials     not recorded (a file before texel 1.1)");
    } else {
        let _ = writeln!(o, "materials     part      triangles  alpha cut  why");
        for m in &s.materials {
            let _ = writeln!(
                o,
                "  {:<26} {:<8} {:>9}  {:>8.1}%  {}",
                printable(&m.name),
                if m.foliage { "foliage" } else { "wood" },
                m.triangles,
                100.0 * m.cut,
                m.reason.describe()
            );
        }
    }
}

/// Fill, coverage against the mesh, and each channel's range.
fn write_contents(o: &mut String, s: &Summary) {
    let _ = writeln!(
        o,
        "fill ratio    {:.3} of cells have extinction; {:.3} of those have no normal (zero gradient)",
        s.fill_ratio, s.filled_without_normal
    );
    let _ = writeln!(o, "coverage      axis   mesh    texture");
    for (a, name) in ["x", "y", "z"].iter().enumerate() {
        let _ = writeln!(
            o,
            "              {name}      {:.4}  {:.4}",
            s.coverage_mesh[a], s.coverage_texture[a]
        );
    }
    let _ = writeln!(
        o,
        "channels      (level 0)                     min          max         mean  over cells"
    );
    for c in &s.channels {
        let over = match c.over {
            "all" => "all",
            "wood" => "with wood",
            _ => "with foliage",
        };
        let _ = writeln!(
            o,
            "  {:<26} {:>6}  {:>11} {:>12} {:>12}  {over}",
            c.name,
            c.unit,
            number(c.min, 4),
            number(c.max, 4),
            number(c.mean, 4)
        );
    }
}

/// The bake's parameters and its input files' hashes.
fn write_provenance(o: &mut String, s: &Summary) {
    let p = &s.parameters;
    let gamma = p
        .requested_gamma
        .map_or("fitted".to_string(), |g| shortest(g).to_string());
    let wood = p
        .wood_pattern
        .as_ref()
        .map_or(String::new(), |w| format!(" --wood {w:?}"));
    let _ = writeln!(
        o,
        "bake          --resolution {} --fine {} --foliage {:?}{wood} gamma {gamma}",
        p.resolution, p.fine, p.foliage_pattern
    );
    let _ = writeln!(o, "inputs        sha256 {}", hex(&s.inputs_sha256));
    for src in &s.sources {
        let _ = writeln!(
            o,
            "  {}  {} bytes  sha256 {}",
            printable(&src.path),
            src.bytes,
            hex(&src.sha256)
        );
    }
}

/// The 10th, 50th and 90th percentiles of a level's per-cell wood weight (shown over stored
/// wood density) over the cells holding both parts: `None` without the channel or such cells.
fn shown_percentiles(l: &Level) -> Option<[f32; 3]> {
    let [wood, foliage] = &l.density;
    let mut w: Vec<f32> = (0..l.wood_shown.len())
        .filter(|&i| wood[i] > 0.0 && foliage[i] > 0.0)
        .map(|i| l.wood_shown[i] / wood[i])
        .collect();
    if w.is_empty() {
        return None;
    }
    w.sort_by(f32::total_cmp);
    Some([0.1, 0.5, 0.9].map(|q| w[((w.len() - 1) as f32 * q).round() as usize]))
}
