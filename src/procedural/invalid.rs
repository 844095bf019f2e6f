//! The corpus of invalid files (`fixtures/formats/invalid/`): one file for every refusal the
//! specs in `formats/` list, each made from a valid file with exactly that defect. Tests assert
//! that our readers refuse each with its message, and CI that a reader written from the specs
//! alone refuses them too. Every damaged file ever met belongs here.

use crate::bake::{mip_chain, sobel};
use crate::formats::container::PREAMBLE;
use crate::formats::{instances, texel};
use crate::volume::{
    BakeParameters, DensityModel, Level, MaterialPart, PartReason, SelfShadow, Texel, TexelInfo,
};

/// An invalid file: its name under `fixtures/formats/invalid/`, its bytes, and a piece of the
/// message `texel` refuses it with.
pub struct InvalidFile {
    pub name: String,
    pub bytes: Vec<u8>,
    pub refusal: &'static str,
}

/// A small valid texture: 3 x 2 x 2 cells and its mips, two materials.
fn small_texel() -> Texel {
    let dims = [3, 2, 2];
    let mut level = Level::empty(dims, 0.5);
    for i in 0..level.cell_count() {
        level.density[0][i] = (i % 3) as f32 * 0.5;
        level.density[1][i] = (i % 4) as f32 * 0.25;
        level.albedo[0][i] = [0.3, 0.2, 0.1];
        level.albedo[1][i] = [0.1, 0.4, 0.1];
    }
    for part in 0..2 {
        level.gradient[part] = sobel::gradient(&level.density[part], dims, level.cell);
    }
    let material = |name: &str, foliage, reason, triangles| MaterialPart {
        name: name.into(),
        foliage,
        reason,
        cut: 0.0,
        triangles,
    };
    Texel {
        info: TexelInfo {
            generator: "texel-forest invalid corpus".into(),
            model_min: [0.0; 3],
            model_max: [1.5, 1.0, 1.0],
            origin: [0.0; 3],
            density_model: DensityModel::Transmittance,
            extinction_scale: 1.0,
            triangles: 30,
            foliage_triangles: 20,
            mesh_coverage: [0.5; 3],
            sources: vec![],
            inputs_sha256: [0; 32],
            parameters: BakeParameters {
                resolution: 3,
                fine: 12,
                foliage_pattern: "leaf".into(),
                requested_gamma: None,
                wood_pattern: None,
            },
            materials: vec![
                material("bark", false, PartReason::Solid, 10),
                material("leaf", true, PartReason::FoliagePattern, 20),
            ],
        },
        levels: mip_chain(level, 1.0)
            .into_iter()
            .map(|mut l| {
                // Rows by the sun's height and by the eye's height and sun's turn, as every
                // bake of a tree with foliage has: the corpus is of the newest minor version.
                let row = |h: usize| std::array::from_fn(|a| (a + h) as f32 * 0.5);
                l.self_shadow = SelfShadow {
                    pooled: row(1),
                    by_height: std::array::from_fn(row),
                    by_view: Some(std::array::from_fn(|e| std::array::from_fn(|t| row(e + t)))),
                };
                l
            })
            .collect(),
    }
}

/// `bytes` with the container's CRC made right again after an edit.
fn recrc(mut bytes: Vec<u8>) -> Vec<u8> {
    let body = bytes.len() - 4;
    let crc = crc32fast::hash(&bytes[..body]);
    bytes[body..].copy_from_slice(&crc.to_le_bytes());
    bytes
}

/// `valid` with its payload replaced by `frames` (and R by `raw_len`), CRC fixed.
fn with_payload(valid: &[u8], frames: &[u8], raw_len: u64) -> Vec<u8> {
    let h = u32::from_le_bytes(valid[12..16].try_into().unwrap_or_default()) as usize;
    let mut out = valid[..PREAMBLE + h].to_vec();
    out[16..24].copy_from_slice(&raw_len.to_le_bytes());
    out[24..32].copy_from_slice(&(frames.len() as u64).to_le_bytes());
    out.extend_from_slice(frames);
    out.extend_from_slice(&[0; 4]);
    recrc(out)
}

