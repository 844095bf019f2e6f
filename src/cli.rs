//! Command-line flags, as clap derives them. Nothing here does work; `commands` turns these
//! into the library's settings.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};
use texel_forest::limits::Limits;

impl Cli {
    pub fn limits(&self) -> Limits {
        Limits {
            cells: self.max_cells,
            triangles: self.max_triangles,
            trees: self.max_trees,
            pixels: self.max_pixels,
            overlap: self.max_overlap,
        }
    }
}

// Value parsers: each flag's value is checked on its own here, before any work, so a bad value
// is a usage error (status 2) naming the flag. What depends on several flags or on the inputs
// is checked by the commands.

fn number(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a number"))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{s} is not a finite number"))
    }
}

fn numbers<const N: usize>(s: &str, what: &str) -> Result<[f64; N], String> {
    list(s, what, number)
}

/// Exactly `N` comma-separated values, each read by `parse` (`what` names the whole).
fn list<T: Copy + Default, const N: usize>(
    s: &str,
    what: &str,
    parse: impl Fn(&str) -> Result<T, String>,
) -> Result<[T; N], String> {
    let parts: Vec<&str> = s.split(',').collect();
    if parts.len() != N {
        return Err(format!("expected {what}"));
    }
    let mut out = [T::default(); N];
    for (o, p) in out.iter_mut().zip(parts) {
        *o = parse(p).map_err(|e| format!("{e}; expected {what}"))?;
    }
    Ok(out)
}

/// A number within `lo..=hi` (both inclusive where `closed`).
fn within(s: &str, lo: f64, hi: f64, what: &str) -> Result<f64, String> {
    let v = number(s)?;
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{v} is outside {lo}..{hi} ({what})"))
    }
}

fn at_least_one(s: &str) -> Result<u64, String> {
    match s.trim().parse::<u64>() {
        Ok(v) if v >= 1 => Ok(v),
        _ => Err(format!("{s:?} is not a whole number of at least 1")),
    }
}

/// A count of primitives one hierarchy holds (triangles, trees): at least 1, at most what its
/// indices can address.
fn primitive_count(s: &str) -> Result<u64, String> {
    let v = at_least_one(s)?;
    let most = texel_forest::geom::MAX_PRIMITIVES as u64;
    if v > most {
        return Err(format!(
            "{v} is over {most}, the most one hierarchy can index"
        ));
    }
    Ok(v)
}

fn positive(s: &str) -> Result<f64, String> {
    let v = number(s)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(format!("{v} is not positive"))
    }
}

fn non_negative(s: &str) -> Result<f64, String> {
    let v = number(s)?;
    if v >= 0.0 {
        Ok(v)
    } else {
        Err(format!("{v} is negative"))
    }
}

/// `X,Y,Z` in metres.
pub fn point(s: &str) -> Result<[f64; 3], String> {
    numbers::<3>(s, "three numbers X,Y,Z (metres)")
}

/// `X0,Z0,X1,Z1` in metres, a non-empty rectangle.
pub fn region(s: &str) -> Result<[f64; 4], String> {
    let r = numbers::<4>(s, "four numbers X0,Z0,X1,Z1 (metres)")?;
    if r[0] < r[2] && r[1] < r[3] {
        Ok(r)
    } else {
        Err("needs X0 < X1 and Z0 < Z1".into())
    }
}

/// `X,Z`: a heightmap's extent, two positive metres.
pub fn terrain_size(s: &str) -> Result<[f64; 2], String> {
    let r = numbers::<2>(s, "two extents X,Z (metres)")?;
    if r.iter().all(|&v| v > 0.0) {
        Ok(r)
    } else {
        Err("needs two positive extents".into())
    }
}

/// `LO,HI`: the heights (m) of a heightmap's lowest and highest integer sample, LO < HI.
pub fn height_range(s: &str) -> Result<[f64; 2], String> {
    let r = numbers::<2>(s, "two heights LO,HI (metres)")?;
    if r[0] < r[1] {
        Ok(r)
    } else {
        Err("needs LO < HI".into())
    }
}

/// `X0,Y0,X1,Y1` in pixels, whole and non-negative, a non-empty rectangle.
pub fn crop(s: &str) -> Result<[u32; 4], String> {
    let whole = |p: &str| {
        p.trim()
            .parse::<u32>()
            .map_err(|_| format!("{p:?} is not a whole number of pixels"))
    };
    let [x0, y0, x1, y1] = list(s, "four whole pixel numbers X0,Y0,X1,Y1", whole)?;
    if x0 < x1 && y0 < y1 {
        Ok([x0, y0, x1, y1])
    } else {
        Err("needs X0 < X1 and Y0 < Y1".into())
    }
}

