//! `.instances` v1: a placed forest (see `formats/instances.md`, which this module mirrors).
//! Version 1.1 adds one header field after `count`, the heightmap conversion of a terrain that
//! was an image; a forest on a glTF terrain is still written as 1.0, byte for byte as before.

use bincode::{Decode, Encode};

use super::container::{self, ContainerError, PayloadStream, header_config};
use crate::limits::{LimitError, Limits};
use crate::number::shortest;
use crate::provenance::SourceFile;
use crate::species::{Seasons, Traits};

pub const MAGIC: &[u8; 8] = b"\x89TXINST\n";
pub const MAJOR: u16 = 1;
/// The newest minor version this module reads and writes.
pub const MINOR: u16 = 1;
/// The minor version that added `heightmap` after `count`.
pub const HEIGHTMAP_MINOR: u16 = 1;

/// Position quantum: one centimetre.
pub const QUANTUM: f64 = 0.01;
/// Scale codes per doubling: a stored scale is `2^((v - 32768) / SCALE_STEPS)`.
pub const SCALE_STEPS: f64 = 2048.0;
/// The range of scales the codes hold: 2^-16 up to (not including) 2^16.
pub const MIN_SCALE: f64 = 1.0 / 65536.0;
pub const MAX_SCALE: f64 = 65536.0;

/// One tree, as a forest file records it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    /// Index into the species table.
    pub species: u8,
    /// World position of the base of the trunk (metres); y is on the terrain.
    pub position: [f64; 3],
    /// Rotation about +Y, radians in [0, 2 pi).
    pub rotation: f32,
    /// Factor from the texel model's units to the tree's size.
    pub scale: f32,
    /// Free for renderers: per-tree variation of colour and the like.
    pub variation: u16,
}

/// Bytes of one instance before compression (x, z, y: 4 each; species 1; rotation, scale,
/// variation: 2 each).
pub const RAW_BYTES_PER_INSTANCE: usize = 19;
/// Most instances a reader accepts (2 GiB of payload / 19 bytes is about 113 million).
const MAX_COUNT: u64 = (container::MAX_PAYLOAD) / RAW_BYTES_PER_INSTANCE as u64;

/// A species as the renderer needs it.
#[derive(Clone, Debug, PartialEq, Encode, Decode, serde::Serialize)]
pub struct SpeciesRecord {
    pub name: String,
    /// The texture, relative to the directory of the `.instances` file.
    pub texel: String,
    #[serde(serialize_with = "crate::hex::hex32")]
    pub texel_sha256: [u8; 32],
    /// A leafless texture for winter, relative to the `.instances` file, and its hash.
    pub leafless_texel: Option<String>,
    #[serde(skip)]
    pub leafless_sha256: Option<[u8; 32]>,
    /// Height of the texel's model, in its own units (the scale's denominator).
    pub model_height: f64,
    /// Disc radius (m) a tree of the reference height keeps free; scales with height.
    pub spacing: f64,
    /// Tree height range (m); the reference height is their mean.
    pub height_min: f64,
    pub height_max: f64,
    pub traits: Traits,
    pub seasons: Seasons,
}

impl SpeciesRecord {
    /// Radius (m) of the disc a tree of this species at `scale` keeps free.
    pub fn radius(&self, scale: f64) -> f64 {
        self.spacing * scale * self.model_height / (0.5 * (self.height_min + self.height_max))
    }
}

/// How to turn a heightmap's samples into metres: what `--terrain-size` and `--height-range`
/// say, recorded in a forest placed on a heightmap so a render rebuilds the same mesh.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, bincode::Encode, bincode::Decode, serde::Serialize,
)]
pub struct HeightmapOptions {
    /// Full extent east-west and north-south (m), first to last sample.
    pub size: Option<[f64; 2]>,
    /// Heights (m) of integer sample 0 and of the type's largest value.
    pub height_range: Option<[f64; 2]>,
}