/// `valid` with four bytes appended to its header (and the minor version set to `minor`).
fn grown_header(valid: &[u8], minor: u16) -> Vec<u8> {
    let h = u32::from_le_bytes(valid[12..16].try_into().unwrap_or_default());
    let end = PREAMBLE + h as usize;
    let mut out = valid[..end].to_vec();
    out[10..12].copy_from_slice(&minor.to_le_bytes());
    out[12..16].copy_from_slice(&(h + 4).to_le_bytes());
    out.extend_from_slice(b"more");
    out.extend_from_slice(&valid[end..]);
    recrc(out)
}

fn container_files(valid: &[u8], files: &mut Vec<InvalidFile>) {
    let mut add = |name: &str, bytes: Vec<u8>, refusal| {
        files.push(InvalidFile {
            name: format!("container-{name}.texel"),
            bytes,
            refusal,
        })
    };
    let patched = |at: usize, with: &[u8]| {
        let mut b = valid.to_vec();
        b[at..at + with.len()].copy_from_slice(with);
        recrc(b)
    };
    let mut magic = valid.to_vec();
    magic[0] = b'X';
    add(
        "magic",
        magic,
        "wrong magic bytes, the first byte was altered",
    );
    add("truncated", valid[..valid.len() - 9].to_vec(), "truncated");
    let mut trailing = valid.to_vec();
    trailing.extend_from_slice(b"xyz");
    add("trailing-data", trailing, "trailing data");
    add(
        "major-2",
        patched(8, &2u16.to_le_bytes()),
        "is newer than this reader",
    );
    add(
        "major-0",
        patched(8, &0u16.to_le_bytes()),
        "is older than this reader",
    );
    add(
        "header-over-16-mib",
        patched(12, &((16u32 << 20) + 1).to_le_bytes()),
        "header length 16777217 exceeds",
    );
    add(
        "payload-over-2-gib",
        patched(16, &((2u64 << 30) + 1).to_le_bytes()),
        "payload length 2147483649 exceeds",
    );
    add(
        "stored-length-absurd",
        patched(24, &(u64::MAX / 2).to_le_bytes()),
        "exceeds what zstd makes of",
    );
    // The header's first field, the generator's length, claims a terabyte.
    add(
        "header-length-field-absurd",
        patched(PREAMBLE, &(1u64 << 40).to_le_bytes()),
        "corrupt header: a length or field runs past the end of the header",
    );
    let mut crc = valid.to_vec();
    let last = crc.len() - 5;
    crc[last] ^= 0x40;
    add("checksum", crc, "checksum mismatch");

    let raw = u64::from_le_bytes(valid[16..24].try_into().unwrap_or_default());
    let payload = decompressed_payload(valid);
    let frame = zstd::bulk::compress(&payload, 9).unwrap_or_default();
    let half = raw as usize / 2;
    let two = [
        zstd::bulk::compress(&payload[..half], 9).unwrap_or_default(),
        zstd::bulk::compress(&payload[half..], 9).unwrap_or_default(),
    ]
    .concat();
    add(
        "two-zstd-frames",
        with_payload(valid, &two, raw),
        "follow the payload's zstd frame",
    );
    let skippable = [&[0x50, 0x2A, 0x4D, 0x18][..], &4u32.to_le_bytes(), b"skip"].concat();
    add(
        "skippable-frame-first",
        with_payload(valid, &[skippable.clone(), frame.clone()].concat(), raw),
        "does not start with a zstd frame",
    );
    add(
        "skippable-frame-after",
        with_payload(valid, &[frame, skippable].concat(), raw),
        "follow the payload's zstd frame",
    );
    let mut no_size = zstd::bulk::Compressor::new(9).unwrap_or_else(|_| unreachable!());
    let _ = no_size.include_contentsize(false);
    add(
        "frame-without-content-size",
        with_payload(valid, &no_size.compress(&payload).unwrap_or_default(), raw),
        "does not declare its content size",
    );
    add(
        "header-bytes-left-over",
        grown_header(valid, texel::MINOR),
        "4 bytes after the header",
    );
}

fn decompressed_payload(valid: &[u8]) -> Vec<u8> {
    let h = u32::from_le_bytes(valid[12..16].try_into().unwrap_or_default()) as usize;
    zstd::decode_all(&valid[PREAMBLE + h..valid.len() - 4]).unwrap_or_default()
}