/// `R,G,B` linear radiances, each within 0..=1e6.
pub fn radiance(s: &str) -> Result<[f64; 3], String> {
    let v = numbers::<3>(s, "three radiances R,G,B")?;
    if v.iter().all(|c| (0.0..=1e6).contains(c)) {
        Ok(v)
    } else {
        Err("each radiance must be within 0..1e6".into())
    }
}

/// `AZ,EL` in degrees: a compass azimuth and an elevation within -90..90.
pub fn sun_angles(s: &str) -> Result<[f64; 2], String> {
    let [az, el] = numbers::<2>(s, "an azimuth and an elevation in degrees, AZ,EL")?;
    if (-90.0..=90.0).contains(&el) {
        Ok([az, el])
    } else {
        Err(format!("elevation {el} must be within -90..90 degrees"))
    }
}

/// `AXIS=INDEX`, e.g. `y=16`.
pub fn slice(s: &str) -> Result<(usize, usize), String> {
    let bad = || "expected AXIS=INDEX such as y=16".to_string();
    let (axis, index) = s.split_once('=').ok_or_else(bad)?;
    let axis = match axis.trim().to_ascii_lowercase().as_str() {
        "x" => 0,
        "y" => 1,
        "z" => 2,
        _ => return Err(bad()),
    };
    Ok((axis, index.trim().parse().map_err(|_| bad())?))
}

/// Most frames one sequence may hold: hours of film at 24 frames a second.
pub const MAX_FRAMES: u32 = 1_000_000;

/// `A..B` (inclusive) or `N`: whole, non-negative frame numbers, A <= B, at most
/// [`MAX_FRAMES`] of them.
pub fn frames(s: &str) -> Result<(u32, u32), String> {
    let whole = |p: &str| {
        p.trim()
            .parse::<u32>()
            .map_err(|_| format!("{p:?} is not a whole, non-negative frame number"))
    };
    let (a, b) = match s.split_once("..") {
        Some((a, b)) => (whole(a)?, whole(b.strip_prefix('=').unwrap_or(b))?),
        None => {
            let n = whole(s)?;
            (n, n)
        }
    };
    if a > b {
        return Err(format!("the first frame {a} is after the last {b}"));
    }
    if b - a >= MAX_FRAMES {
        return Err(format!("more than {MAX_FRAMES} frames"));
    }
    Ok((a, b))
}

fn frame_rate(s: &str) -> Result<f64, String> {
    within(s, 1e-3, 1e4, "frames per second")
}

fn day(s: &str) -> Result<f64, String> {
    within(s, 1.0, 366.0, "a day of the year")
}

fn field_of_view(s: &str) -> Result<f64, String> {
    use texel_forest::render::camera::{fov_error, fov_ok};
    let v = number(s)?;
    if fov_ok(v) { Ok(v) } else { Err(fov_error(v)) }
}

/// A march's work grows as 1 / step: below 1/64 of a cell a frame would take days, and nothing
/// is gained (a cell's trilinear field is smooth well above it).
fn step(s: &str) -> Result<f32, String> {
    within(s, 1.0 / 64.0, 64.0, "cells per step").map(|v| v as f32)
}

fn cutoff(s: &str) -> Result<f32, String> {
    let v = number(s)?;
    if (0.0..1.0).contains(&v) {
        Ok(v as f32)
    } else {
        Err(format!("{v} is not a transmittance in [0, 1)"))
    }
}

fn share(s: &str) -> Result<f32, String> {
    within(s, 0.0, 1.0, "a share of a pixel").map(|v| v as f32)
}

/// `--edge-spp`: 0 for none, else 2 to 65536 (one sample is what every pixel has).
fn edge_spp(s: &str) -> Result<u32, String> {
    match s.parse::<u32>() {
        Ok(n) if n == 0 || (2..=65536).contains(&n) => Ok(n),
        _ => Err(format!(
            "{s} is not a sample count from 2 to 65536, or 0 for none"
        )),
    }
}

fn lod_bias(s: &str) -> Result<f32, String> {
    within(s, -16.0, 16.0, "mip levels").map(|v| v as f32)
}

fn lod_switch(s: &str) -> Result<f32, String> {
    within(s, 1.0 / 1024.0, 1024.0, "texture cells per footprint").map(|v| v as f32)
}

fn lod_band(s: &str) -> Result<f32, String> {
    within(s, 0.0, 16.0, "octaves of footprint").map(|v| v as f32)
}