impl HeightmapOptions {
    pub fn is_empty(&self) -> bool {
        self.size.is_none() && self.height_range.is_none()
    }

    /// Refuses sizes and ranges no terrain can have (`field` names them as the user gave them).
    pub fn validate(&self) -> Result<(), (String, String)> {
        if let Some([x, z]) = self.size
            && !(x.is_finite() && z.is_finite() && x > 0.0 && z > 0.0)
        {
            return Err((
                "--terrain-size".into(),
                format!(
                    "{},{} is not two positive finite extents",
                    shortest(x),
                    shortest(z)
                ),
            ));
        }
        if let Some([lo, hi]) = self.height_range
            && !(lo.is_finite() && hi.is_finite() && lo < hi)
        {
            return Err((
                "--height-range".into(),
                format!("{},{} needs finite LO < HI", shortest(lo), shortest(hi)),
            ));
        }
        Ok(())
    }
}

/// Everything about a forest but its trees.
#[derive(Clone, Debug, PartialEq, Encode, Decode)]
pub struct ForestInfo {
    pub generator: String,
    /// The terrain glTF first, then its buffers and images; paths relative to the
    /// `.instances` file. A renderer compares the terrain's hash to detect a stale forest.
    pub terrain: Vec<SourceFile>,
    pub species_file: SourceFile,
    pub seed: u64,
    /// x0, z0, x1, z1 (m): the ground placed on.
    pub region: [f64; 4],
    /// Cell (m) of the height raster the habitat was judged on.
    pub raster_cell: f64,
    /// `--max-count`, or `u64::MAX`.
    pub max_count: u64,
    /// Whether `max_count` stopped placement before the ground was full.
    pub truncated: bool,
    /// Bounds of the terrain surface (m).
    pub terrain_min: [f64; 3],
    pub terrain_max: [f64; 3],
    /// Quantisation origin: position = origin + 0.01 x stored integer (m).
    pub origin: [f64; 3],
    pub species: Vec<SpeciesRecord>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Forest {
    pub info: ForestInfo,
    pub instances: Vec<Instance>,
    /// How the terrain image was turned into a mesh, when the terrain is a heightmap (the
    /// 1.1 header field after `count`); `None` for a glTF terrain (a 1.0 file).
    pub heightmap: Option<HeightmapOptions>,
}

impl Forest {
    /// The minor version this forest is written as: 1.0 unless it needs a later field.
    pub fn minor(&self) -> u16 {
        if self.heightmap.is_some() {
            HEIGHTMAP_MINOR
        } else {
            0
        }
    }
}

/// A forest's trees as the payload stores them, centimetres from the origin and the codes: 19
/// bytes a tree where an [`Instance`] takes 40, for a reader that holds millions of trees
/// only to look at them (`texel inspect`). [`Trees::get`] is the tree [`decode`] gives.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Trees {
    origin: [f64; 3],
    /// x, y, z.
    position: [Vec<i32>; 3],
    species: Vec<u8>,
    rotation: Vec<u16>,
    scale: Vec<u16>,
    variation: Vec<u16>,
}

impl Trees {
    pub fn len(&self) -> usize {
        self.species.len()
    }

    pub fn is_empty(&self) -> bool {
        self.species.is_empty()
    }

    pub fn species(&self, i: usize) -> u8 {
        self.species[i]
    }

    pub fn position(&self, i: usize) -> [f64; 3] {
        std::array::from_fn(|a| self.coordinate(a, i))
    }

    /// One coordinate of tree `i` (0: x, 1: y, 2: z), as [`Trees::position`] gives it.
    pub fn coordinate(&self, axis: usize, i: usize) -> f64 {
        self.origin[axis] + self.position[axis][i] as f64 * QUANTUM
    }

    pub fn scale(&self, i: usize) -> f32 {
        decode_scale(self.scale[i])
    }

    pub fn get(&self, i: usize) -> Instance {
        Instance {
            species: self.species[i],
            position: self.position(i),
            rotation: decode_rotation(self.rotation[i]),
            scale: self.scale(i),
            variation: self.variation[i],
        }
    }