/// Adds one invalid file to the corpus: its name (without family prefix or extension), its
/// bytes and a piece of the refusal.
type Add<'a> = dyn FnMut(&str, Vec<u8>, &'static str) + 'a;

/// Texture files valid as containers but whose contents break a rule of `formats/texel.md`,
/// family by family, each made from one small valid texture.
fn texel_files(files: &mut Vec<InvalidFile>) {
    let base = small_texel();
    let mut add = |name: &str, bytes: Vec<u8>, refusal| {
        files.push(InvalidFile {
            name: format!("texel-{name}.texel"),
            bytes,
            refusal,
        })
    };
    texel_level_chain_files(&base, &mut add);
    texel_channel_files(&base, &mut add);
    texel_material_files(&base, &mut add);
    texel_directional_files(&base, &mut add);
    texel_payload_layout_files(&base, &mut add);
    texel_level_value_files(&base, &mut add);
}

/// The header's geometry: the bounds, the extinction scale and the chain of levels, whose
/// sizes a reader must check before it trusts them to size the payload.
fn texel_level_chain_files(base: &Texel, add: &mut Add) {
    let forge = |edit: &dyn Fn(&mut texel::Parts)| texel::forge(base, edit);
    add(
        "bounds-nan",
        forge(&|p| p.header.model_max[1] = f64::NAN),
        "bounds are not finite",
    );
    add(
        "extinction-scale-zero",
        forge(&|p| p.header.extinction_scale = 0.0),
        "extinction scale 0 is not a positive number",
    );
    // A value the message must show in a few characters, not in 301 digits.
    add(
        "extinction-scale-minus-1e300",
        forge(&|p| p.header.extinction_scale = -1e300),
        "extinction scale -1e300 is not a positive number",
    );
    add("no-levels", forge(&|p| p.header.levels.clear()), "0 levels");
    add(
        "seventeen-levels",
        forge(&|p| {
            let last = p.header.levels[p.header.levels.len() - 1].clone();
            while p.header.levels.len() < 17 {
                p.header.levels.push(last.clone());
            }
        }),
        "17 levels",
    );
    add(
        "level-0-side-0",
        forge(&|p| p.header.levels[0].dims[1] = 0),
        "level 0 has [3, 0, 2] cells",
    );
    add(
        "level-0-side-4097",
        forge(&|p| p.header.levels[0].dims[0] = 4097),
        "level 0 has [4097, 2, 2] cells",
    );
    // A decompression bomb's header: 300^3 cells (31 million with the mips; 2.4 GB of payload,
    // which zeros compress to some 70 KB) is over the default limit, refused before the
    // payload is looked at.
    add(
        "cells-over-the-default-limit",
        forge(&|p| {
            let mut dims = [300u32; 3];
            let mut cell = 0.1;
            p.header.levels.clear();
            loop {
                p.header.levels.push(texel::LevelHeader { dims, cell });
                if dims == [1, 1, 1] {
                    break;
                }
                dims = dims.map(|d| d.div_ceil(2));
                cell *= 2.0;
            }
            let n = p.header.levels.len();
            let e = &mut p.extension2;
            e.directional.resize(n, e.directional[0]);
            e.self_shadow.resize(n, e.self_shadow[0]);
            e.wood_weight.resize(n, e.wood_weight[0]);
            if let Some(e) = &mut p.extension5 {
                e.self_shadow_by_height
                    .resize(n, e.self_shadow_by_height[0]);
            }
            if let Some(e) = &mut p.extension6 {
                e.self_shadow_by_view.resize(n, e.self_shadow_by_view[0]);
            }
        }),
        "the texture's cell count (all levels) is 30859767, over the limit of 4194304",
    );
    add(
        "cell-negative",
        forge(&|p| p.header.levels[0].cell = -0.5),
        "cell size -0.5 is not a positive number",
    );
    add(
        "level-not-half",
        forge(&|p| p.header.levels[1].dims = [2, 2, 1]),
        "level 1 is not half of level 0",
    );
    add(
        "cell-not-doubled",
        forge(&|p| p.header.levels[1].cell = 1.0000001),
        "level 1 is not half of level 0",
    );
    add(
        "level-after-single-cell",
        forge(&|p| {
            let last = p.header.levels[p.header.levels.len() - 1].clone();
            p.header.levels.push(texel::LevelHeader {
                dims: [1, 1, 1],
                cell: last.cell * 2.0,
            });
        }),
        "follows a single-cell level",
    );
    add(
        "chain-not-ending-in-one-cell",
        forge(&|p| {
            p.header.levels.pop();
        }),
        "does not end in a single cell",
    );
}

