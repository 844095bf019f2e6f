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
        `inspect` shows any intermediate file to a person.\n\n\
        Exit status: 0 on success, 1 when an input or output is bad (the message names the \
        file and the problem), 2 for a malformed command line."
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

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Bake a glTF tree into a .texel 3D texture.
    Bake(BakeArgs),
    /// Describe a texel-forest file, as text, JSON or pictures.
    Inspect(InspectArgs),
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
    /// Case-insensitive regular expression on material names that marks foliage
    /// (alpha-masked materials are foliage too).
    #[arg(long, default_value = texel_forest::bake::DEFAULT_FOLIAGE, value_name = "REGEX")]
    pub foliage: String,
    /// Also write a Make rule listing every file the bake read.
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
    /// The file to describe (.texel).
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
    /// Where to write the picture (PNG).
    #[arg(short, long, value_name = "FILE.png")]
    pub output: Option<PathBuf>,
}
