//! Command-line flags, as clap derives them. Nothing here does work; `commands` turns these
//! into the library's settings.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

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
    /// Worker threads (default: one per core). Results are identical for any number.
    #[arg(long, global = true, value_name = "N")]
    pub threads: Option<usize>,
    /// Print nothing but errors and warnings.
    #[arg(long, short, global = true)]
    pub quiet: bool,
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
}

#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The render to judge (OpenEXR with R, G, B, A).
    #[arg(value_name = "A.exr")]
    pub image: PathBuf,
    /// The reference (OpenEXR with R, G, B, A, the same size and window).
    #[arg(value_name = "REFERENCE.exr")]
    pub reference: PathBuf,
    /// Also measure inside a mask: a PNG (pixels brighter than half inside) or an OpenEXR
    /// (alpha above one half inside), the size of the images.
    #[arg(long, value_name = "FILE")]
    pub mask: Option<PathBuf>,
    /// Print the measures as JSON.
    #[arg(long)]
    pub json: bool,
    /// Write a false-colour picture of each pixel's largest error (PNG).
    #[arg(long, value_name = "DIFF.png")]
    pub heatmap: Option<PathBuf>,
    /// The error the heatmap's brightest colour stands for (default: the largest error).
    #[arg(long, value_name = "ERROR", requires = "heatmap")]
    pub scale: Option<f32>,
    /// Exit with status 3 when the colour RMSE exceeds this (for build systems and tests).
    #[arg(long, value_name = "RMSE")]
    pub fail_above: Option<f64>,
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// The forest (.instances); its texels and terrain are found relative to it.
    pub instances: PathBuf,
    /// The image to write: OpenEXR, linear, scene-referred, premultiplied RGBA + Z.
    #[arg(short, long, value_name = "FRAME.exr")]
    pub output: PathBuf,
    /// The terrain (default: the one the forest was placed on).
    #[arg(long, value_name = "FILE")]
    pub terrain: Option<PathBuf>,
    /// A camera node of the terrain glTF (or of --camera-file), by name.
    #[arg(long, value_name = "NAME", conflicts_with_all = ["eye", "target"])]
    pub camera: Option<String>,
    /// A glTF file holding the camera named by --camera (and lights).
    #[arg(long, value_name = "FILE")]
    pub camera_file: Option<PathBuf>,
    /// Eye position (world metres).
    #[arg(
        long,
        value_name = "X,Y,Z",
        allow_hyphen_values = true,
        requires = "target"
    )]
    pub eye: Option<String>,
    /// Point looked at (world metres).
    #[arg(
        long,
        value_name = "X,Y,Z",
        allow_hyphen_values = true,
        requires = "eye"
    )]
    pub target: Option<String>,
    /// Vertical field of view, degrees.
    #[arg(long, value_name = "DEGREES")]
    pub fov: Option<f64>,
    /// Sun direction: compass azimuth (degrees clockwise from north, -Z) and elevation
    /// (default: a directional light of the glTF, else afternoon light from the south-west).
    #[arg(long, value_name = "AZ,EL", allow_hyphen_values = true)]
    pub sun: Option<String>,
    /// Day of the year for foliage colour and leaf fraction.
    #[arg(long, default_value_t = 200.0, value_name = "1..366")]
    pub day: f64,
    #[arg(long, default_value_t = 1280)]
    pub width: u32,
    #[arg(long, default_value_t = 720)]
    pub height: u32,
    /// Samples per pixel.
    #[arg(long, default_value_t = 1)]
    pub spp: u32,
    /// What draws the trees: their 3D textures, or the glTF models the textures were baked
    /// from (the conventional method; the ground truth at many samples per pixel).
    #[arg(long, value_enum, default_value_t = MethodArg::Texel)]
    pub method: MethodArg,
    /// Render only this part of the frame (pixels, x1 and y1 exclusive); equals the same region
    /// of a full render bit for bit.
    #[arg(long, value_name = "X0,Y0,X1,Y1")]
    pub crop: Option<String>,
    /// Also write an sRGB preview over a sky, for people.
    #[arg(long, value_name = "FRAME.png")]
    pub preview: Option<PathBuf>,
    /// Extra EXR layers: normal, albedo, canopy, species, samples (comma-separated).
    #[arg(long, value_delimiter = ',', value_name = "LIST")]
    pub aov: Vec<AovArg>,
    /// Write colour and AOVs as half floats (depth stays float).
    #[arg(long)]
    pub half: bool,
    /// Sky radiance (linear RGB) behind everything; without it the sky is transparent.
    #[arg(long, value_name = "R,G,B")]
    pub sky: Option<String>,
    /// Segment length in texture cells (smaller: slower, less noise).
    #[arg(long, default_value_t = 1.0)]
    pub step: f32,
    /// Transmittance at which a ray stops.
    #[arg(long, default_value_t = 1e-3)]
    pub cutoff: f32,
    /// Share of a pixel below which a sample's shadow ray is cast only by Russian roulette
    /// (unbiased; larger: faster, noisier; 0 casts them all).
    #[arg(long, default_value_t = 0.05, value_name = "SHARE")]
    pub shadow_share: f32,
    /// Mip levels added to what the pixel footprint asks for (negative: sharper, slower).
    #[arg(
        long,
        default_value_t = 0.0,
        allow_hyphen_values = true,
        value_name = "LEVELS"
    )]
    pub lod_bias: f32,
    /// Further mip levels for shadow rays.
    #[arg(long, default_value_t = 1.0, value_name = "LEVELS")]
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
}