fn shadow_lod(s: &str) -> Result<f32, String> {
    within(s, 0.0, 16.0, "mip levels").map(|v| v as f32)
}

fn gamma(s: &str) -> Result<f64, String> {
    let v = positive(s)?;
    if v <= 1e6 {
        Ok(v)
    } else {
        Err(format!(
            "{v} per metre is more than 1e6 (a mean free path under a micrometre)"
        ))
    }
}

fn cell_size(s: &str) -> Result<f64, String> {
    let v = positive(s)?;
    if v <= 1e6 {
        Ok(v)
    } else {
        Err(format!("{v} metres is more than 1e6"))
    }
}

#[derive(Parser, Debug)]
#[command(
    name = "texel",
    version,
    about = "Forest scenery from volumetric tree textures",
    long_about = "Forest scenery from volumetric tree textures.\n\n\
        Stages talk through files: `bake` turns a glTF tree into a .texel 3D texture, \
        `place` grows a forest of them on a terrain (.instances), `render` ray traces it to \
        OpenEXR, `compare` measures one render against another, `inspect` shows any \
        intermediate file to a person.\n\n\
        Exit status: 0 on success, 1 when an input or output is bad (the message names the \
        file and the problem), 2 for a malformed command line, 3 when `compare --fail-above` \
        finds the images too different."
)]
pub struct Cli {
    /// Worker threads, 1 to 1024 (default: one per core; at most four per core are started,
    /// with a warning). Results are identical for any number.
    #[arg(long, global = true, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=1024))]
    pub threads: Option<u16>,
    /// Print nothing but errors and warnings.
    #[arg(long, short, global = true)]
    pub quiet: bool,
    /// Most cells one texture may have, all levels (a damaged or hostile file can claim
    /// billions).
    #[arg(long, global = true, value_name = "N", default_value_t = Limits::default().cells, value_parser = at_least_one)]
    pub max_cells: u64,
    /// Most triangles one glTF scene may have once every node is instanced.
    #[arg(long, global = true, value_name = "N", default_value_t = Limits::default().triangles, value_parser = primitive_count)]
    pub max_triangles: u64,
    /// Most trees one forest may have.
    #[arg(long, global = true, value_name = "N", default_value_t = Limits::default().trees, value_parser = primitive_count)]
    pub max_trees: u64,
    /// Most pixels one image may have, read or written, and a glTF's images together.
    #[arg(long, global = true, value_name = "N", default_value_t = Limits::default().pixels, value_parser = at_least_one)]
    pub max_pixels: u64,
    /// Most trees of a forest to render that may stand over one tree's base (within their
    /// reach across the ground), itself included: a ray inside all their boxes at once pays
    /// for each, and a hand-made file can pile millions on one spot.
    #[arg(long, global = true, value_name = "N", default_value_t = Limits::default().overlap, value_parser = at_least_one)]
    pub max_overlap: u64,
    #[command(subcommand)]
    pub command: Command,
}

// Parsed once per run: the size of the largest variant does not matter.
#[allow(clippy::large_enum_variant)]
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Bake a glTF tree into a .texel 3D texture.
    Bake(BakeArgs),
    /// Place trees on a terrain: species chosen by habitat, Poisson-disk spacing.
    Place(PlaceArgs),
    /// Ray trace a forest over its terrain with volume rendering, to a linear OpenEXR.
    Render(RenderArgs),
    /// Describe a texel-forest file, as text, JSON or pictures.
    Inspect(InspectArgs),
    /// Measure the error of one render against a reference render.
    Compare(CompareArgs),
    /// Assemble a frame sequence's previews (PNG) into one animated PNG.
    Animate(AnimateArgs),
    /// Export a forest for other tools: a glTF of instanced tree models, tables of the trees.
    Export(ExportArgs),
}

#[derive(Args, Debug)]
pub struct AnimateArgs {
    /// The frames, in the order shown (e.g. `out/flyin/frame.*.png`, which the shell sorts).
    #[arg(required = true, value_name = "FRAME.png")]
    pub frames: Vec<PathBuf>,
    /// The animated PNG to write (APNG: every frame whole, looping).
    #[arg(short, long, value_name = "FILE.png")]
    pub output: PathBuf,
    /// Frames per second.
    #[arg(long, default_value_t = 24.0, value_name = "FPS", value_parser = frame_rate)]
    pub fps: f64,
    /// Scale every frame to this width (the height in proportion), for a small preview.
    #[arg(long, value_name = "PIXELS", value_parser = clap::value_parser!(u32).range(1..=65535))]
    pub width: Option<u32>,
}