/// The channel list: how many channels, and that each is well formed and named once.
fn texel_channel_files(base: &Texel, add: &mut Add) {
    let forge = |edit: &dyn Fn(&mut texel::Parts)| texel::forge(base, edit);
    add(
        "sixty-five-channels",
        forge(&|p| {
            for k in p.header.channels.len()..65 {
                let mut ch = p.header.channels[0].clone();
                ch.name = format!("extra_{k}");
                p.header.channels.push(ch);
            }
        }),
        "65 channels",
    );
    add(
        "channel-without-components",
        forge(&|p| p.header.channels[5].components = 0),
        "channel albedo_foliage has 0 components",
    );
    add(
        "duplicate-channel",
        forge(&|p| {
            let ch = p.header.channels[0].clone();
            p.header.channels.push(ch);
        }),
        "channel density_wood appears twice",
    );
}

/// The triangle accounting: the foliage count and the materials must agree with the total.
fn texel_material_files(base: &Texel, add: &mut Add) {
    let forge = |edit: &dyn Fn(&mut texel::Parts)| texel::forge(base, edit);
    add(
        "foliage-over-triangles",
        forge(&|p| p.header.foliage_triangles = 31),
        "31 foliage triangles of 30",
    );
    add(
        "materials-do-not-add-up",
        forge(&|p| p.extension.materials[0].triangles = 11),
        "the materials hold 31 triangles",
    );
    add(
        "material-cut-out-of-range",
        forge(&|p| p.extension.materials[1].cut = 1.5),
        "cut share of 1.5",
    );
}

/// The directional forms, self-shadowing rows and wood weights (1.2): one per level, every
/// form entry a number within +-4096, every factor within 0 to 64, every weight within 1/4096
/// to 4096.
fn texel_directional_files(base: &Texel, add: &mut Add) {
    let forge = |edit: &dyn Fn(&mut texel::Parts)| texel::forge(base, edit);
    add(
        "directional-count",
        forge(&|p| {
            p.extension2.directional.pop();
        }),
        "directional forms for",
    );
    add(
        "directional-nan",
        forge(&|p| p.extension2.directional[1][6] = f32::NAN),
        "directional form",
    );
    add(
        "directional-huge",
        forge(&|p| p.extension2.directional[0][3] = 5000.0),
        "within -4096 to 4096",
    );
    add(
        "self-shadow-count",
        forge(&|p| {
            p.extension2.self_shadow.push([1.0; 6]);
        }),
        "self-shadowing rows for",
    );
    add(
        "self-shadow-negative",
        forge(&|p| p.extension2.self_shadow[2][1] = -0.5),
        "not a number within 0 to 64",
    );
    add(
        "wood-weight-count",
        forge(&|p| {
            p.extension2.wood_weight.pop();
        }),
        "wood weights for",
    );
    add(
        "wood-weight-zero",
        forge(&|p| p.extension2.wood_weight[1] = 0.0),
        "wood weight 0 is not a number within 1/4096 to 4096",
    );
    add(
        "self-shadow-nan",
        forge(&|p| p.extension2.self_shadow[0][4] = f32::NAN),
        "self-shadowing factors",
    );
    add(
        "self-shadow-by-height-count",
        forge(&|p| {
            if let Some(e) = &mut p.extension5 {
                e.self_shadow_by_height.pop();
            }
        }),
        "self-shadowing rows by sun height for",
    );
    add(
        "self-shadow-by-height-huge",
        forge(&|p| {
            if let Some(e) = &mut p.extension5 {
                e.self_shadow_by_height[1][3][2] = 100.0;
            }
        }),
        "for a sun 90 degrees high",
    );
    add(
        "self-shadow-by-view-count",
        forge(&|p| {
            if let Some(e) = &mut p.extension6 {
                e.self_shadow_by_view.pop();
            }
        }),
        "self-shadowing rows by eye height and sun turn for",
    );
    add(
        "self-shadow-by-view-huge",
        forge(&|p| {
            if let Some(e) = &mut p.extension6 {
                e.self_shadow_by_view[0][2][0][3] = 65.0;
            }
        }),
        "for an eye 60 degrees high and a sun turned 0 degrees",
    );
}