#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum AovArg {
    Normal,
    Albedo,
    Canopy,
    Species,
    /// Volume samples and shadow rays per pixel: where the time goes.
    Samples,
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
    /// Texture cells along the model's longest side.
    #[arg(long, default_value_t = 32, value_name = "CELLS")]
    pub resolution: usize,
    /// Fine scan cells along the longest side (a multiple of --resolution).
    #[arg(long, default_value_t = 256, value_name = "CELLS")]
    pub fine: usize,
    /// How density becomes extinction.
    #[arg(long, value_enum, default_value_t = DensityArg::Transmittance)]
    pub density: DensityArg,
    /// Extinction per unit occupancy, 1/m (occupancy model; default: fitted to the mesh's
    /// silhouettes).
    #[arg(long, value_name = "PER_METRE")]
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

#[derive(Args, Debug)]
pub struct PlaceArgs {
    /// The terrain: a triangulated glTF surface, metres, +Y up.
    pub terrain: PathBuf,
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
    #[arg(long, value_name = "N")]
    pub max_count: Option<usize>,
    /// Place only within this rectangle of the ground plane (metres).
    #[arg(long, value_name = "X0,Z0,X1,Z1", allow_hyphen_values = true)]
    pub region: Option<String>,
    /// Cell of the height raster habitat is judged on (metres; default: the mesh's own
    /// resolution).
    #[arg(long, value_name = "METRES")]
    pub cell: Option<f64>,
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

#[derive(Args, Debug)]
pub struct InspectArgs {
    /// The file to describe (.texel or .instances).
    pub file: PathBuf,
    /// Print the summary as JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Picture of one slice of cells, e.g. `y=16` (needs -o).
    #[arg(long, value_name = "AXIS=INDEX", conflicts_with = "projection")]
    pub slice: Option<String>,
    /// Picture of the texture seen along an axis: colour and opacity accumulated front to back
    /// through the optical depth (needs -o).
    #[arg(long, value_enum, value_name = "AXIS")]
    pub projection: Option<AxisArg>,
    /// Mip level the pictures show (0 = finest).
    #[arg(long, default_value_t = 0)]
    pub level: usize,
    /// Top-down picture of a forest over its hillshaded terrain, trees coloured by species
    /// (.instances; needs -o).
    #[arg(long)]
    pub map: bool,
    /// Where to write the picture (PNG).
    #[arg(short, long, value_name = "FILE.png")]
    pub output: Option<PathBuf>,
}
