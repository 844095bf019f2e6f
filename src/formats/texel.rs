//! `.texel` v1: a baked 3D texture (see `formats/texel.md`, which this module mirrors).
//!
//! Reading follows the container's order: framing and checksum, then the header (decoded and
//! validated, limits checked), and only then the payload, whose decompressed size the header
//! has already justified.

use bincode::{Decode, Encode};

use super::container::{self, ContainerError, header_config};
use crate::limits::{LimitError, Limits};
use crate::number::shortest;
use crate::provenance::SourceFile;
use crate::volume::{
    BakeParameters, ByView, DensityModel, EYE_HEIGHTS, Level, MaterialPart, PartReason,
    SUN_HEIGHTS, SUN_TURNS, SelfShadow, Texel, TexelInfo,
};

pub const MAGIC: &[u8; 8] = b"\x89TEXEL\r\n";
pub const MAJOR: u16 = 1;
/// The newest minor version, which this writes where a texture needs it and reads with every
/// older one (`formats/texel.md`, *Versions*).
pub const MINOR: u16 = 7;

/// Limits a reader enforces before it allocates anything a header asks for.
const MAX_LEVELS: usize = 16;
const MAX_SIDE: u32 = 4096;
const MAX_CHANNELS: usize = 64;
const MAX_MATERIALS: usize = 1 << 16;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Encode, Decode)]
pub enum Encoding {
    /// IEEE 754 binary32, little-endian.
    F32,
    /// Unsigned 16-bit little-endian integer n standing for n / 65535.
    Unorm16,
}