/// The payload against the header: its length, and the channels a reader needs to find in it
/// with the encoding it expects.
fn texel_payload_layout_files(base: &Texel, add: &mut Add) {
    use texel::Encoding;
    let forge = |edit: &dyn Fn(&mut texel::Parts)| texel::forge(base, edit);
    add(
        "payload-length",
        forge(&|p| p.payload.extend_from_slice(&[0; 4])),
        "payload bytes, the container says",
    );
    add(
        "required-channel-missing",
        forge(&|p| p.header.channels[0].name = "density_wooden".into()),
        "required channel density_wood is missing",
    );
    add(
        "channel-encoding",
        forge(&|p| {
            // Six more bytes for each of the 15 cells, so only the encoding is wrong.
            p.header.channels[4].encoding = Encoding::F32;
            p.payload.extend_from_slice(&[0; 90]);
        }),
        "channel albedo_wood has 3 x F32",
    );
}

/// Values in the levels themselves, which only a reader that checks every cell catches: made
/// by editing the texture and encoding it, so the header and payload agree.
fn texel_level_value_files(base: &Texel, add: &mut Add) {
    let edited = |edit: &dyn Fn(&mut Texel)| {
        let mut t = base.clone();
        edit(&mut t);
        texel::forge(&t, |_| {})
    };
    add(
        "density-negative",
        edited(&|t| t.levels[0].density[0][1] = -1.0),
        "density -1 in a level",
    );
    add(
        "density-nan",
        edited(&|t| t.levels[1].density[1][0] = f32::NAN),
        "density NaN in a level",
    );
    add(
        "gradient-infinite",
        edited(&|t| t.levels[0].gradient[1][2][1] = f32::INFINITY),
        "a gradient in a level of [3, 2, 2] cells is not finite",
    );
    add(
        "leaves-out-of-range",
        edited(&|t| t.levels[0].leaves[1][0] = 1.5),
        "leaf-normal moment [1.5,",
    );
    add(
        "leaves-nan",
        edited(&|t| t.levels[1].leaves[0][4] = f32::NAN),
        "is not one of unit normals",
    );
    add(
        "leaves-channel-layout",
        // The same bytes per cell (24) as 12 x Unorm16: only the layout check can refuse it.
        texel::forge(base, |p| {
            let ch = &mut p.header.channels[6];
            ch.components = 12;
            ch.encoding = texel::Encoding::Unorm16;
        }),
        "channel leaves_foliage has 12 x Unorm16",
    );
    // (1.4) The wood's normal moments, checked as the leaves' are.
    let with_wood = |edit: &dyn Fn(&mut Texel)| {
        let mut t = base.clone();
        for level in &mut t.levels {
            level.wood_normals = vec![crate::volume::ISOTROPIC_LEAVES; level.cell_count()];
        }
        edit(&mut t);
        t
    };
    add(
        "wood-normals-out-of-range",
        texel::forge(
            &with_wood(&|t| t.levels[0].wood_normals[2][1] = -0.5),
            |_| {},
        ),
        "wood-normal moment [0.33333334, -0.5,",
    );
    add(
        "wood-normals-channel-layout",
        texel::forge(&with_wood(&|_| {}), |p| {
            let ch = &mut p.header.channels[7];
            ch.components = 12;
            ch.encoding = texel::Encoding::Unorm16;
        }),
        "channel normals_wood has 12 x Unorm16",
    );
    // (1.7) The wood's shown density, checked as the densities are.
    let with_shown = |edit: &dyn Fn(&mut Texel)| {
        let mut t = base.clone();
        for level in &mut t.levels {
            level.wood_shown = level.density[0].clone();
        }
        edit(&mut t);
        t
    };
    add(
        "shown-wood-negative",
        texel::forge(&with_shown(&|t| t.levels[0].wood_shown[3] = -2.0), |_| {}),
        "shown_wood: -2 at cell 3",
    );
    add(
        "shown-wood-channel-layout",
        // The same bytes per cell (4) as 2 x Unorm16: only the layout check can refuse it.
        texel::forge(&with_shown(&|_| {}), |p| {
            for ch in p
                .header
                .channels
                .iter_mut()
                .filter(|c| c.name == "shown_wood")
            {
                ch.components = 2;
                ch.encoding = texel::Encoding::Unorm16;
            }
        }),
        "channel shown_wood has 2 x Unorm16",
    );
}

