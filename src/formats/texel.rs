//! `.texel` v1: a baked 3D texture (see `formats/texel.md`, which this module mirrors).

use bincode::{Decode, Encode};

use super::container::{self, ContainerError, header_config};
use crate::volume::{BakeParameters, DensityModel, Level, SourceFile, Texel, TexelInfo};

pub const MAGIC: &[u8; 8] = b"\x89TEXEL\r\n";
pub const MAJOR: u16 = 1;
pub const MINOR: u16 = 0;

/// Limits a reader enforces before it allocates anything a header asks for.
const MAX_LEVELS: usize = 16;
const MAX_SIDE: u32 = 4096;
const MAX_CHANNELS: usize = 64;

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
struct ChannelHeader {
    name: String,
    components: u8,
    encoding: Encoding,
    unit: String,
}

#[derive(Clone, Debug, PartialEq, Encode, Decode)]
struct LevelHeader {
    dims: [u32; 3],
    cell: f64,
}

/// The header exactly as it is encoded; field order is the byte order.
#[derive(Clone, Debug, PartialEq, Encode, Decode)]
struct Header {
    generator: String,
    model_min: [f64; 3],
    model_max: [f64; 3],
    origin: [f64; 3],
    density_model: DensityModel,
    extinction_scale: f64,
    triangles: u64,
    foliage_triangles: u64,
    mesh_coverage: [f64; 3],
    sources: Vec<SourceFile>,
    inputs_sha256: [u8; 32],
    parameters: BakeParameters,
    levels: Vec<LevelHeader>,
    channels: Vec<ChannelHeader>,
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

#[derive(Debug, thiserror::Error)]
pub enum TexelError {
    #[error(transparent)]
    Container(#[from] ContainerError),
    #[error("corrupt header: {0}")]
    Header(String),
}

fn unorm16(v: f32) -> [u8; 2] {
    ((v.clamp(0.0, 1.0) * 65535.0).round() as u16).to_le_bytes()
}

/// Encodes a texture as `.texel` bytes (deterministic: same texture, same bytes).
pub fn encode(texel: &Texel) -> Result<Vec<u8>, ContainerError> {
    let info = &texel.info;
    let channels = v1_channels(info.density_model);
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
        parameters: info.parameters.clone(),
        levels: texel
            .levels
            .iter()
            .map(|l| LevelHeader {
                dims: l.dims.map(|d| d as u32),
                cell: l.cell,
            })
            .collect(),
        channels,
    };
    let header = bincode::encode_to_vec(&header, header_config())
        .map_err(|e| ContainerError::TooLarge(format!("header: {e}")))?;
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
    }
    container::write(MAGIC, MAJOR, MINOR, &header, &payload)
}

fn decode_header(bytes: &[u8]) -> Result<Header, TexelError> {
    let (header, used): (Header, usize) = bincode::decode_from_slice(bytes, header_config())
        .map_err(|e| TexelError::Header(e.to_string()))?;
    if used != bytes.len() {
        return Err(TexelError::Header(format!(
            "{} bytes after the header",
            bytes.len() - used
        )));
    }
    validate(&header)?;
    Ok(header)
}

/// The header of `.texel` bytes (checked, payload not decompressed): for tools that need a
/// texture's bounds but not its voxels.
pub fn read_info(bytes: &[u8]) -> Result<TexelInfo, TexelError> {
    let opened = container::open(bytes, MAGIC, "texel", MAJOR)?;
    Ok(info_of(decode_header(opened.header)?))
}

fn info_of(header: Header) -> TexelInfo {
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
        parameters: header.parameters,
    }
}