impl Encoding {
    fn size(self) -> usize {
        match self {
            Encoding::F32 => 4,
            Encoding::Unorm16 => 2,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Eq, Encode, Decode)]
pub(crate) struct ChannelHeader {
    pub(crate) name: String,
    pub(crate) components: u8,
    pub(crate) encoding: Encoding,
    pub(crate) unit: String,
}

#[derive(Clone, Debug, PartialEq, Encode, Decode)]
pub(crate) struct LevelHeader {
    pub(crate) dims: [u32; 3],
    pub(crate) cell: f64,
}

/// `Parameters` as v1.0 encodes them.
#[derive(Clone, Debug, PartialEq, Encode, Decode)]
pub(crate) struct Parameters {
    pub(crate) resolution: u32,
    pub(crate) fine: u32,
    pub(crate) foliage_pattern: String,
    pub(crate) requested_gamma: Option<f64>,
}

/// The v1.0 header exactly as it is encoded; field order is the byte order.
#[derive(Clone, Debug, PartialEq, Encode, Decode)]
pub(crate) struct Header {
    pub(crate) generator: String,
    pub(crate) model_min: [f64; 3],
    pub(crate) model_max: [f64; 3],
    pub(crate) origin: [f64; 3],
    pub(crate) density_model: DensityModel,
    pub(crate) extinction_scale: f64,
    pub(crate) triangles: u64,
    pub(crate) foliage_triangles: u64,
    pub(crate) mesh_coverage: [f64; 3],
    pub(crate) sources: Vec<SourceFile>,
    pub(crate) inputs_sha256: [u8; 32],
    pub(crate) parameters: Parameters,
    pub(crate) levels: Vec<LevelHeader>,
    pub(crate) channels: Vec<ChannelHeader>,
}

/// The oldest minor version `texel render` draws: its foliage is shaded from the leaf normals
/// and shadows itself by the self-shadowing factors 1.2 adds, which older files lack (they
/// are still read, by `inspect` for one).
pub const RENDER_MINOR: u16 = 2;

/// What minor version 1 appends to the header.
#[derive(Clone, Debug, PartialEq, Encode, Decode, Default)]
pub(crate) struct HeaderV1_1 {
    pub(crate) wood_pattern: Option<String>,
    pub(crate) materials: Vec<MaterialRecord>,
}

/// What minor version 2 appends to the header.
#[derive(Clone, Debug, PartialEq, Encode, Decode, Default)]
pub(crate) struct HeaderV1_2 {
    /// Per level, finest first: the directional extinction form, `[S_xx, S_yy, S_zz, S_xy,
    /// S_xz, S_yz, c]`.
    pub(crate) directional: Vec<[f32; 7]>,
    /// Per level, finest first: the self-shadowing factors at the angles of
    /// [`crate::volume::SELF_SHADOW_ANGLES`].
    pub(crate) self_shadow: Vec<[f32; 6]>,
    /// Per level, finest first: the weight on the wood's extinction in choosing which part
    /// scatters.
    pub(crate) wood_weight: Vec<f32>,
}

/// What minor version 5 appends to the header.
#[derive(Clone, Debug, PartialEq, Encode, Decode, Default)]
pub(crate) struct HeaderV1_5 {
    /// Per level, finest first: the self-shadowing factors at the angles of
    /// [`crate::volume::SELF_SHADOW_ANGLES`], one row per sun height of
    /// [`crate::volume::SUN_HEIGHTS`].
    pub(crate) self_shadow_by_height: Vec<[[f32; 6]; SUN_HEIGHTS.len()]>,
}

/// What minor version 6 appends to the header.
#[derive(Clone, Debug, PartialEq, Encode, Decode, Default)]
pub(crate) struct HeaderV1_6 {
    /// Per level, finest first: the self-shadowing factors at the angles of
    /// [`crate::volume::SELF_SHADOW_ANGLES`], one row per eye height of
    /// [`crate::volume::EYE_HEIGHTS`] and sun turn of [`crate::volume::SUN_TURNS`].
    pub(crate) self_shadow_by_view: Vec<ByView>,
}

/// Bounds of a wood weight (the bake's fit stays within 1/64 to 64).
const WOOD_WEIGHT_RANGE: std::ops::RangeInclusive<f32> = (1.0 / 4096.0)..=4096.0;

/// Largest self-shadowing factor (the bake's fit stays within 16).
const SELF_SHADOW_MAX: f32 = 64.0;

/// Largest magnitude of a directional form's entry (64^2: a factor of 64 along an axis).
const DIRECTIONAL_MAX: f32 = 4096.0;

#[derive(Clone, Debug, PartialEq, Encode, Decode)]
pub(crate) struct MaterialRecord {
    pub(crate) name: String,
    pub(crate) reason: Reason,
    pub(crate) cut: f32,
    pub(crate) triangles: u64,
}

/// `PartReason` as encoded: the variant index is the byte value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Encode, Decode)]
pub(crate) enum Reason {
    WoodPattern,
    FoliagePattern,
    AlphaCuts,
    Solid,
}

impl From<PartReason> for Reason {
    fn from(r: PartReason) -> Reason {
        match r {
            PartReason::WoodPattern => Reason::WoodPattern,
            PartReason::FoliagePattern => Reason::FoliagePattern,
            PartReason::AlphaCuts => Reason::AlphaCuts,
            PartReason::Solid => Reason::Solid,
        }
    }
}

impl From<Reason> for PartReason {
    fn from(r: Reason) -> PartReason {
        match r {
            Reason::WoodPattern => PartReason::WoodPattern,
            Reason::FoliagePattern => PartReason::FoliagePattern,
            Reason::AlphaCuts => PartReason::AlphaCuts,
            Reason::Solid => PartReason::Solid,
        }
    }
}

/// The channels of v1.0, in payload order. Later minor versions may append channels, which
/// v1.0 readers skip.
fn v1_channels(model: DensityModel) -> Vec<ChannelHeader> {
    let density_unit = match model {
        DensityModel::Occupancy => "1",
        DensityModel::Transmittance => "1/m",
    };
    let gradient_unit = match model {
        DensityModel::Occupancy => "1/m",
        DensityModel::Transmittance => "1/m^2",
    };
    let ch = |name: &str, components, encoding, unit: &str| ChannelHeader {
        name: name.to_string(),
        components,
        encoding,
        unit: unit.to_string(),
    };
    vec![
        ch("density_wood", 1, Encoding::F32, density_unit),
        ch("density_foliage", 1, Encoding::F32, density_unit),
        ch("gradient_wood", 3, Encoding::F32, gradient_unit),
        ch("gradient_foliage", 3, Encoding::F32, gradient_unit),
        ch("albedo_wood", 3, Encoding::Unorm16, "linear"),
        ch("albedo_foliage", 3, Encoding::Unorm16, "linear"),
    ]
}

/// The channel 1.2 appends: the foliage's leaf-normal moment `E[n n^T]`, `[xx, yy, zz, xy, xz,
/// yz]`, as F32. Optional for readers.
const LEAVES: &str = "leaves_foliage";

fn leaves_channel() -> ChannelHeader {
    ChannelHeader {
        name: LEAVES.to_string(),
        components: 6,
        encoding: Encoding::F32,
        unit: "1".to_string(),
    }
}

/// The channels 1.3 appends: each part's solid, the fraction of a cell inside the model's
/// thick closed parts, as Unorm16. Optional for readers (none: no solids).
const SOLIDS: [&str; 2] = ["solid_wood", "solid_foliage"];

fn solid_channel(name: &str) -> ChannelHeader {
    ChannelHeader {
        name: name.to_string(),
        components: 1,
        encoding: Encoding::Unorm16,
        unit: "1".to_string(),
    }
}

/// The channel 1.4 appends: the wood's normal moment, laid out as `leaves_foliage`. Optional
/// for readers (none: the wood is shaded on its density gradient).
const WOOD_NORMALS: &str = "normals_wood";

fn wood_normals_channel() -> ChannelHeader {
    ChannelHeader {
        name: WOOD_NORMALS.to_string(),
        ..leaves_channel()
    }
}

/// The channel 1.7 appends: the wood's density as it counts in choosing which part of a
/// sample scatters (`Level::wood_shown`), in the density's unit, as F32. Optional for readers
/// (none: the level's `wood_weight` times the wood's density).
const WOOD_SHOWN: &str = "shown_wood";

fn wood_shown_channel(model: DensityModel) -> ChannelHeader {
    ChannelHeader {
        name: WOOD_SHOWN.to_string(),
        ..v1_channels(model).swap_remove(0)
    }
}

/// Whether a texture carries the wood's shown density (every level or none).
fn has_wood_shown(texel: &Texel) -> bool {
    texel.levels.iter().any(|l| !l.wood_shown.is_empty())
}

/// Whether a texture carries the wood's normal moments (every level or none).
fn has_wood_normals(texel: &Texel) -> bool {
    texel.levels.iter().any(|l| !l.wood_normals.is_empty())
}

/// Whether a texture draws solids: only then are the solid channels written (a 1.3 file, or
/// 1.4 with the wood's normals); a texture with neither is written as 1.2 wrote it, byte for
/// byte.
fn has_solids(texel: &Texel) -> bool {
    texel.levels.iter().any(Level::has_solid)
}

/// Every channel this version writes for `texel`, in payload order.
fn channels(texel: &Texel) -> Vec<ChannelHeader> {
    let mut channels = v1_channels(texel.info.density_model);
    channels.push(leaves_channel());
    if has_solids(texel) {
        channels.extend(SOLIDS.map(solid_channel));
    }
    if has_wood_normals(texel) {
        channels.push(wood_normals_channel());
    }
    if has_wood_shown(texel) {
        channels.push(wood_shown_channel(texel.info.density_model));
    }
    channels
}

#[derive(Debug, thiserror::Error)]
pub enum TexelError {
    #[error(transparent)]
    Container(#[from] ContainerError),
    #[error("corrupt header: {0}")]
    Header(String),
    #[error("corrupt payload: {0}")]
    Payload(String),
    #[error(transparent)]
    Limit(#[from] LimitError),
    /// What a writer refuses to write, because readers would refuse it.
    #[error("cannot write this texture: {0}")]
    Unwritable(String),
}

fn unorm16(v: f32) -> [u8; 2] {
    ((v.clamp(0.0, 1.0) * 65535.0).round() as u16).to_le_bytes()
}

/// Encodes a texture as `.texel` bytes (deterministic: same texture, same bytes). Refuses what
/// a reader would refuse: the header's rules and non-finite or negative values.
pub fn encode(texel: &Texel) -> Result<Vec<u8>, TexelError> {
    let unwritable = |e: TexelError| TexelError::Unwritable(e.to_string());
    every_level_or_none(texel, "wood normals", |l| l.wood_normals.len())?;
    every_level_or_none(texel, "shown wood", |l| l.wood_shown.len())?;
    let parts = parts(texel);
    validate(
        &parts.header,
        &parts.extension,
        Some(&parts.extension2),
        parts.extension5.as_ref(),
        parts.extension6.as_ref(),
    )
    .map_err(unwritable)?;
    for level in &texel.levels {
        check_values(level).map_err(unwritable)?;
    }
    Ok(assemble(&parts)?)
}

/// An optional channel (`len` values a level) is one of every level or of none: where some
/// level has it, a level whose count is not its cell count is refused.
fn every_level_or_none(
    texel: &Texel,
    what: &str,
    len: impl Fn(&Level) -> usize,
) -> Result<(), TexelError> {
    if texel.levels.iter().all(|l| len(l) == 0) {
        return Ok(());
    }
    match texel.levels.iter().find(|l| len(l) != l.cell_count()) {
        Some(l) => Err(TexelError::Unwritable(format!(
            "{what} of {} cells in a level of {}",
            len(l),
            l.cell_count()
        ))),
        None => Ok(()),
    }
}

/// A file's three parts before they are put in the container.
pub(crate) struct Parts {
    pub(crate) header: Header,
    pub(crate) extension: HeaderV1_1,
    pub(crate) extension2: HeaderV1_2,
    /// Where some level's self-shadowing depends on the sun's height (and wherever there is
    /// an `extension6`, which follows it).
    pub(crate) extension5: Option<HeaderV1_5>,
    /// Where some level's self-shadowing depends on the eye's height and the sun's turn.
    pub(crate) extension6: Option<HeaderV1_6>,
    pub(crate) payload: Vec<u8>,
    /// 7 where the payload holds the shown wood, else 6 where the header holds self-shadowing
    /// by eye height and sun turn, else 5 where it holds it by sun height, else 4 where the
    /// payload holds the wood's normals, else 3 where it holds solids, else 2.
    pub(crate) minor: u16,
}

fn parts(texel: &Texel) -> Parts {
    let info = &texel.info;
    // The optional channels, each of every level or none: asked once, not per level.
    let (solids, wood_normals, wood_shown) = (
        has_solids(texel),
        has_wood_normals(texel),
        has_wood_shown(texel),
    );
    let header = Header {
        generator: info.generator.clone(),
        model_min: info.model_min,
        model_max: info.model_max,
        origin: info.origin,
        density_model: info.density_model,
        extinction_scale: info.extinction_scale,
        triangles: info.triangles,
        foliage_triangles: info.foliage_triangles,
        mesh_coverage: info.mesh_coverage,
        sources: info.sources.clone(),
        inputs_sha256: info.inputs_sha256,
        parameters: Parameters {
            resolution: info.parameters.resolution,
            fine: info.parameters.fine,
            foliage_pattern: info.parameters.foliage_pattern.clone(),
            requested_gamma: info.parameters.requested_gamma,
        },
        levels: texel
            .levels
            .iter()
            .map(|l| LevelHeader {
                dims: l.dims.map(|d| d as u32),
                cell: l.cell,
            })
            .collect(),
        channels: channels(texel),
    };
    let extension = HeaderV1_1 {
        wood_pattern: info.parameters.wood_pattern.clone(),
        materials: info
            .materials
            .iter()
            .map(|m| MaterialRecord {
                name: m.name.clone(),
                reason: m.reason.into(),
                cut: m.cut,
                triangles: m.triangles,
            })
            .collect(),
    };
    let extension2 = HeaderV1_2 {
        directional: texel.levels.iter().map(|l| l.directional).collect(),
        self_shadow: texel.levels.iter().map(|l| l.self_shadow.pooled).collect(),
        wood_weight: texel.levels.iter().map(|l| l.wood_weight).collect(),
    };
    let mut payload = Vec::new();
    for level in &texel.levels {
        for part in 0..2 {
            payload.extend(level.density[part].iter().flat_map(|v| v.to_le_bytes()));
        }
        for part in 0..2 {
            payload.extend(
                level.gradient[part]
                    .iter()
                    .flatten()
                    .flat_map(|v| v.to_le_bytes()),
            );
        }
        for part in 0..2 {
            payload.extend(
                level.albedo[part]
                    .iter()
                    .flatten()
                    .flat_map(|&v| unorm16(v)),
            );
        }
        payload.extend(level.leaves.iter().flatten().flat_map(|m| m.to_le_bytes()));
        if solids {
            for part in 0..2 {
                if level.has_solid() {
                    payload.extend(level.solid[part].iter().flat_map(|&v| unorm16(v)));
                } else {
                    payload.extend(std::iter::repeat_n(0u8, 2 * level.cell_count()));
                }
            }
        }
        if wood_normals {
            payload.extend(
                level
                    .wood_normals
                    .iter()
                    .flatten()
                    .flat_map(|m| m.to_le_bytes()),
            );
        }
        if wood_shown {
            payload.extend(level.wood_shown.iter().flat_map(|v| v.to_le_bytes()));
        }
    }
    // A texture whose self-shadowing is one row for every sun height is the file it was
    // before 1.5, byte for byte, and one without rows by view the file it was before 1.6;
    // a 1.7 file (shown wood) has both fields, as its minor version says.
    let extension6 = (wood_shown || texel.levels.iter().any(|l| l.self_shadow.by_view.is_some()))
        .then(|| HeaderV1_6 {
            self_shadow_by_view: texel
                .levels
                .iter()
                .map(|l| {
                    let s = &l.self_shadow;
                    s.by_view
                        .unwrap_or([[s.pooled; SUN_TURNS.len()]; EYE_HEIGHTS.len()])
                })
                .collect(),
        });
    let extension5 = (extension6.is_some()
        || texel
            .levels
            .iter()
            .any(|l| l.self_shadow != SelfShadow::uniform(l.self_shadow.pooled)))
    .then(|| HeaderV1_5 {
        self_shadow_by_height: texel
            .levels
            .iter()
            .map(|l| l.self_shadow.by_height)
            .collect(),
    });
    Parts {
        header,
        extension,
        extension2,
        minor: if wood_shown {
            7
        } else if extension6.is_some() {
            6
        } else if extension5.is_some() {
            5
        } else if wood_normals {
            4
        } else if solids {
            3
        } else {
            2
        },
        extension5,
        extension6,
        payload,
    }
}

fn assemble(parts: &Parts) -> Result<Vec<u8>, ContainerError> {
    let too_large =
        |e: bincode::error::EncodeError| ContainerError::TooLarge(format!("header: {e}"));
    let mut header = bincode::encode_to_vec(&parts.header, header_config()).map_err(too_large)?;
    header.extend(bincode::encode_to_vec(&parts.extension, header_config()).map_err(too_large)?);
    header.extend(bincode::encode_to_vec(&parts.extension2, header_config()).map_err(too_large)?);
    if let Some(e) = &parts.extension5 {
        header.extend(bincode::encode_to_vec(e, header_config()).map_err(too_large)?);
    }
    if let Some(e) = &parts.extension6 {
        header.extend(bincode::encode_to_vec(e, header_config()).map_err(too_large)?);
    }
    container::write(MAGIC, MAJOR, parts.minor, &header, &parts.payload)
}

/// A file the writer would refuse: `texel`'s parts with `edit` applied, put in a container
/// without any check. For the corpus of invalid files readers are tested against.
#[cfg(feature = "dev-tools")]
pub(crate) fn forge(texel: &Texel, edit: impl FnOnce(&mut Parts)) -> Vec<u8> {
    let mut p = parts(texel);
    edit(&mut p);
    assemble(&p).unwrap_or_default()
}

/// `texel` as a 1.1 writer wrote it: without the 1.2 header fields and the channels after
/// 1.0's. For tests of how older files are read and refused.
#[cfg(feature = "dev-tools")]
pub fn encode_v1_1(texel: &Texel) -> Vec<u8> {
    let mut p = parts(texel);
    let per_cell = |channels: &[ChannelHeader]| {
        channels
            .iter()
            .map(|c| c.components as usize * c.encoding.size())
            .sum::<usize>()
    };
    // The v1 channels lead every level's payload; the later ones (leaves, solids, wood
    // normals) follow them and are left out.
    let all = per_cell(&p.header.channels);
    let v1 = per_cell(&v1_channels(texel.info.density_model));
    p.header
        .channels
        .truncate(v1_channels(texel.info.density_model).len());
    let mut payload = Vec::new();
    let mut at = 0;
    for level in &texel.levels {
        let n = level.cell_count();
        payload.extend_from_slice(&p.payload[at..at + n * v1]);
        at += n * all;
    }
    let mut header = bincode::encode_to_vec(&p.header, header_config()).unwrap_or_default();
    header.extend(bincode::encode_to_vec(&p.extension, header_config()).unwrap_or_default());
    container::write(MAGIC, MAJOR, 1, &header, &payload).unwrap_or_default()
}

/// Decodes the header of a file of minor version `minor`: the v1.0 fields, then those of
/// every later minor version this reader knows. Bytes after those are refused, unless the file
/// is of a newer minor version, whose appended fields this reader skips.
fn decode_header(bytes: &[u8], minor: u16) -> Result<Decoded, TexelError> {
    let mut rest = bytes;
    let header: Header = decode_front(&mut rest)?;
    let extension: HeaderV1_1 = appended(&mut rest, minor >= 1)?.unwrap_or_default();
    let extension2: Option<HeaderV1_2> = appended(&mut rest, minor >= 2)?;
    let extension5: Option<HeaderV1_5> = appended(&mut rest, minor >= 5)?;
    let extension6: Option<HeaderV1_6> = appended(&mut rest, minor >= 6)?;
    if !rest.is_empty() && minor <= MINOR {
        return Err(TexelError::Header(format!(
            "{} bytes after the header",
            rest.len()
        )));
    }
    validate(
        &header,
        &extension,
        extension2.as_ref(),
        extension5.as_ref(),
        extension6.as_ref(),
    )?;
    // Files before 1.2 are isotropic and shadow themselves as independent media: every
    // factor 1. Files before 1.5 have one self-shadowing row for every sun height, and files
    // before 1.6 no rows by view (a renderer reads theirs by the sun's height).
    let n = header.levels.len();
    let mut fits = extension2.map_or_else(
        || LevelFits {
            directional: vec![crate::volume::ISOTROPIC; n],
            self_shadow: vec![SelfShadow::NONE; n],
            wood_weight: vec![1.0; n],
        },
        |e| LevelFits {
            directional: e.directional,
            self_shadow: e.self_shadow.into_iter().map(SelfShadow::uniform).collect(),
            wood_weight: e.wood_weight,
        },
    );
    if let Some(e) = extension5 {
        for (s, rows) in fits.self_shadow.iter_mut().zip(e.self_shadow_by_height) {
            s.by_height = rows;
        }
    }
    if let Some(e) = extension6 {
        for (s, rows) in fits.self_shadow.iter_mut().zip(e.self_shadow_by_view) {
            s.by_view = Some(rows);
        }
    }
    Ok(Decoded {
        header,
        extension,
        fits,
    })
}

/// Header fields decoded from the front of `rest`, which then starts after them.
fn decode_front<T: bincode::Decode<()>>(rest: &mut &[u8]) -> Result<T, TexelError> {
    let (fields, used) = bincode::decode_from_slice(rest, header_config())
        .map_err(|e| TexelError::Header(container::decode_error(&e)))?;
    *rest = &rest[used..];
    Ok(fields)
}

/// The fields a minor version appended to the header, where the file is of that version or
/// later (`present`).
fn appended<T: bincode::Decode<()>>(
    rest: &mut &[u8],
    present: bool,
) -> Result<Option<T>, TexelError> {
    present.then(|| decode_front(rest)).transpose()
}

/// A decoded, checked header: the fields of every minor version this reader knows.
struct Decoded {
    header: Header,
    extension: HeaderV1_1,
    fits: LevelFits,
}

/// The per-level fields of 1.2 and 1.5 (neutral values for older files).
struct LevelFits {
    directional: Vec<[f32; 7]>,
    self_shadow: Vec<SelfShadow>,
    wood_weight: Vec<f32>,
}

/// The header of `.texel` bytes (checked, payload not decompressed): for tools that need a
/// texture's bounds but not its voxels.
pub fn read_info(bytes: &[u8]) -> Result<TexelInfo, TexelError> {
    let opened = container::open(bytes, MAGIC, "texel", MAJOR)?;
    let d = decode_header(opened.header, opened.minor)?;
    Ok(info_of(d.header, d.extension))
}

fn info_of(header: Header, extension: HeaderV1_1) -> TexelInfo {
    let p = header.parameters;
    TexelInfo {
        generator: header.generator,
        model_min: header.model_min,
        model_max: header.model_max,
        origin: header.origin,
        density_model: header.density_model,
        extinction_scale: header.extinction_scale,
        triangles: header.triangles,
        foliage_triangles: header.foliage_triangles,
        mesh_coverage: header.mesh_coverage,
        sources: header.sources,
        inputs_sha256: header.inputs_sha256,
        parameters: BakeParameters {
            resolution: p.resolution,
            fine: p.fine,
            foliage_pattern: p.foliage_pattern,
            requested_gamma: p.requested_gamma,
            wood_pattern: extension.wood_pattern,
        },
        materials: extension
            .materials
            .into_iter()
            .map(|m| {
                let reason = PartReason::from(m.reason);
                MaterialPart {
                    name: m.name,
                    foliage: matches!(reason, PartReason::FoliagePattern | PartReason::AlphaCuts),
                    reason,
                    cut: m.cut,
                    triangles: m.triangles,
                }
            })
            .collect(),
    }
}

/// Decodes `.texel` bytes within the default [`Limits`].
pub fn decode(bytes: &[u8]) -> Result<Texel, TexelError> {
    decode_with(bytes, &Limits::default())
}

/// Decodes `.texel` bytes, validating every size before use.
pub fn decode_with(bytes: &[u8], limits: &Limits) -> Result<Texel, TexelError> {
    let opened = container::open(bytes, MAGIC, "texel", MAJOR)?;
    let Decoded {
        header,
        extension,
        fits,
    } = decode_header(opened.header, opened.minor)?;
    let bad = |m: String| TexelError::Header(m);

    // Everything the payload must hold follows from the header: check it before inflating.
    let cells: Vec<u64> = header
        .levels
        .iter()
        .map(|l| l.dims.iter().map(|&d| d as u64).product())
        .collect();
    limits.check_cells(cells.iter().sum(), "the texture's cell count (all levels)")?;
    let per_cell: u64 = header
        .channels
        .iter()
        .map(|ch| ch.components as u64 * ch.encoding.size() as u64)
        .sum();
    let expected: u64 = cells.iter().map(|c| c * per_cell).sum();
    if expected != opened.raw_len() {
        return Err(bad(format!(
            "levels and channels need {expected} payload bytes, the container says {}",
            opened.raw_len()
        )));
    }
    let Slots {
        slots,
        leaves: leaves_slot,
        solids: solid_slots,
        wood_normals: wood_normals_slot,
        wood_shown: wood_shown_slot,
    } = channel_slots(&header)?;
    let payload = opened.payload()?;

    let mut levels = Vec::with_capacity(header.levels.len());
    let mut at = 0usize;
    for (index, lh) in header.levels.iter().enumerate() {
        let dims = lh.dims.map(|d| d as usize);
        let n: usize = dims.iter().product();
        let mut offsets = Vec::with_capacity(header.channels.len());
        for ch in &header.channels {
            offsets.push(at);
            at += n * ch.components as usize * ch.encoding.size();
        }
        let bytes_of = |slot: usize| {
            let i = slots[slot];
            let len =
                n * header.channels[i].components as usize * header.channels[i].encoding.size();
            &payload[offsets[i]..offsets[i] + len]
        };
        let level = Level {
            dims,
            cell: lh.cell,
            density: [f32s(bytes_of(0)), f32s(bytes_of(1))],
            gradient: [vec3(f32s(bytes_of(2))), vec3(f32s(bytes_of(3)))],
            albedo: [vec3(unorm(bytes_of(4))), vec3(unorm(bytes_of(5)))],
            leaves: match leaves_slot {
                Some(slot) => f32s(bytes_of(slot))
                    .chunks_exact(6)
                    .map(|m| std::array::from_fn(|k| m[k]))
                    .collect(),
                None => vec![crate::volume::ISOTROPIC_LEAVES; n],
            },
            wood_normals: match wood_normals_slot {
                Some(slot) => f32s(bytes_of(slot))
                    .chunks_exact(6)
                    .map(|m| std::array::from_fn(|k| m[k]))
                    .collect(),
                None => Vec::new(),
            },
            directional: fits.directional[index],
            self_shadow: fits.self_shadow[index],
            wood_weight: fits.wood_weight[index],
            wood_shown: wood_shown_slot.map_or_else(Vec::new, |slot| f32s(bytes_of(slot))),
            solid: match solid_slots {
                // A level whose solids are all 0 has none, as the bake leaves it.
                Some([w, f]) => {
                    let solid = [unorm(bytes_of(w)), unorm(bytes_of(f))];
                    if solid.iter().flatten().all(|&v| v == 0.0) {
                        [Vec::new(), Vec::new()]
                    } else {
                        solid
                    }
                }
                None => [Vec::new(), Vec::new()],
            },
        };
        check_values(&level)?;
        levels.push(level);
    }
    Ok(Texel {
        info: info_of(header, extension),
        levels,
    })
}

/// Where the reader finds its channels, as indices into `slots`, which indexes the header's
/// table: the required ones first, then the optional ones found.
struct Slots {
    slots: Vec<usize>,
    leaves: Option<usize>,
    solids: Option<[usize; 2]>,
    wood_normals: Option<usize>,
    wood_shown: Option<usize>,
}

/// Where each channel the reader uses sits in the header's table: the six required ones (in
/// [`v1_channels`] order), each checked for its layout, (1.2) the optional leaf moments,
/// (1.3) the optional solids, both parts or neither, (1.4) the optional wood moments and
/// (1.7) the optional shown wood.
fn channel_slots(header: &Header) -> Result<Slots, TexelError> {
    let find = |name: &str| header.channels.iter().position(|ch| ch.name == name);
    let layout = |i: usize, want: &ChannelHeader| {
        let have = &header.channels[i];
        if (have.components, have.encoding) == (want.components, want.encoding) {
            Ok(i)
        } else {
            Err(TexelError::Header(format!(
                "channel {} has {} x {:?}, expected {} x {:?}",
                want.name, have.components, have.encoding, want.components, want.encoding
            )))
        }
    };
    let mut slots = Vec::new();
    for want in &v1_channels(header.density_model) {
        let i = find(&want.name).ok_or_else(|| {
            TexelError::Header(format!("required channel {} is missing", want.name))
        })?;
        slots.push(layout(i, want)?);
    }
    let leaves = match find(LEAVES) {
        Some(i) => {
            slots.push(layout(i, &leaves_channel())?);
            Some(slots.len() - 1)
        }
        None => None,
    };
    let solids = match SOLIDS.map(find) {
        [Some(w), Some(f)] => {
            for (i, name) in [w, f].into_iter().zip(SOLIDS) {
                slots.push(layout(i, &solid_channel(name))?);
            }
            Some([slots.len() - 2, slots.len() - 1])
        }
        [None, None] => None,
        [w, _] => {
            return Err(TexelError::Header(format!(
                "channel {} is there without {}",
                SOLIDS[usize::from(w.is_none())],
                SOLIDS[usize::from(w.is_some())]
            )));
        }
    };
    let wood_normals = match find(WOOD_NORMALS) {
        Some(i) => {
            slots.push(layout(i, &wood_normals_channel())?);
            Some(slots.len() - 1)
        }
        None => None,
    };
    let wood_shown = match find(WOOD_SHOWN) {
        Some(i) => {
            slots.push(layout(i, &wood_shown_channel(header.density_model))?);
            Some(slots.len() - 1)
        }
        None => None,
    };
    Ok(Slots {
        slots,
        leaves,
        solids,
        wood_normals,
        wood_shown,
    })
}

fn f32s(b: &[u8]) -> Vec<f32> {
    b.chunks_exact(4)
        .map(|x| f32::from_le_bytes([x[0], x[1], x[2], x[3]]))
        .collect()
}

fn vec3(v: Vec<f32>) -> Vec<[f32; 3]> {
    v.chunks_exact(3).map(|x| [x[0], x[1], x[2]]).collect()
}

fn unorm(b: &[u8]) -> Vec<f32> {
    b.chunks_exact(2)
        .map(|x| u16::from_le_bytes([x[0], x[1]]) as f32 / 65535.0)
        .collect()
}

/// Densities must be finite and non-negative, gradients finite, leaf-normal moments those of
/// unit vectors.
fn check_values(level: &Level) -> Result<(), TexelError> {
    let dims = level.dims;
    if let Some((i, v)) = level
        .wood_shown
        .iter()
        .enumerate()
        .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
    {
        return Err(TexelError::Payload(format!(
            "shown_wood: {v} at cell {i} in a level of {dims:?} cells is not a finite non-negative number"
        )));
    }
    for part in 0..2 {
        if let Some(v) = level.density[part]
            .iter()
            .find(|v| !(v.is_finite() && **v >= 0.0))
        {
            return Err(TexelError::Payload(format!(
                "density {v} in a level of {dims:?} cells is not a finite non-negative number"
            )));
        }
        if level.gradient[part]
            .iter()
            .flatten()
            .any(|v| !v.is_finite())
        {
            return Err(TexelError::Payload(format!(
                "a gradient in a level of {dims:?} cells is not finite"
            )));
        }
    }
    // Solids: both parts or neither, a fraction per cell.
    let n = level.cell_count();
    match level.solid.each_ref().map(Vec::len) {
        [0, 0] => {}
        [a, b] if a == n && b == n => {
            if let Some(v) = level
                .solid
                .iter()
                .flatten()
                .find(|v| !(0.0..=1.0).contains(*v))
            {
                return Err(TexelError::Payload(format!(
                    "solid {v} in a level of {dims:?} cells is not a fraction"
                )));
            }
        }
        [a, b] => {
            return Err(TexelError::Payload(format!(
                "solids of {a} and {b} cells in a level of {n}"
            )));
        }
    }
    // A second moment of unit vectors: diagonal within [0, 1], the rest within [-1, 1].
    let moment = |m: &[f32; 6]| {
        m[..3].iter().all(|v| (0.0..=1.0).contains(v))
            && m[3..].iter().all(|v| (-1.0..=1.0).contains(v))
    };
    if let Some(m) = level.leaves.iter().find(|m| !moment(m)) {
        return Err(TexelError::Payload(format!(
            "leaf-normal moment {m:?} in a level of {dims:?} cells is not one of unit normals"
        )));
    }
    if let Some((i, m)) = level
        .wood_normals
        .iter()
        .enumerate()
        .find(|(_, m)| !moment(m))
    {
        return Err(TexelError::Payload(format!(
            "normals_wood: the wood-normal moment {m:?} of cell {i} in a level of {dims:?} cells is not one of unit normals"
        )));
    }
    Ok(())
}

fn validate(
    h: &Header,
    extension: &HeaderV1_1,
    extension2: Option<&HeaderV1_2>,
    extension5: Option<&HeaderV1_5>,
    extension6: Option<&HeaderV1_6>,
) -> Result<(), TexelError> {
    validate_geometry(h)?;
    validate_channels(h)?;
    validate_materials(h, extension)?;
    if let Some(e) = extension2 {
        validate_directional(h, e)?;
    }
    if let Some(e) = extension5 {
        validate_self_shadow_by_height(h, e)?;
    }
    if let Some(e) = extension6 {
        validate_self_shadow_by_view(h, e)?;
    }
    Ok(())
}

/// Refuses `count` entries of a per-level field (`what`) where the header has another number
/// of levels.
fn one_per_level(h: &Header, count: usize, what: &str) -> Result<(), TexelError> {
    if count != h.levels.len() {
        return bad(format!("{count} {what} for {} levels", h.levels.len()));
    }
    Ok(())
}

/// Whether every self-shadowing factor of `row` is a number within 0 to 64.
fn factors_in_range(row: &[f32; 6]) -> bool {
    row.iter().all(|v| (0.0..=SELF_SHADOW_MAX).contains(v))
}

/// The 1.5 rows: one set per level, every factor within 0 to 64.
fn validate_self_shadow_by_height(h: &Header, e: &HeaderV1_5) -> Result<(), TexelError> {
    validate_row_sets(
        h,
        "sun height",
        e.self_shadow_by_height.iter().map(|rows| rows.as_slice()),
        |j| format!("a sun {} degrees high", SUN_HEIGHTS[j]),
    )
}

/// The 1.6 rows: one set per level, every factor within 0 to 64.
fn validate_self_shadow_by_view(h: &Header, e: &HeaderV1_6) -> Result<(), TexelError> {
    validate_row_sets(
        h,
        "eye height and sun turn",
        e.self_shadow_by_view.iter().map(|rows| rows.as_flattened()),
        |j| {
            let (eye, turn) = (
                EYE_HEIGHTS[j / SUN_TURNS.len()],
                SUN_TURNS[j % SUN_TURNS.len()],
            );
            format!("an eye {eye} degrees high and a sun turned {turn} degrees from above it")
        },
    )
}

/// Per-level sets of self-shadowing rows (`what` they are by): one set per level, every
/// factor within 0 to 64; a refusal names the level and, by `label`, the row's place in its set.
fn validate_row_sets<'a>(
    h: &Header,
    what: &str,
    sets: impl ExactSizeIterator<Item = &'a [[f32; 6]]>,
    label: impl Fn(usize) -> String,
) -> Result<(), TexelError> {
    one_per_level(
        h,
        sets.len(),
        &format!("sets of self-shadowing rows by {what}"),
    )?;
    for (i, rows) in sets.enumerate() {
        if let Some((j, row)) = rows.iter().enumerate().find(|(_, r)| !factors_in_range(r)) {
            return bad(format!(
                "level {i}'s self-shadowing factors for {} {row:?} have one that is not a number within 0 to 64",
                label(j)
            ));
        }
    }
    Ok(())
}

fn bad(m: String) -> Result<(), TexelError> {
    Err(TexelError::Header(m))
}

/// Bounds, extinction scale and the mip chain (checks 3 to 6 of `formats/texel.md`).
fn validate_geometry(h: &Header) -> Result<(), TexelError> {
    let finite3 = |v: &[f64; 3]| v.iter().all(|c| c.is_finite());
    if !(finite3(&h.model_min) && finite3(&h.model_max) && finite3(&h.origin)) {
        return bad("bounds are not finite".into());
    }
    if !(h.extinction_scale.is_finite() && h.extinction_scale > 0.0) {
        return bad(format!(
            "extinction scale {} is not a positive number",
            shortest(h.extinction_scale)
        ));
    }
    if h.levels.is_empty() || h.levels.len() > MAX_LEVELS {
        return bad(format!(
            "{} levels (1 to {MAX_LEVELS} allowed)",
            h.levels.len()
        ));
    }
    let first = &h.levels[0];
    if first.dims.iter().any(|&d| d == 0 || d > MAX_SIDE) {
        return bad(format!(
            "level 0 has {:?} cells (1 to {MAX_SIDE} per side)",
            first.dims
        ));
    }
    if !(first.cell.is_finite() && first.cell > 0.0) {
        return bad(format!(
            "cell size {} is not a positive number",
            shortest(first.cell)
        ));
    }
    for (i, pair) in h.levels.windows(2).enumerate() {
        let want = pair[0].dims.map(|d| d.div_ceil(2));
        if pair[0].dims == [1, 1, 1] {
            return bad(format!("level {} follows a single-cell level", i + 1));
        }
        if pair[1].dims != want || pair[1].cell != pair[0].cell * 2.0 || !pair[1].cell.is_finite() {
            return bad(format!(
                "level {} is not half of level {i} (cells {:?} of {} m, expected {want:?} of {} m)",
                i + 1,
                pair[1].dims,
                pair[1].cell,
                pair[0].cell * 2.0
            ));
        }
    }
    if h.levels.last().is_some_and(|l| l.dims != [1, 1, 1]) {
        return bad("the mip chain does not end in a single cell".into());
    }
    Ok(())
}

/// The channel table: how many, their components, no name twice.
fn validate_channels(h: &Header) -> Result<(), TexelError> {
    if h.channels.len() > MAX_CHANNELS {
        return bad(format!(
            "{} channels (at most {MAX_CHANNELS})",
            h.channels.len()
        ));
    }
    if let Some(ch) = h
        .channels
        .iter()
        .find(|ch| ch.components == 0 || ch.components > 16)
    {
        return bad(format!(
            "channel {} has {} components",
            ch.name, ch.components
        ));
    }
    for (i, ch) in h.channels.iter().enumerate() {
        if h.channels[..i].iter().any(|c| c.name == ch.name) {
            return bad(format!("channel {} appears twice", ch.name));
        }
    }
    Ok(())
}

/// Triangle counts and (1.1) the material table that must add up to them.
fn validate_materials(h: &Header, extension: &HeaderV1_1) -> Result<(), TexelError> {
    if h.foliage_triangles > h.triangles {
        return bad(format!(
            "{} foliage triangles of {} in all",
            h.foliage_triangles, h.triangles
        ));
    }
    let m = &extension.materials;
    if m.len() > MAX_MATERIALS {
        return bad(format!("{} materials (at most {MAX_MATERIALS})", m.len()));
    }
    if !m.is_empty() {
        let total: u64 = m.iter().map(|r| r.triangles).fold(0, u64::saturating_add);
        let foliage: u64 = m
            .iter()
            .filter(|r| matches!(r.reason, Reason::FoliagePattern | Reason::AlphaCuts))
            .map(|r| r.triangles)
            .fold(0, u64::saturating_add);
        if (total, foliage) != (h.triangles, h.foliage_triangles) {
            return bad(format!(
                "the materials hold {total} triangles ({foliage} foliage), the header says {} ({})",
                h.triangles, h.foliage_triangles
            ));
        }
        if let Some(r) = m.iter().find(|r| !(0.0..=1.0).contains(&r.cut)) {
            return bad(format!(
                "material {:?} has a cut share of {} (not within 0 to 1)",
                r.name, r.cut
            ));
        }
    }
    Ok(())
}

/// (1.2) One finite, bounded directional form, one row of self-shadowing factors and one wood
/// weight per level.
fn validate_directional(h: &Header, e: &HeaderV1_2) -> Result<(), TexelError> {
    one_per_level(h, e.directional.len(), "directional forms")?;
    for (i, s) in e.directional.iter().enumerate() {
        if !s
            .iter()
            .all(|v| v.is_finite() && v.abs() <= DIRECTIONAL_MAX)
        {
            return bad(format!(
                "level {i}'s directional form {s:?} has an entry that is not a number within -4096 to 4096"
            ));
        }
    }
    one_per_level(h, e.self_shadow.len(), "self-shadowing rows")?;
    for (i, s) in e.self_shadow.iter().enumerate() {
        if !factors_in_range(s) {
            return bad(format!(
                "level {i}'s self-shadowing factors {s:?} have one that is not a number within 0 to 64"
            ));
        }
    }
    one_per_level(h, e.wood_weight.len(), "wood weights")?;
    if let Some((i, w)) = e
        .wood_weight
        .iter()
        .enumerate()
        .find(|(_, w)| !WOOD_WEIGHT_RANGE.contains(*w))
    {
        return bad(format!(
            "level {i}'s wood weight {w} is not a number within 1/4096 to 4096"
        ));
    }
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::rng::Stream;

    /// A small texture with every field set to something recognisable.
    pub(crate) fn sample_texel(seed: u64) -> Texel {
        let mut s = Stream::new(seed, 1);
        let mut levels = vec![];
        let (mut dims, mut cell) = ([5usize, 4, 3], 0.25);
        loop {
            let mut l = Level::empty(dims, cell);
            for part in 0..2 {
                for i in 0..l.cell_count() {
                    l.density[part][i] = (s.unit() * 8.0) as f32;
                    l.gradient[part][i] = [s.unit() as f32 - 0.5, 1.0, -2.0];
                    l.albedo[part][i] = [(s.unit() * 65535.0).round() as f32 / 65535.0, 0.0, 1.0];
                }
            }
            levels.push(l);
            if dims == [1, 1, 1] {
                break;
            }
            dims = dims.map(|d| d.div_ceil(2));
            cell *= 2.0;
        }
        Texel {
            info: TexelInfo {
                generator: "test".into(),
                model_min: [-0.6, 0.0, -0.35],
                model_max: [0.6, 1.0, 0.35],
                origin: [-0.625, 0.0, -0.375],
                density_model: DensityModel::Transmittance,
                extinction_scale: 1.0,
                triangles: 12,
                foliage_triangles: 4,
                mesh_coverage: [0.5, 0.25, 0.125],
                sources: vec![SourceFile {
                    path: "../trees/a b.glb".into(),
                    sha256: [7; 32],
                    bytes: 99,
                }],
                inputs_sha256: [9; 32],
                parameters: BakeParameters {
                    resolution: 5,
                    fine: 20,
                    foliage_pattern: "leaf".into(),
                    requested_gamma: None,
                    wood_pattern: Some("bark".into()),
                },
                materials: vec![
                    MaterialPart {
                        name: "bark".into(),
                        foliage: false,
                        reason: PartReason::WoodPattern,
                        cut: 0.0,
                        triangles: 8,
                    },
                    MaterialPart {
                        name: "leaf card".into(),
                        foliage: true,
                        reason: PartReason::AlphaCuts,
                        cut: 0.75,
                        triangles: 4,
                    },
                ],
            },
            levels,
        }
    }

    #[test]
    fn round_trip_is_exact() {
        let t = sample_texel(1);
        let bytes = encode(&t).unwrap();
        assert_eq!(decode(&bytes).unwrap(), t);
        assert_eq!(encode(&decode(&bytes).unwrap()).unwrap(), bytes);
    }

    /// Pins the header's byte layout against formats/texel.md.
    /// A texture with solids on its first levels is written as 1.3 with both solid channels
    /// (zeros on the levels without), and read back as it was, bit for bit (fractions on the
    /// Unorm16 grid); without solids it is the 1.2 file it always was. A file with one solid
    /// channel and not the other is refused, naming them.
    #[test]
    fn solids_are_written_as_1_3_and_read_back() {
        let plain = sample_texel(5);
        let bytes = encode(&plain).unwrap();
        assert_eq!(minor_of(&bytes), 2);
        let mut t = plain.clone();
        let mut s = Stream::new(8, 0);
        for l in &mut t.levels[..2] {
            let n = l.cell_count();
            l.solid = [0, 1].map(|_| {
                (0..n)
                    .map(|_| (s.unit() * 65535.0).round() as f32 / 65535.0)
                    .collect()
            });
        }
        let bytes = encode(&t).unwrap();
        assert_eq!(minor_of(&bytes), 3);
        assert_eq!(decode(&bytes).unwrap(), t);
        let half = forge(&t, |p| {
            for c in &mut p.header.channels {
                if c.name == "solid_foliage" {
                    c.name = "solid_other".into();
                }
            }
        });
        let e = decode(&half).unwrap_err().to_string();
        assert!(
            e.contains("solid_wood") && e.contains("solid_foliage"),
            "{e}"
        );
        let mut bad = t.clone();
        bad.levels[0].solid[1].pop();
        assert!(encode(&bad).unwrap_err().to_string().contains("solids of"));
    }

    #[test]
    fn wood_normals_are_written_as_1_4_and_read_back() {
        let mut t = sample_texel(6);
        let mut s = Stream::new(9, 0);
        for l in &mut t.levels {
            l.wood_normals = (0..l.cell_count())
                .map(|_| {
                    let mut c = || s.unit() as f32 - 0.5;
                    crate::volume::normal_moment(
                        glam::Vec3::new(c(), c(), c()).normalize_or(glam::Vec3::Y),
                    )
                })
                .collect();
        }
        let bytes = encode(&t).unwrap();
        assert_eq!(minor_of(&bytes), 4);
        assert_eq!(decode(&bytes).unwrap(), t);
        // The channel is the last, after the 1.2 channels (no solids here).
        let parts = parts(&t);
        let names: Vec<&str> = parts
            .header
            .channels
            .iter()
            .map(|c| c.name.as_str())
            .collect();
        assert_eq!(names.last(), Some(&"normals_wood"));
        assert_eq!(names.len(), 8);
        // A level without them is refused by the writer, not written short.
        let mut bad = t.clone();
        bad.levels[1].wood_normals.clear();
        let e = encode(&bad).unwrap_err().to_string();
        assert!(e.contains("wood normals of 0 cells"), "{e}");
        // A reader of 1.3 (one that skips the channel) draws the rest as before.
        let read = read_without(&t, "normals_wood");
        assert!(read.levels.iter().all(|l| l.wood_normals.is_empty()));
        assert_eq!(read.levels[0].density, t.levels[0].density);
    }

    /// `t` as a reader that does not know the channel `name` reads it: the channel renamed, so
    /// skipped as unknown.
    fn read_without(t: &Texel, name: &str) -> Texel {
        let skipped = forge(t, |p| {
            for c in &mut p.header.channels {
                if c.name == name {
                    c.name = format!("{name}_unknown");
                }
            }
        });
        decode(&skipped).unwrap()
    }

    #[test]
    fn shown_wood_is_written_as_1_7_and_read_back() {
        let mut t = sample_texel(7);
        for l in &mut t.levels {
            l.wood_shown = l.density[0].iter().map(|d| 0.25 * d).collect();
            // A bake writes it for trees with foliage, whose self-shadowing has rows by view
            // (a 1.7 header has their field).
            l.self_shadow.by_view =
                Some([[l.self_shadow.pooled; SUN_TURNS.len()]; EYE_HEIGHTS.len()]);
        }
        let bytes = encode(&t).unwrap();
        assert_eq!(minor_of(&bytes), 7);
        assert_eq!(decode(&bytes).unwrap(), t);
        let names: Vec<String> = parts(&t)
            .header
            .channels
            .into_iter()
            .map(|c| c.name)
            .collect();
        assert_eq!(names.last().map(String::as_str), Some("shown_wood"));
        // A level without it is refused by the writer, not written short.
        let mut bad = t.clone();
        bad.levels[1].wood_shown.clear();
        let e = encode(&bad).unwrap_err().to_string();
        assert!(e.contains("shown wood of 0 cells"), "{e}");
        // Nor is a negative one written.
        let mut bad = t.clone();
        bad.levels[0].wood_shown[0] = -1.0;
        let e = encode(&bad).unwrap_err().to_string();
        assert!(e.contains("shown_wood: -1 at cell 0"), "{e}");
        // A reader of 1.6 (one that skips the channel) weighs the wood by the level's weight.
        let read = read_without(&t, "shown_wood");
        assert!(read.levels.iter().all(|l| l.wood_shown.is_empty()));
        assert_eq!(read.levels[0].density, t.levels[0].density);
    }

    #[test]
    fn header_layout_matches_the_spec() {
        let t = sample_texel(1);
        let bytes = encode(&t).unwrap();
        let h = &bytes[container::PREAMBLE..];
        // generator: u64 length, then UTF-8
        assert_eq!(&h[..8], &4u64.to_le_bytes());
        assert_eq!(&h[8..12], b"test");
        // model_min: 3 x f64
        assert_eq!(&h[12..20], &(-0.6f64).to_le_bytes());
        // origin at 12 + 48, density model (u32 variant index) at 12 + 72
        assert_eq!(&h[60..68], &(-0.625f64).to_le_bytes());
        assert_eq!(&h[84..88], &1u32.to_le_bytes());
        // extinction_scale f64, triangles u64, foliage_triangles u64, mesh_coverage 3 x f64
        assert_eq!(&h[88..96], &1.0f64.to_le_bytes());
        assert_eq!(&h[96..104], &12u64.to_le_bytes());
        assert_eq!(&h[112..120], &0.5f64.to_le_bytes());
        // sources: u64 count, then path (u64 length + bytes), sha256 (32 bytes, no length), bytes u64
        assert_eq!(&h[136..144], &1u64.to_le_bytes());
        assert_eq!(&h[144..152], &16u64.to_le_bytes());
        assert_eq!(&h[152..168], b"../trees/a b.glb");
        assert_eq!(&h[168..200], &[7u8; 32]);
        assert_eq!(&h[200..208], &99u64.to_le_bytes());
        assert_eq!(&h[208..240], &[9u8; 32]);
        // parameters: resolution u32, fine u32, pattern string, Option<f64> as a tag byte
        assert_eq!(&h[240..244], &5u32.to_le_bytes());
        assert_eq!(&h[244..248], &20u32.to_le_bytes());
        assert_eq!(&h[248..256], &4u64.to_le_bytes());
        assert_eq!(&h[256..260], b"leaf");
        assert_eq!(h[260], 0);
        // levels: u64 count, each dims 3 x u32 and cell f64
        assert_eq!(&h[261..269], &(t.levels.len() as u64).to_le_bytes());
        assert_eq!(
            &h[269..281],
            &[5u32.to_le_bytes(), 4u32.to_le_bytes(), 3u32.to_le_bytes()].concat()[..]
        );
        assert_eq!(&h[281..289], &0.25f64.to_le_bytes());
    }

    /// `bytes` with the container's CRC recomputed after an edit.
    fn recrc(mut bytes: Vec<u8>) -> Vec<u8> {
        let body = bytes.len() - 4;
        let crc = crc32fast::hash(&bytes[..body]);
        bytes[body..].copy_from_slice(&crc.to_le_bytes());
        bytes
    }

    /// The minor version `bytes` declare.
    fn minor_of(bytes: &[u8]) -> u16 {
        container::open(bytes, MAGIC, "texel", MAJOR).unwrap().minor
    }

    /// `bytes` as an older writer of minor version `minor` wrote them: the last `cut` header
    /// bytes (the fields later versions appended) left out.
    fn older(bytes: &[u8], cut: usize, minor: u16) -> Vec<u8> {
        let p = container::preamble(bytes).unwrap();
        let h = container::PREAMBLE + p.header_len as usize;
        let mut b = bytes[..h - cut].to_vec();
        b[10..12].copy_from_slice(&minor.to_le_bytes());
        b[12..16].copy_from_slice(&(p.header_len - cut as u32).to_le_bytes());
        b.extend_from_slice(&bytes[h..]);
        recrc(b)
    }

    #[test]
    fn a_header_that_breaks_the_mip_rule_is_refused_by_writer_and_reader() {
        let mut t = sample_texel(2);
        t.levels[1] = Level::empty([3, 2, 1], 0.5);
        let e = encode(&t).unwrap_err();
        assert!(
            e.to_string().contains("cannot write") && e.to_string().contains("not half"),
            "{e}"
        );
        // The same defect forged into a written file: level 1's cell size (header offset 289
        // + 20) no longer doubles.
        let mut bytes = encode(&sample_texel(2)).unwrap();
        let at = container::PREAMBLE + 289 + 12;
        bytes[at..at + 8].copy_from_slice(&0.75f64.to_le_bytes());
        let e = decode(&recrc(bytes)).unwrap_err().to_string();
        assert!(e.contains("level 1 is not half of level 0"), "{e}");
    }

    /// The header is judged before the payload is inflated: a payload that would not even
    /// decompress is never reached when the header asks for more than the limits allow.
    #[test]
    fn the_header_is_checked_before_the_payload_is_decompressed() {
        let bytes = encode(&sample_texel(5)).unwrap();
        let p = container::preamble(&bytes).unwrap();
        let mut damaged = bytes.clone();
        let payload = container::PREAMBLE + p.header_len as usize;
        damaged[payload + 8] ^= 0xff;
        let damaged = recrc(damaged);
        let small = Limits {
            cells: 10,
            ..Limits::default()
        };
        let e = decode_with(&damaged, &small).unwrap_err();
        assert!(matches!(e, TexelError::Limit(_)), "{e}");
        let e = decode(&damaged).unwrap_err().to_string();
        assert!(e.contains("payload"), "{e}");
    }

    /// What the reader says of `t`'s parts with `edit` applied, forged without the writer's
    /// checks.
    fn refusal(t: &Texel, edit: impl FnOnce(&mut Parts)) -> String {
        decode(&forge(t, edit)).unwrap_err().to_string()
    }

    /// `t` with self-shadowing rows that differ by the sun's height, as every bake of a tree
    /// with foliage has since 1.5.
    fn with_heights(mut t: Texel) -> Texel {
        for (n, l) in t.levels.iter_mut().enumerate() {
            let row = |h: usize| std::array::from_fn(|a| (a * (h + 1) + n) as f32 * 0.25);
            l.self_shadow = SelfShadow {
                pooled: row(1),
                by_height: std::array::from_fn(row),
                by_view: None,
            };
        }
        t
    }

    /// `t` (rows by sun height) with rows by eye height and sun turn too, as every bake of a
    /// tree with foliage has since 1.6.
    fn with_views(mut t: Texel) -> Texel {
        for (n, l) in t.levels.iter_mut().enumerate() {
            l.self_shadow.by_view = Some(std::array::from_fn(|e| {
                std::array::from_fn(|v| std::array::from_fn(|a| (a + 3 * e + v + n) as f32 * 0.5))
            }));
        }
        t
    }

    /// Rows by eye height and sun turn make a 1.6 file, read back bit for bit; a 1.5 reader
    /// (which skips the appended field) reads the rows by sun height alone; rows out of range
    /// are refused, naming the level, the eye's height and the sun's turn.
    #[test]
    fn self_shadowing_by_view_is_written_as_1_6_and_read_back() {
        let t = with_views(with_heights(sample_texel(3)));
        let bytes = encode(&t).unwrap();
        assert_eq!(minor_of(&bytes), 6);
        assert_eq!(decode(&bytes).unwrap(), t);
        let old = decode(&older(&bytes, 8 + 4 * 6 * 9 * t.levels.len(), 5)).unwrap();
        for (l, o) in t.levels.iter().zip(&old.levels) {
            assert_eq!(o.self_shadow.by_view, None);
            assert_eq!(o.self_shadow.by_height, l.self_shadow.by_height);
        }
        let e = refusal(&t, |p| {
            if let Some(e) = &mut p.extension6 {
                e.self_shadow_by_view[2][1][2][0] = f32::NAN;
            }
        });
        assert!(
            e.contains("level 2") && e.contains("35 degrees high") && e.contains("turned 180"),
            "{e}"
        );
        let e = refusal(&t, |p| {
            if let Some(e) = &mut p.extension6 {
                e.self_shadow_by_view.pop();
            }
        });
        assert!(e.contains("by eye height and sun turn"), "{e}");
    }

    /// Rows by sun height make a 1.5 file, read back bit for bit; the pooled row stays where
    /// 1.2 put it, so a 1.4 reader (which skips the appended field) reads it alone; rows out of
    /// range are refused, naming the level and the sun's height. A texture whose rows are all
    /// its pooled one is the file it was before.
    #[test]
    fn self_shadowing_by_sun_height_is_written_as_1_5_and_read_back() {
        let t = with_heights(sample_texel(3));
        let bytes = encode(&t).unwrap();
        assert_eq!(minor_of(&bytes), 5);
        assert_eq!(decode(&bytes).unwrap(), t);
        // As a 1.4 reader reads it: the same header, minor 4, the appended field left out.
        let old = decode(&older(&bytes, 8 + 4 * 6 * 4 * t.levels.len(), 4)).unwrap();
        for (l, o) in t.levels.iter().zip(&old.levels) {
            assert_eq!(o.self_shadow, SelfShadow::uniform(l.self_shadow.pooled));
        }
        let e = refusal(&t, |p| {
            if let Some(e) = &mut p.extension5 {
                e.self_shadow_by_height[1][2][3] = 65.0;
            }
        });
        assert!(
            e.contains("level 1") && e.contains("60 degrees high"),
            "{e}"
        );
        let e = refusal(&t, |p| {
            if let Some(e) = &mut p.extension5 {
                e.self_shadow_by_height.pop();
            }
        });
        assert!(e.contains("by sun height"), "{e}");
        assert_eq!(minor_of(&encode(&sample_texel(3)).unwrap()), 2);
    }

    #[test]
    fn minor_versions_append_header_fields_that_older_readers_skip() {
        // A file of the newest minor version, whose every header field is present.
        let t = with_views(with_heights(sample_texel(3)));
        let bytes = encode(&t).unwrap();
        let p = container::preamble(&bytes).unwrap();
        // The same file with four more header bytes, as a newer minor version would append.
        let grow = |minor: u16| {
            let h = container::PREAMBLE + p.header_len as usize;
            let mut b = bytes[..h].to_vec();
            b[10..12].copy_from_slice(&minor.to_le_bytes());
            b[12..16].copy_from_slice(&(p.header_len + 4).to_le_bytes());
            b.extend_from_slice(b"more");
            b.extend_from_slice(&bytes[h..]);
            recrc(b)
        };
        assert_eq!(decode(&grow(MINOR + 1)).unwrap(), t);
        let e = decode(&grow(MINOR)).unwrap_err().to_string();
        assert!(e.contains("4 bytes after the header"), "{e}");
    }

    #[test]
    fn a_v1_0_file_reads_without_the_material_table() {
        let mut t = sample_texel(4);
        let bytes = encode(&t).unwrap();
        // Drop the v1.1 fields, wood pattern `Some("bark")` (1 + 8 + 4 bytes) and the
        // material table, and the v1.2 forms (a length and 7 f32 per level), which end the
        // header.
        let table = 8 + (8 + 4 + 4 + 4 + 8) + (8 + 9 + 4 + 4 + 8);
        let back = decode(&older(&bytes, 13 + table + directional_bytes(&t), 0)).unwrap();
        t.info.materials.clear();
        t.info.parameters.wood_pattern = None;
        assert_eq!(back, isotropic(t));
    }

    /// Bytes of the v1.2 header fields for `t`'s levels: three lengths, 7 + 6 + 1 f32 per
    /// level.
    fn directional_bytes(t: &Texel) -> usize {
        3 * 8 + (7 + 6 + 1) * 4 * t.levels.len()
    }

    fn isotropic(mut t: Texel) -> Texel {
        for l in &mut t.levels {
            l.directional = crate::volume::ISOTROPIC;
            l.self_shadow = SelfShadow::NONE;
            l.wood_weight = 1.0;
        }
        t
    }

    /// A 1.1 file (no directional forms) reads as isotropic: it renders as it always did.
    #[test]
    fn a_v1_1_file_reads_as_isotropic() {
        let mut t = sample_texel(6);
        t.levels[0].directional = [0.5, 2.0, 1.0, 0.1, 0.0, -0.1, 0.2];
        let bytes = encode(&t).unwrap();
        assert_eq!(decode(&bytes).unwrap(), t);
        let back = decode(&older(&bytes, directional_bytes(&t), 1)).unwrap();
        assert_eq!(back, isotropic(t));
    }
}