fn instances_files(valid: &[u8], files: &mut Vec<InvalidFile>) {
    let Ok(base) = instances::decode(valid) else {
        return;
    };
    let mut add = |name: &str, bytes: Vec<u8>, refusal| {
        files.push(InvalidFile {
            name: format!("instances-{name}.instances"),
            bytes,
            refusal,
        })
    };
    let forge = |edit: &dyn Fn(&mut instances::Header, &mut Vec<u8>)| instances::forge(&base, edit);
    add(
        "region-empty",
        forge(&|h, _| h.info.region[2] = h.info.region[0]),
        "is empty (needs x0 < x1 and z0 < z1)",
    );
    add(
        "origin-infinite",
        forge(&|h, _| h.info.origin[2] = f64::INFINITY),
        "bounds are not finite",
    );
    add(
        "raster-cell-zero",
        forge(&|h, _| h.info.raster_cell = 0.0),
        "raster cell 0 is not a positive finite number",
    );
    add(
        "no-species",
        forge(&|h, _| h.info.species.clear()),
        "0 species (1 to 255 allowed)",
    );
    add(
        "model-height-zero",
        forge(&|h, _| h.info.species[0].model_height = 0.0),
        "model_height 0 is not a positive finite number",
    );
    add(
        "spacing-nan",
        forge(&|h, _| h.info.species[1].spacing = f64::NAN),
        "spacing NaN is not a positive finite number",
    );
    add(
        "height-min-negative",
        forge(&|h, _| h.info.species[0].height_min = -1.0),
        "height_min -1 is not a positive finite number",
    );
    add(
        "height-max-infinite",
        forge(&|h, _| h.info.species[0].height_max = f64::INFINITY),
        "height_max inf is not a positive finite number",
    );
    add(
        "heights-reversed",
        forge(&|h, _| h.info.species[1].height_min = 30.0),
        "height_min 30 exceeds height_max 16",
    );
    add(
        "leafless-without-hash",
        forge(&|h, _| h.info.species[0].leafless_sha256 = None),
        "must be both present or both absent",
    );
    add(
        "season-days-not-increasing",
        forge(&|h, _| h.info.species[0].seasons.leaf_fraction[2].day = 120.0),
        "days must increase",
    );
    add(
        "season-albedo-above-one",
        forge(&|h, _| h.info.species[1].seasons.foliage[0].albedo[1] = 2.0),
        "components must be linear values in [0, 1]",
    );
    add(
        "season-empty",
        forge(&|h, _| h.info.species[1].seasons.foliage.clear()),
        "is empty: give at least one keyframe",
    );
    add(
        "no-terrain-source",
        forge(&|h, _| h.info.terrain.clear()),
        "no terrain source",
    );
    add(
        "count-and-payload-disagree",
        forge(&|h, _| h.count += 1),
        "13 trees need 247 payload bytes, the container says 228",
    );
    add(
        "species-out-of-range",
        forge(&|_, payload| payload[12 * 12 + 4] = 2),
        "tree 4 names species 2 of 2",
    );
    add(
        "header-bytes-left-over",
        grown_header(valid, 0),
        "4 bytes after the header",
    );
}

/// Every invalid file, made from the golden `.instances` (`golden_instances`) and a small
/// texture.
pub fn invalid_files(golden_instances: &[u8]) -> Vec<InvalidFile> {
    let mut files = Vec::new();
    let valid = texel::encode(&small_texel()).unwrap_or_default();
    container_files(&valid, &mut files);
    texel_files(&mut files);
    instances_files(golden_instances, &mut files);
    files
}