    pub fn iter(&self) -> impl ExactSizeIterator<Item = Instance> + '_ {
        (0..self.len()).map(|i| self.get(i))
    }
}

/// A forest whose trees are kept as [`Trees`] ([`decode_stored_with`]).
#[derive(Clone, Debug, PartialEq)]
pub struct StoredForest {
    pub info: ForestInfo,
    pub trees: Trees,
    pub heightmap: Option<HeightmapOptions>,
}

#[derive(Encode, Decode)]
pub(crate) struct Header {
    pub(crate) info: ForestInfo,
    pub(crate) count: u64,
}

#[derive(Debug, thiserror::Error)]
pub enum InstancesError {
    #[error(transparent)]
    Container(#[from] ContainerError),
    #[error("corrupt header: {0}")]
    Header(String),
    #[error("corrupt payload: {0}")]
    Payload(String),
    #[error(transparent)]
    Limit(#[from] LimitError),
    /// What a writer refuses to write, because readers would refuse it.
    #[error("cannot write this forest: {0}")]
    Unwritable(String),
}

fn zigzag(d: i32) -> u32 {
    ((d << 1) ^ (d >> 31)) as u32
}

fn unzigzag(v: u32) -> i32 {
    ((v >> 1) as i32) ^ -((v & 1) as i32)
}

/// `v` as `width` byte planes appended to `out`: all first bytes, then all second bytes...
fn push_planes(out: &mut Vec<u8>, values: &[u32], width: usize) {
    for b in 0..width {
        out.extend(values.iter().map(|v| (v >> (8 * b)) as u8));
    }
}

/// The payload's next column of `n` values of `T`'s width, stored as byte planes, read a slice
/// of a plane at a time: no more of the payload is held than that slice.
fn read_column<T>(payload: &mut PayloadStream, n: usize) -> Result<Vec<T>, ContainerError>
where
    T: Copy + Default + From<u8> + std::ops::Shl<usize, Output = T> + std::ops::BitOrAssign,
{
    const SLICE: usize = 1 << 16;
    let mut values = vec![T::default(); n];
    let mut bytes = vec![0; SLICE.min(n)];
    for plane in 0..size_of::<T>() {
        for values in values.chunks_mut(SLICE) {
            let bytes = &mut bytes[..values.len()];
            payload.read_exact(bytes)?;
            for (v, &b) in values.iter_mut().zip(bytes.iter()) {
                *v |= T::from(b) << (8 * plane);
            }
        }
    }
    Ok(values)
}

/// Scale as a u16 on a log scale: 2^((v - 32768) / 2048), 0.034% steps from 2^-16 to 2^16.
pub fn encode_scale(scale: f32) -> u16 {
    ((scale as f64).log2() * SCALE_STEPS + 32768.0)
        .round()
        .clamp(0.0, 65535.0) as u16
}

pub fn decode_scale(v: u16) -> f32 {
    ((v as f64 - 32768.0) / SCALE_STEPS).exp2() as f32
}

/// Rotation in [0, 2 pi) as a u16 of 1/65536 turns.
pub fn encode_rotation(r: f32) -> u16 {
    ((r as f64 / std::f64::consts::TAU).rem_euclid(1.0) * 65536.0).round() as u32 as u16
}

pub fn decode_rotation(v: u16) -> f32 {
    (v as f64 / 65536.0 * std::f64::consts::TAU) as f32
}

/// Quantises a position component to centimetres from `origin`; `None` beyond what 32 bits
/// of centimetres reach (21,474 km).
fn quantise(v: f64, origin: f64) -> Option<i32> {
    let q = ((v - origin) / QUANTUM).round();
    (q.is_finite() && q >= i32::MIN as f64 && q <= i32::MAX as f64).then_some(q as i32)
}

/// What a reader would refuse in a forest about to be written.
fn check_writable(forest: &Forest) -> Result<(), InstancesError> {
    let unwritable = |m: String| Err(InstancesError::Unwritable(m));
    validate(&forest.info).or_else(|e| unwritable(e.to_string()))?;
    if let Some(h) = &forest.heightmap {
        validate_heightmap(h).or_else(|e| unwritable(e.to_string()))?;
    }
    if forest.instances.len() as u64 > MAX_COUNT {
        return unwritable(format!(
            "{} trees (a file holds at most {MAX_COUNT})",
            forest.instances.len()
        ));
    }
    let o = forest.info.origin;
    for (i, p) in forest.instances.iter().enumerate() {
        if p.species as usize >= forest.info.species.len() {
            return unwritable(format!("tree {i} names species {}", p.species));
        }
        if (0..3).any(|a| quantise(p.position[a], o[a]).is_none()) {
            return unwritable(format!(
                "tree {i} at {:?} is more than 21,000 km from the origin {o:?}",
                p.position
            ));
        }
        if !(p.scale.is_finite() && p.scale > 0.0 && p.rotation.is_finite()) {
            return unwritable(format!(
                "tree {i} has scale {} and rotation {}",
                p.scale, p.rotation
            ));
        }
        let stored = decode_scale(encode_scale(p.scale));
        if (stored / p.scale - 1.0).abs() > 1e-3 {
            return unwritable(format!(
                "tree {i} has scale {}, outside the stored range 2^-16 to 2^16; check the \
                 species' height against its texel's model height",
                p.scale
            ));
        }
    }
    Ok(())
}

/// Encodes a forest as `.instances` bytes (deterministic), refusing what a reader would refuse.
pub fn encode(forest: &Forest) -> Result<Vec<u8>, InstancesError> {
    check_writable(forest)?;
    let header = Header {
        info: forest.info.clone(),
        count: forest.instances.len() as u64,
    };
    let mut header = bincode::encode_to_vec(&header, header_config())
        .map_err(|e| ContainerError::TooLarge(format!("header: {e}")))?;
    if let Some(h) = &forest.heightmap {
        header.extend(
            bincode::encode_to_vec(h, header_config())
                .map_err(|e| ContainerError::TooLarge(format!("header: {e}")))?,
        );
    }
    Ok(container::write(
        MAGIC,
        MAJOR,
        forest.minor(),
        &header,
        &payload(forest),
    )?)
}

/// The seven columns of the payload.
fn payload(forest: &Forest) -> Vec<u8> {
    let o = forest.info.origin;
    let mut payload = Vec::with_capacity(forest.instances.len() * RAW_BYTES_PER_INSTANCE);
    for (axis, origin) in [(0, o[0]), (2, o[2]), (1, o[1])] {
        let mut previous = 0i32;
        let deltas: Vec<u32> = forest
            .instances
            .iter()
            .map(|p| {
                let q = quantise(p.position[axis], origin).unwrap_or_default();
                let d = zigzag(q.wrapping_sub(previous));
                previous = q;
                d
            })
            .collect();
        push_planes(&mut payload, &deltas, 4);
    }
    payload.extend(forest.instances.iter().map(|p| p.species));
    let column = |f: &dyn Fn(&Instance) -> u16| {
        forest
            .instances
            .iter()
            .map(|p| f(p) as u32)
            .collect::<Vec<u32>>()
    };
    push_planes(&mut payload, &column(&|p| encode_rotation(p.rotation)), 2);
    push_planes(&mut payload, &column(&|p| encode_scale(p.scale)), 2);
    push_planes(&mut payload, &column(&|p| p.variation), 2);
    payload
}

/// A file the writer would refuse: `forest`'s header and payload with `edit` applied, put in a
/// container without any check. For the corpus of invalid files readers are tested against.
#[cfg(feature = "dev-tools")]
pub(crate) fn forge(forest: &Forest, edit: impl FnOnce(&mut Header, &mut Vec<u8>)) -> Vec<u8> {
    let mut header = Header {
        info: forest.info.clone(),
        count: forest.instances.len() as u64,
    };
    let mut payload = payload(forest);
    edit(&mut header, &mut payload);
    bincode::encode_to_vec(&header, header_config())
        .ok()
        .and_then(|h| container::write(MAGIC, MAJOR, 0, &h, &payload).ok())
        .unwrap_or_default()
}

/// Decodes `.instances` bytes within the default [`Limits`].
pub fn decode(bytes: &[u8]) -> Result<Forest, InstancesError> {
    decode_with(bytes, &Limits::default())
}

/// Decodes `.instances` bytes: container, then the header (validated, the tree count checked
/// against the payload's declared length and `limits`), and only then the payload.
pub fn decode_with(bytes: &[u8], limits: &Limits) -> Result<Forest, InstancesError> {
    let StoredForest {
        info,
        trees,
        heightmap,
    } = decode_stored_with(bytes, limits)?;
    Ok(Forest {
        info,
        instances: trees.iter().collect(),
        heightmap,
    })
}

/// [`decode_stored_with`] within the default [`Limits`].
pub fn decode_stored(bytes: &[u8]) -> Result<StoredForest, InstancesError> {
    decode_stored_with(bytes, &Limits::default())
}

/// Decodes `.instances` bytes as [`decode_with`] does (the same checks and errors), keeping
/// the trees as [`Trees`].
pub fn decode_stored_with(bytes: &[u8], limits: &Limits) -> Result<StoredForest, InstancesError> {
    let opened = container::open(bytes, MAGIC, "instances", MAJOR)?;
    let bad = |m: String| InstancesError::Header(m);
    let (header, used): (Header, usize) =
        bincode::decode_from_slice(opened.header, header_config())
            .map_err(|e| bad(container::decode_error(&e)))?;
    // The heightmap conversion follows `count` from 1.1 on.
    let mut used = used;
    let heightmap = if opened.minor >= HEIGHTMAP_MINOR {
        let (h, n): (HeightmapOptions, usize) =
            bincode::decode_from_slice(&opened.header[used..], header_config())
                .map_err(|e| bad(format!("heightmap: {}", container::decode_error(&e))))?;
        used += n;
        validate_heightmap(&h)?;
        Some(h)
    } else {
        None
    };
    // Header fields a newer minor version appended are skipped (formats/container.md).
    let is_newer = opened.minor > MINOR;
    if used != opened.header.len() && !is_newer {
        return Err(bad(format!(
            "{} bytes after the header",
            opened.header.len() - used
        )));
    }
    let info = header.info;
    validate(&info)?;
    if header.count > MAX_COUNT || header.count * RAW_BYTES_PER_INSTANCE as u64 != opened.raw_len()
    {
        return Err(bad(format!(
            "{} trees need {} payload bytes, the container says {}",
            header.count,
            header.count.saturating_mul(RAW_BYTES_PER_INSTANCE as u64),
            opened.raw_len()
        )));
    }
    limits.check_trees(header.count, "the forest's tree count")?;
    // Column by column from the decompressing stream: the decoded trees and a slice of the
    // payload are all that is held, not the payload as well (a hostile 11 KB file can declare
    // 16 million trees, 319 MB of payload).
    let n = header.count as usize;
    let mut payload = opened.payload_stream()?;
    let mut position: [Vec<i32>; 3] = Default::default();
    for axis in [0, 2, 1] {
        let mut value = 0i32;
        position[axis] = read_column::<u32>(&mut payload, n)?
            .into_iter()
            .map(|d| {
                value = value.wrapping_add(unzigzag(d));
                value
            })
            .collect();
    }
    let species = read_column::<u8>(&mut payload, n)?;
    let rotation = read_column(&mut payload, n)?;
    let scale = read_column(&mut payload, n)?;
    let variation = read_column(&mut payload, n)?;
    payload.finish()?;
    if let Some(i) = species
        .iter()
        .position(|&s| s as usize >= info.species.len())
    {
        return Err(InstancesError::Payload(format!(
            "tree {i} names species {} of {}",
            species[i],
            info.species.len()
        )));
    }
    Ok(StoredForest {
        trees: Trees {
            origin: info.origin,
            position,
            species,
            rotation,
            scale,
            variation,
        },
        info,
        heightmap,
    })
}

/// Check 10 of formats/instances.md: a recorded heightmap conversion a terrain can have.
fn validate_heightmap(h: &HeightmapOptions) -> Result<(), InstancesError> {
    h.validate()
        .map_err(|(field, m)| InstancesError::Header(format!("heightmap: {field}: {m}")))
}

fn validate(info: &ForestInfo) -> Result<(), InstancesError> {
    let bad = |m: String| Err(InstancesError::Header(m));
    let finite = |v: &[f64]| v.iter().all(|c| c.is_finite());
    if !(finite(&info.region)
        && finite(&info.terrain_min)
        && finite(&info.terrain_max)
        && finite(&info.origin))
    {
        return bad("bounds are not finite".into());
    }
    let r = info.region;
    if !(r[0] < r[2] && r[1] < r[3]) {
        return bad(format!("region {r:?} is empty (needs x0 < x1 and z0 < z1)"));
    }
    if !(info.raster_cell.is_finite() && info.raster_cell > 0.0) {
        return bad(format!(
            "raster cell {} is not a positive finite number",
            info.raster_cell
        ));
    }
    if info.species.is_empty() || info.species.len() > 255 {
        return bad(format!("{} species (1 to 255 allowed)", info.species.len()));
    }
    for s in &info.species {
        let sizes = [
            ("model_height", s.model_height),
            ("spacing", s.spacing),
            ("height_min", s.height_min),
            ("height_max", s.height_max),
        ];
        if let Some((field, v)) = sizes.iter().find(|(_, v)| !(v.is_finite() && *v > 0.0)) {
            return bad(format!(
                "species {:?}: {field} {} is not a positive finite number",
                s.name,
                shortest(*v)
            ));
        }
        if s.height_min > s.height_max {
            return bad(format!(
                "species {:?}: height_min {} exceeds height_max {}",
                s.name,
                shortest(s.height_min),
                shortest(s.height_max)
            ));
        }
        if s.leafless_texel.is_some() != s.leafless_sha256.is_some() {
            return bad(format!(
                "species {:?}: leafless_texel and leafless_sha256 must be both present or both absent",
                s.name
            ));
        }
        if let Err((field, message)) = s.seasons.validate("seasons") {
            return bad(format!("species {:?}: {field}: {message}", s.name));
        }
    }
    if info.terrain.is_empty() {
        return bad("no terrain source".into());
    }
    Ok(())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::species::SpeciesFile;

    pub(crate) fn sample_forest(n: usize) -> Forest {
        let species = SpeciesFile::parse(crate::species::tests::MINIMAL.as_bytes())
            .unwrap()
            .species;
        let s = &species[0];
        let record = SpeciesRecord {
            name: s.name.clone(),
            texel: "trees/beech.texel".into(),
            texel_sha256: [3; 32],
            leafless_texel: Some("trees/bare.texel".into()),
            leafless_sha256: Some([4; 32]),
            model_height: 12.5,
            spacing: s.spacing,
            height_min: s.height.min,
            height_max: s.height.max,
            traits: s.traits,
            seasons: s.seasons.clone(),
        };
        let source = |p: &str| SourceFile {
            path: p.into(),
            sha256: [1; 32],
            bytes: 10,
        };
        let origin = [29_000.0, 200.0, -31_000.0];
        let instances = (0..n)
            .map(|i| Instance {
                species: 0,
                position: [
                    origin[0] + i as f64 * 3.17,
                    origin[1] + (i % 7) as f64 * 0.5,
                    origin[2] + (i % 13) as f64 * 2.01,
                ],
                rotation: decode_rotation((i * 977) as u16),
                scale: decode_scale(30_000 + i as u16),
                variation: (i * 31) as u16,
            })
            .collect();
        Forest {
            info: ForestInfo {
                generator: "test".into(),
                terrain: vec![source("terrain.glb")],
                species_file: source("species.json"),
                seed: 7,
                region: [origin[0], origin[2], origin[0] + 1e4, origin[2] + 1e4],
                raster_cell: 10.0,
                max_count: u64::MAX,
                truncated: false,
                terrain_min: [0.0; 3],
                terrain_max: [1.0; 3],
                origin,
                species: vec![record],
            },
            instances,
            heightmap: None,
        }
    }

    #[test]
    fn round_trip_keeps_centimetres_far_from_the_origin() {
        let f = sample_forest(1000);
        let back = decode(&encode(&f).unwrap()).unwrap();
        assert_eq!(back.info, f.info);
        for (a, b) in f.instances.iter().zip(&back.instances) {
            for c in 0..3 {
                assert!(
                    (a.position[c] - b.position[c]).abs() <= 0.005 + 1e-9,
                    "{a:?} {b:?}"
                );
            }
            assert_eq!(
                (a.species, a.variation, a.rotation, a.scale),
                (b.species, b.variation, b.rotation, b.scale)
            );
        }
        assert_eq!(encode(&back).unwrap(), encode(&f).unwrap());
    }

    /// A forest on a heightmap is a 1.1 file whose conversion reads back; on a glTF, 1.0 with
    /// nothing after `count`.
    #[test]
    fn heightmap_conversion_is_a_1_1_field_after_count() {
        let mut f = sample_forest(5);
        let plain = encode(&f).unwrap();
        assert_eq!(container::preamble(&plain).unwrap().minor, 0);
        f.heightmap = Some(HeightmapOptions {
            size: Some([1000.0, 800.0]),
            height_range: None,
        });
        let bytes = encode(&f).unwrap();
        assert_eq!(container::preamble(&bytes).unwrap().minor, 1);
        // Option tags: 1 then two f64, then 0.
        assert_eq!(bytes.len(), plain.len() + 1 + 16 + 1);
        assert_eq!(decode(&bytes).unwrap(), f);
        f.heightmap = Some(HeightmapOptions {
            size: None,
            height_range: Some([5.0, 5.0]),
        });
        let e = encode(&f).unwrap_err().to_string();
        assert!(e.contains("--height-range") && e.contains("LO < HI"), "{e}");
    }

    #[test]
    fn scale_and_rotation_codes_are_fine_enough() {
        for s in [0.01f32, 0.5, 1.0, 3.7, 27.0, 400.0] {
            assert!(
                (decode_scale(encode_scale(s)) / s - 1.0).abs() < 2e-4,
                "{s}"
            );
        }
        assert_eq!(encode_rotation(std::f32::consts::TAU), 0);
        assert!((decode_rotation(encode_rotation(1.0)) - 1.0).abs() < 1e-4);
    }

    #[test]
    fn zigzag_round_trips_extremes() {
        for d in [0, 1, -1, i32::MAX, i32::MIN, 12345, -54321] {
            assert_eq!(unzigzag(zigzag(d)), d);
        }
    }

    #[test]
    fn corrupt_counts_and_species_are_refused() {
        let f = sample_forest(10);
        let bytes = encode(&f).unwrap();
        for n in (0..bytes.len()).step_by(5) {
            assert!(decode(&bytes[..n]).is_err());
        }
        let mut wrong = f.clone();
        wrong.instances[3].species = 9;
        let e = encode(&wrong).unwrap_err().to_string();
        assert!(e.contains("cannot write") && e.contains("species 9"), "{e}");
        let e = decode(&forge(&wrong, |_, _| {})).unwrap_err().to_string();
        assert!(e.contains("tree 3 names species 9"), "{e}");
    }
}