#[derive(Args, Debug)]
#[command(
    group(clap::ArgGroup::new("mask_source").args(["mask", "temporal"])),
    override_usage = "texel compare [OPTIONS] <A.exr> <REFERENCE.exr>\n       \
                      texel compare [OPTIONS] --temporal <FRAME> <FRAME>..."
)]
pub struct CompareArgs {
    /// The render to judge (OpenEXR with R, G, B, A).
    #[arg(value_name = "A.exr", required_unless_present = "temporal")]
    pub image: Option<PathBuf>,
    /// The reference (OpenEXR with R, G, B, A, the same size and window).
    #[arg(value_name = "REFERENCE.exr", required_unless_present = "temporal")]
    pub reference: Option<PathBuf>,
    /// Measure instead the change from each frame of a sequence to the next (flicker), in the
    /// order given: camera motion is undone with each frame's Z and camera matrices (as
    /// `texel render` writes them); frames with the same matrices compare pixel for pixel.
    #[arg(long, value_name = "FRAME", num_args = 2..,
          conflicts_with_all = ["image", "reference", "mask", "heatmap", "fail_above"])]
    pub temporal: Option<Vec<PathBuf>>,
    /// Also measure inside a mask: a PNG (pixels brighter than half inside) or an OpenEXR
    /// (alpha above one half inside), the size of the images.
    #[arg(long, value_name = "FILE")]
    pub mask: Option<PathBuf>,
    /// The EXR mask's channel that marks inside (above one half; default `A`): e.g.
    /// `canopy.A` of a render with `--aov canopy`, for the pixels where trees are. With
    /// `--temporal`, each frame's own channel, and only the pixels inside are measured.
    #[arg(long, value_name = "NAME", requires = "mask_source")]
    pub mask_channel: Option<String>,
    /// Decide the mask in blocks of N x N pixels: a whole block is inside when more than half
    /// of its pixels are. A mask drawn from the reference's own matte favours the reference at
    /// silhouettes (a render with softer edges than the reference's has less canopy and more
    /// ground exactly there); at a block a few pixels wide, the mean ratio inside measures
    /// brightness rather than edge sharpness.
    #[arg(long, value_name = "N", default_value_t = 1, requires = "mask",
          conflicts_with = "temporal", value_parser = clap::value_parser!(u32).range(1..=256))]
    pub mask_block: u32,
    /// Print the measures as JSON.
    #[arg(long)]
    pub json: bool,
    /// Write a false-colour picture of each pixel's largest error (PNG).
    #[arg(long, value_name = "DIFF.png")]
    pub heatmap: Option<PathBuf>,
    /// The error the heatmap's brightest colour stands for (default: the largest error).
    #[arg(long, value_name = "ERROR", requires = "heatmap", conflicts_with = "temporal",
          value_parser = non_negative)]
    pub scale: Option<f64>,
    /// Exit with status 3 when the colour RMSE exceeds this, or when either image has a pixel
    /// that is not finite (for build systems and tests).
    #[arg(long, value_name = "RMSE", value_parser = non_negative)]
    pub fail_above: Option<f64>,
    /// With --temporal: leave out the pixels where this channel of the frame is above one half
    /// (e.g. `lod_band.A`: the canopy outside the hybrid's transition band, with `--mask-channel
    /// canopy.A`).
    #[arg(long, value_name = "NAME", conflicts_with_all = ["image", "reference"])]
    pub exclude_channel: Option<String>,
    /// With --temporal: how far, as a fraction of its depth, the next frame's Z may be from a
    /// point carried into it and still count as the same surface (beyond it the pixel is
    /// rejected as hidden or uncovered).
    // Not `requires = "temporal"`: clap waives a requirement that conflicts with a present
    // argument, and --temporal conflicts with the images.
    #[arg(long, value_name = "FRACTION", conflicts_with_all = ["image", "reference"],
          value_parser = non_negative,
          default_value_t = texel_forest::temporal::DEFAULT_DEPTH_TOLERANCE)]
    pub depth_tolerance: f64,
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The forest (.instances); its texels and terrain are found relative to it.
    pub instances: PathBuf,
    /// The image to write: OpenEXR, linear, scene-referred, premultiplied RGBA + Z.
    #[arg(short, long, value_name = "FRAME.exr")]
    pub output: PathBuf,
    /// The terrain (default: the one the forest was placed on, a heightmap converted as
    /// recorded): a glTF or a heightmap image.
    #[arg(long, value_name = "FILE")]
    pub terrain: Option<PathBuf>,
    /// With --terrain: how a heightmap becomes metres.
    #[command(flatten)]
    pub heightmap: HeightmapArgs,
    /// A perspective camera of the terrain glTF (or of --camera-file), by its name or the
    /// name of the node that places it.
    #[arg(long, value_name = "NAME", conflicts_with_all = ["eye", "target"])]
    pub camera: Option<String>,
    /// A glTF file holding the camera named by --camera (and lights).
    #[arg(long, value_name = "FILE")]
    pub camera_file: Option<PathBuf>,
    /// A moving camera: a keyframe file (`.json`, formats/camera-path.md) or a glTF with an
    /// animated camera (the one --camera names, else the first an animation moves). Renders a
    /// frame sequence: --frames, or every frame of the path at --fps.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["eye", "target", "camera_file"])]
    pub camera_path: Option<PathBuf>,
    /// Frames to render, `A..B` (inclusive) or `N`, at times frame / --fps: each to -o (and
    /// --preview) with the frame number in place of the `#`s of the file name, zero-padded to
    /// their count (frame.####.exr). Each frame draws its own noise and is the same bytes
    /// whichever frames are rendered with it.
    #[arg(long, value_name = "A..B", value_parser = frames)]
    pub frames: Option<(u32, u32)>,
    /// Frames per second of --frames.
    #[arg(long, default_value_t = 24.0, value_name = "FPS", value_parser = frame_rate)]
    pub fps: f64,
    /// Eye position (world metres).
    #[arg(
        long,
        value_name = "X,Y,Z",
        allow_hyphen_values = true,
        requires = "target",
        value_parser = point
    )]
    pub eye: Option<[f64; 3]>,
    /// Point looked at (world metres).
    #[arg(
        long,
        value_name = "X,Y,Z",
        allow_hyphen_values = true,
        requires = "eye",
        value_parser = point
    )]
    pub target: Option<[f64; 3]>,
    /// Vertical field of view, degrees (0.001 up to 179).
    #[arg(long, value_name = "DEGREES", value_parser = field_of_view)]
    pub fov: Option<f64>,
    /// Sun direction: compass azimuth (degrees clockwise from north, -Z) and elevation
    /// (default: a directional light of the glTF, else afternoon light from the south-west).
    #[arg(long, value_name = "AZ,EL", allow_hyphen_values = true, value_parser = sun_angles)]
    pub sun: Option<[f64; 2]>,
    /// Day of the year for foliage colour and leaf fraction.
    #[arg(long, default_value_t = 200.0, value_name = "1..366", value_parser = day)]
    pub day: f64,
    /// Image width in pixels.
    #[arg(long, default_value_t = 1280, value_parser = clap::value_parser!(u32).range(1..=65535))]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 720, value_parser = clap::value_parser!(u32).range(1..=65535))]
    pub height: u32,
    /// Samples per pixel: one in each of as many cells of equal area over the pixel, as square a
    /// grid as the count allows (16: 4 x 4; 6: 2 x 3).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=65536))]
    pub spp: u32,
    /// Send each sample's ray through a random point of its share of the pixel rather than
    /// its centre: unbiased (renders with different seeds average to the true image, as a
    /// reference must), but noisier at any --spp. Without it, samples sit at the centres of
    /// a grid of equal cells over the pixel.
    #[arg(long)]
    pub jitter: bool,
    /// Samples per pixel for a pixel at an edge, more than --spp: after a first pass at --spp,
    /// each pixel that differs from a neighbour by more than --edge-contrast is rendered again
    /// at this count (silhouettes against the sky and the terrain, where one ray sees all or
    /// none of what covers part of the pixel). 0: every pixel at --spp. Default: at --spp 1,
    /// the texel and hybrid methods render the outline again at 4 (pixels whose alpha differs
    /// from a neighbour's by more than a half: the terrain and the trees against the sky,
    /// which no texture level smooths); otherwise none.
    #[arg(long, value_name = "SPP", value_parser = edge_spp)]
    pub edge_spp: Option<u32>,
    /// The least difference to a neighbour that makes a pixel an edge (--edge-spp): in alpha,
    /// or in a colour channel compared as c / (1 + c).
    #[arg(long, default_value_t = 0.05, value_name = "C", value_parser = non_negative, requires = "edge_spp")]
    pub edge_contrast: f64,
    /// What draws the trees: their 3D textures, the glTF models the textures were baked
    /// from (the conventional method; the ground truth at many samples per pixel), or each
    /// tree whichever of the two its footprint needs. Default: hybrid, or texel (with a
    /// warning saying why) where a model the textures were baked from is missing or changed.
    #[arg(long, value_enum)]
    pub method: Option<MethodArg>,
    /// Hybrid method: the pixel footprint at a tree, in its finest texture cells, at which it
    /// is drawn from its texture and its model with equal chance (smaller footprints: the
    /// model; larger: the texture). Above 4 spp it grows with the square of spp / 4 (8 spp:
    /// 4x, 16 spp: 16x), where the models are faster at equal error.
    #[arg(long, default_value_t = 1.0, value_name = "CELLS", value_parser = lod_switch)]
    pub lod_switch: f32,
    /// Hybrid method: the width of the transition around --lod-switch, in octaves of
    /// footprint, across which trees are drawn by either at random in proportion (0: a hard
    /// switch).
    #[arg(long, default_value_t = 1.0, value_name = "OCTAVES", value_parser = lod_band)]
    pub lod_band: f32,
    /// Render only this part of the frame (pixels, x1 and y1 exclusive); equals the same region
    /// of a full render bit for bit.
    #[arg(long, value_name = "X0,Y0,X1,Y1", value_parser = crop)]
    pub crop: Option<[u32; 4]>,
    /// Also write an sRGB preview over a sky, for people.
    #[arg(long, value_name = "FRAME.png")]
    pub preview: Option<PathBuf>,
    /// Extra EXR layers: normal, albedo, canopy, species, lod, samples, cryptomatte
    /// (comma-separated).
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    pub aov: Vec<AovArg>,
    /// Write colour and AOVs as half floats (depth stays float).
    #[arg(long)]
    pub half: bool,
    /// Sky radiance (linear RGB, each 0 to 1e6) behind everything; without it the sky is
    /// transparent.
    #[arg(long, value_name = "R,G,B", value_parser = radiance)]
    pub sky: Option<[f64; 3]>,
    /// Light everything by the unshadowed sun: no shadow rays, nothing stands between any
    /// surface and the sun. For measuring shading apart from shadows (`make report`'s error
    /// budget); not a look.
    #[arg(long)]
    pub no_shadows: bool,
    /// How shadow rays cross the trees' textures: `cached`, one lookup per tree in a grid of
    /// optical depths towards the sun, built per species, level and turn of tree as the frame
    /// first needs it (no noise, interpolated between columns; see README); `exact`, a
    /// jittered march through each (unbiased, noisy; for references).
    #[arg(long, value_enum, default_value_t = ShadowsArg::Cached, value_name = "HOW")]
    pub shadows: ShadowsArg,
    /// Segment length in texture cells, 1/64 to 64 (smaller: slower, less noise).
    #[arg(long, default_value_t = 1.0, value_parser = step)]
    pub step: f32,
    /// Transmittance at which a ray stops, in [0, 1).
    #[arg(long, default_value_t = 1e-3, value_parser = cutoff)]
    pub cutoff: f32,
    /// Share of its ray's radiance (of the pixel, at 1 spp) below which a sample's shadow ray
    /// is cast only by Russian roulette (unbiased; larger: faster, noisier; 0 casts them all).
    /// Per ray, not per pixel, so the roulette's noise falls with --spp as the rest does.
    #[arg(long, default_value_t = 0.2, value_name = "SHARE", value_parser = share)]
    pub shadow_share: f32,
    /// Transmittance below which a view ray goes on only by Russian roulette, past each
    /// segment with probability transmittance / this (unbiased; larger: fewer samples,
    /// noisier; 0 marches every ray to --cutoff).
    #[arg(long, default_value_t = 0.05, value_name = "SHARE", value_parser = share)]
    pub view_share: f32,
    /// Mip levels added to what the pixel footprint asks for, as a footprint 2^LEVELS times as
    /// wide would ask (negative: sharper, slower; 2 at --spp 16 reads what --spp 1 reads).
    #[arg(
        long,
        default_value_t = 0.0,
        allow_hyphen_values = true,
        value_name = "LEVELS",
        value_parser = lod_bias
    )]
    pub lod_bias: f32,
    /// Further mip levels for shadow rays: coarser, blurrier shadows between trees (0: the
    /// level the view ray reads).
    #[arg(long, default_value_t = 0.0, value_name = "LEVELS", value_parser = shadow_lod)]
    pub shadow_lod: f32,
    /// Random seed of the sampling.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Also write a Make rule listing every file the render read.
    #[arg(long, value_name = "FILE")]
    pub depfile: Option<PathBuf>,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum MethodArg {
    /// Volume rendering of the 3D textures (the paper's method).
    Texel,
    /// Ray tracing the polygon models, with alpha-masked leaves.
    Mesh,
    /// Each tree as its footprint needs: the model near, the texture far (--lod-switch).
    Hybrid,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShadowsArg {
    Cached,
    Exact,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum AovArg {
    Normal,
    Albedo,
    Canopy,
    Species,
    /// Coverage drawn by meshes and by textures (lod_mesh.A, lod_texel.A), and by trees in the
    /// transition band (lod_band.A): the hybrid method's transitions.
    Lod,
    /// Volume samples and shadow rays per pixel: where the time goes.
    Samples,
    /// Cryptomatte ID mattes by species (CryptoSpecies) and by tree (CryptoInstance), with
    /// their manifests: pick species or single trees in Nuke's or Blender's Cryptomatte node.
    Cryptomatte,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum DensityArg {
    /// Extinction calibrated so axis-aligned views transmit what the mesh lets through.
    Transmittance,
    /// The paper's: solid occupancy times a coefficient gamma.
    Occupancy,
}

#[derive(Args, Debug)]
pub struct BakeArgs {
    /// The tree model: .gltf (with its buffers and images) or .glb. Metres, +Y up, origin at
    /// the base of the trunk.
    pub input: PathBuf,
    /// The .texel file to write.
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
    /// Texture cells along the model's longest side (1 to 256).
    #[arg(long, default_value_t = 32, value_name = "CELLS",
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new()
              .range(1..=texel_forest::bake::MAX_RESOLUTION as u64))]
    pub resolution: usize,
    /// Fine scan cells along the longest side (a multiple of --resolution, at most 4096; the
    /// occupancy model keeps 3 bytes a fine cell and takes at most 2^30 of them).
    #[arg(long, default_value_t = 256, value_name = "CELLS",
          value_parser = clap::builder::RangedU64ValueParser::<usize>::new()
              .range(1..=texel_forest::bake::MAX_FINE as u64))]
    pub fine: usize,
    /// How density becomes extinction.
    #[arg(long, value_enum, default_value_t = DensityArg::Transmittance)]
    pub density: DensityArg,
    /// Extinction per unit occupancy, 1/m (occupancy model; default: fitted to the mesh's
    /// silhouettes).
    #[arg(long, value_name = "PER_METRE", value_parser = gamma)]
    pub gamma: Option<f64>,
    /// Case-insensitive regular expression on material names that marks foliage. Materials
    /// whose alpha mask cuts shapes out of them (leaf cards) are foliage too.
    #[arg(long, default_value = texel_forest::bake::DEFAULT_FOLIAGE, value_name = "REGEX")]
    pub foliage: String,
    /// Case-insensitive regular expression on material names that marks wood, whatever
    /// --foliage or an alpha mask says (e.g. bark with holes in its texture).
    #[arg(long, value_name = "REGEX")]
    pub wood: Option<String>,
    /// Also write a Make rule listing every file the bake read.
    #[arg(long, value_name = "FILE")]
    pub depfile: Option<PathBuf>,
}