/// Decodes `.texel` bytes, validating every size before use.
pub fn decode(bytes: &[u8]) -> Result<Texel, TexelError> {
    let c = container::read(bytes, MAGIC, "texel", MAJOR)?;
    let bad = |m: String| TexelError::Header(m);
    let header = decode_header(&c.header)?;

    // Locate every channel's array within each level.
    let per_cell: usize = header
        .channels
        .iter()
        .map(|ch| ch.components as usize * ch.encoding.size())
        .sum();
    let expected: u64 = header
        .levels
        .iter()
        .map(|l| l.dims.iter().map(|&d| d as u64).product::<u64>() * per_cell as u64)
        .sum();
    if expected != c.payload.len() as u64 {
        return Err(bad(format!(
            "levels and channels need {expected} payload bytes, the file has {}",
            c.payload.len()
        )));
    }
    let find = |name: &str| header.channels.iter().position(|ch| ch.name == name);
    let required = v1_channels(header.density_model);
    let mut slots = Vec::new();
    for want in &required {
        let Some(i) = find(&want.name) else {
            return Err(bad(format!("required channel {} is missing", want.name)));
        };
        let have = &header.channels[i];
        if (have.components, have.encoding) != (want.components, want.encoding) {
            return Err(bad(format!(
                "channel {} has {} x {:?}, expected {} x {:?}",
                want.name, have.components, have.encoding, want.components, want.encoding
            )));
        }
        slots.push(i);
    }

    let mut levels = Vec::with_capacity(header.levels.len());
    let mut at = 0usize;
    for lh in &header.levels {
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
            &c.payload[offsets[i]..offsets[i] + len]
        };
        let f32s = |b: &[u8]| -> Vec<f32> {
            b.chunks_exact(4)
                .map(|x| f32::from_le_bytes([x[0], x[1], x[2], x[3]]))
                .collect()
        };
        let vec3 = |v: Vec<f32>| -> Vec<[f32; 3]> {
            v.chunks_exact(3).map(|x| [x[0], x[1], x[2]]).collect()
        };
        let unorm = |b: &[u8]| -> Vec<f32> {
            b.chunks_exact(2)
                .map(|x| u16::from_le_bytes([x[0], x[1]]) as f32 / 65535.0)
                .collect()
        };
        let level = Level {
            dims,
            cell: lh.cell,
            density: [f32s(bytes_of(0)), f32s(bytes_of(1))],
            gradient: [vec3(f32s(bytes_of(2))), vec3(f32s(bytes_of(3)))],
            albedo: [vec3(unorm(bytes_of(4))), vec3(unorm(bytes_of(5)))],
        };
        for part in 0..2 {
            if let Some(v) = level.density[part]
                .iter()
                .find(|v| !(v.is_finite() && **v >= 0.0))
            {
                return Err(bad(format!(
                    "density {v} in a level of {dims:?} cells is not a finite non-negative number"
                )));
            }
            if level.gradient[part]
                .iter()
                .flatten()
                .any(|v| !v.is_finite())
            {
                return Err(bad(format!(
                    "a gradient in a level of {dims:?} cells is not finite"
                )));
            }
        }
        levels.push(level);
    }
    Ok(Texel {
        info: info_of(header),
        levels,
    })
}

fn validate(h: &Header) -> Result<(), TexelError> {
    let bad = |m: String| Err(TexelError::Header(m));
    let finite3 = |v: &[f64; 3]| v.iter().all(|c| c.is_finite());
    if !(finite3(&h.model_min) && finite3(&h.model_max) && finite3(&h.origin)) {
        return bad("bounds are not finite".into());
    }
    if !(h.extinction_scale.is_finite() && h.extinction_scale > 0.0) {
        return bad(format!(
            "extinction scale {} is not a positive number",
            h.extinction_scale
        ));
    }
    if h.levels.is_empty() || h.levels.len() > MAX_LEVELS {
        return bad(format!(
            "{} levels (1 to {MAX_LEVELS} allowed)",
            h.levels.len()
        ));
    }
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
    let first = &h.levels[0];
    if first.dims.iter().any(|&d| d == 0 || d > MAX_SIDE) {
        return bad(format!(
            "level 0 has {:?} cells (1 to {MAX_SIDE} per side)",
            first.dims
        ));
    }
    for (i, pair) in h.levels.windows(2).enumerate() {
        let want = pair[0].dims.map(|d| d.div_ceil(2));
        if pair[1].dims != want || pair[1].cell != pair[0].cell * 2.0 {
            return bad(format!("level {} is not half of level {i}", i + 1));
        }
    }
    if h.levels.last().is_some_and(|l| l.dims != [1, 1, 1]) {
        return bad("the mip chain does not end in a single cell".into());
    }
    if !(first.cell.is_finite() && first.cell > 0.0) {
        return bad(format!("cell size {} is not a positive number", first.cell));
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
                },
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

    #[test]
    fn a_header_that_breaks_the_mip_rule_is_refused() {
        let mut t = sample_texel(2);
        t.levels[1].dims = [3, 2, 1];
        t.levels[1] = Level::empty([3, 2, 1], 0.5);
        let e = decode(&encode(&t).unwrap()).unwrap_err();
        assert!(e.to_string().contains("not half"), "{e}");
    }
}