/// How a heightmap terrain becomes metres (formats/heightmap.md).
#[derive(Args, Debug, Default)]
pub struct HeightmapArgs {
    /// Heightmap terrain: its full extent east-west and north-south (metres), first sample
    /// to last; needed unless a GeoTIFF's tags say it.
    #[arg(long, value_name = "X,Z", value_parser = terrain_size)]
    pub terrain_size: Option<[f64; 2]>,
    /// Heightmap terrain of integer samples: the heights (metres) of sample 0 and of the
    /// largest value (255, 65535). Float samples are metres as stored.
    #[arg(long, value_name = "LO,HI", allow_hyphen_values = true, value_parser = height_range)]
    pub height_range: Option<[f64; 2]>,
}

impl HeightmapArgs {
    pub fn options(&self) -> texel_forest::terrain::HeightmapOptions {
        texel_forest::terrain::HeightmapOptions {
            size: self.terrain_size,
            height_range: self.height_range,
        }
    }
}

#[derive(Args, Debug)]
pub struct PlaceArgs {
    /// The terrain: a triangulated glTF surface (metres, +Y up), or a heightmap image (PNG,
    /// EXR, TIFF/GeoTIFF, .r16; see --terrain-size, --height-range).
    pub terrain: PathBuf,
    #[command(flatten)]
    pub heightmap: HeightmapArgs,
    /// The species description (JSON, see formats/species.md); texel paths in it are
    /// relative to it.
    #[arg(long, value_name = "FILE")]
    pub species: PathBuf,
    /// The .instances file to write.
    #[arg(short, long, value_name = "FILE")]
    pub output: PathBuf,
    /// Random seed: the same seed gives the same forest.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Stop after this many trees.
    #[arg(long, value_name = "N", value_parser = at_least_one)]
    pub max_count: Option<u64>,
    /// Place only within this rectangle of the ground plane (metres).
    #[arg(long, value_name = "X0,Z0,X1,Z1", allow_hyphen_values = true, value_parser = region)]
    pub region: Option<[f64; 4]>,
    /// Cell of the height raster habitat is judged on (metres; default: the mesh's own
    /// resolution).
    #[arg(long, value_name = "METRES", value_parser = cell_size)]
    pub cell: Option<f64>,
    /// Nothing grows where the ground is below this height (metres): sea level on a
    /// topo-bathymetric terrain (default: no limit).
    #[arg(long, value_name = "METRES", allow_hyphen_values = true, value_parser = number)]
    pub sea_level: Option<f64>,
    /// Also write a Make rule listing every file placement read.
    #[arg(long, value_name = "FILE")]
    pub depfile: Option<PathBuf>,
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum AxisArg {
    X,
    Y,
    Z,
}

impl AxisArg {
    /// 0, 1 or 2 for x, y or z.
    pub fn index(self) -> usize {
        self as usize
    }
}

#[derive(Args, Debug)]
pub struct InspectArgs {
    /// The file to describe: a .texel, a .instances, a terrain (.glb, .gltf or a heightmap
    /// image), or a frame `texel render` wrote (.exr).
    pub file: PathBuf,
    /// Terrain: how a heightmap becomes metres.
    #[command(flatten)]
    pub heightmap: HeightmapArgs,
    /// Print the summary as JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Picture of one slice of cells, e.g. `y=16` (needs -o).
    #[arg(long, value_name = "AXIS=INDEX", conflicts_with = "projection", value_parser = slice)]
    pub slice: Option<(usize, usize)>,
    /// Picture of the texture seen along an axis: colour and opacity accumulated front to back
    /// through the optical depth (needs -o).
    #[arg(long, value_enum, value_name = "AXIS")]
    pub projection: Option<AxisArg>,
    /// Mip level the pictures show (0 = finest).
    #[arg(long, default_value_t = 0)]
    pub level: usize,
    /// Top-down picture of a forest over its hillshaded terrain, trees coloured by species
    /// (.instances), or of a terrain's attributes (needs -o).
    #[arg(long)]
    pub map: bool,
    /// Terrain: judge the ground with this species file's analysis settings, and say how much
    /// of it suits each species.
    #[arg(long, value_name = "FILE")]
    pub species: Option<PathBuf>,
    /// Terrain: the raster cell (metres; default: the mesh's own resolution).
    #[arg(long, value_name = "METRES", value_parser = cell_size)]
    pub cell: Option<f64>,
    /// Terrain: only this rectangle of the ground plane (metres).
    #[arg(long, value_name = "X0,Z0,X1,Z1", allow_hyphen_values = true, value_parser = region)]
    pub region: Option<[f64; 4]>,
    /// Terrain: ground below this height (metres) suits no species.
    #[arg(long, value_name = "METRES", allow_hyphen_values = true, value_parser = number)]
    pub sea_level: Option<f64>,
    /// Where to write the picture (PNG).
    #[arg(short, long, value_name = "FILE.png")]
    pub output: Option<PathBuf>,
}

#[derive(Args, Debug)]
#[command(group = clap::ArgGroup::new("outputs").required(true).multiple(true)
    .args(["output", "csv", "json"]))]
pub struct ExportArgs {
    /// The forest (.instances); its texels, their models and its terrain are found relative
    /// to it.
    pub instances: PathBuf,
    /// A glTF 2.0 placing each species' source model once per tree
    /// (EXT_mesh_gpu_instancing), the models copied in whole: binary (.glb), or for a name
    /// ending .gltf a JSON text with its buffer inline (base64).
    #[arg(short, long, value_name = "FILE.glb|FILE.gltf")]
    pub output: Option<PathBuf>,
    /// Also put the terrain the forest was placed on into the glTF.
    #[arg(long, requires = "output")]
    pub with_terrain: bool,
    /// One line per tree: x,y,z (m), rotation_deg (about +Y), scale, height_m, species,
    /// variation.
    #[arg(long, value_name = "FILE.csv")]
    pub csv: Option<PathBuf>,
    /// The same table as JSON.
    #[arg(long, value_name = "FILE.json")]
    pub json: Option<PathBuf>,
    /// Also write a Make rule listing every file the export read.
    #[arg(long, value_name = "FILE")]
    pub depfile: Option<PathBuf>,
}
