//! Procedural models for the fixtures, the tests and the benchmarks. `fixture_files` is what
//! `make fixtures` writes under `fixtures/`; a test checks the committed files still match it.

pub mod builder;
pub mod invalid;
pub mod terrain;
pub mod trees;

use std::path::Path;

use trees::Deciduous;

use crate::bake::{self, BakeSettings};
use crate::formats::instances::{self, ForestInfo, SpeciesRecord, decode_rotation};
use crate::formats::texel;
use crate::place::Instance;
use crate::provenance::SourceFile;
use crate::species::{
    AutumnColor, ColorKey, Form, FractionKey, LeafHabit, LeafOut, Light, Seasons, Traits,
};
use crate::terrain::HeightmapOptions;

const GENERATOR: &str = "texel-forest procedural fixtures";

/// Every fixture file, as (path relative to `fixtures/`, bytes).
pub fn fixture_files() -> Vec<(String, Vec<u8>)> {
    let mut files = Vec::new();
    let conifer = trees::conifer(1).to_gltf(None, GENERATOR);
    files.push((
        "trees/conifer.glb".to_string(),
        builder::glb(&conifer.doc, &conifer.bin),
    ));
    // The broadleaf tree is a .gltf with an external buffer and image, the layout many
    // exporters write, so the fixtures exercise it too.
    let broadleaf = trees::deciduous(2, Deciduous::BROADLEAF).to_gltf(Some("broadleaf"), GENERATOR);
    let mut json = serde_json::to_vec_pretty(&broadleaf.doc).expect("JSON values serialise");
    json.push(b'\n');
    files.push(("trees/broadleaf.gltf".to_string(), json));
    files.push(("trees/broadleaf.bin".to_string(), broadleaf.bin));
    for (name, bytes) in broadleaf.images {
        files.push((format!("trees/{name}"), bytes));
    }
    let bare = trees::deciduous(3, Deciduous::BARE).to_gltf(None, GENERATOR);
    files.push((
        "trees/bare.glb".to_string(),
        builder::glb(&bare.doc, &bare.bin),
    ));
    // The demo's heightmap terrain: another mountain as a 129 x 129 16-bit grey PNG, 1 km
    // across, heights 100 to 600 m (make demo: --terrain-size 1000,1000 --height-range 100,600).
    files.push((
        "terrain/valley.png".to_string(),
        terrain::mountain_png(1000.0, 129, 11, [100.0, 600.0]),
    ));
    // The demo's terrain: a mountain 1 km across, 129 x 129 vertices (7.8 m cells).
    let mountain = terrain::mountain(1000.0, 129, 5).to_gltf(None, GENERATOR);
    files.push((
        "terrain/mountain.glb".to_string(),
        builder::glb(&mountain.doc, &mountain.bin),
    ));
    files
}

/// The golden `.texel` (`fixtures/formats/conifer-8.texel`): the conifer fixture baked at 8
/// cells, its source recorded as it lies relative to `fixtures/formats/`.
pub fn golden_texel(conifer_glb: &Path) -> anyhow::Result<Vec<u8>> {
    let model = crate::import::load(conifer_glb)?;
    let settings = BakeSettings {
        resolution: 8,
        fine: 32,
        ..BakeSettings::default()
    };
    // Recorded as it lies from `formats/`, beside the trees' directory.
    let formats = conifer_glb
        .parent()
        .unwrap_or(Path::new("."))
        .join("../formats");
    let t = bake::bake_model(&model, &settings, &formats)?;
    Ok(texel::encode(&t)?)
}

/// The golden `.instances` (`fixtures/formats/forest-12.instances`): twelve trees of two
/// species, written by hand so that every field and every corner of the encoding is pinned:
/// a leafless texture on one species and not the other, rotations at both ends of the turn,
/// scales either side of 1, variation at its extremes, deltas of both signs, and two trees
/// 42,000 km apart whose delta wraps modulo 2^32.
pub fn golden_instances() -> anyhow::Result<Vec<u8>> {
    let origin = [-1000.0, 120.0, -2000.0];
    let instances = golden_trees(origin);
    let info = golden_forest_info(origin, vec![golden_beech(), golden_pine()]);
    Ok(instances::encode(&instances::Forest {
        info,
        instances,
        heightmap: None,
    })?)
}

/// The golden 1.1 `.instances` (`fixtures/formats/forest-12-heightmap.instances`): the golden
/// forest placed on a heightmap, so the header ends with the conversion field 1.1 adds (a size
/// and a height range, both present).
pub fn golden_heightmap_instances() -> anyhow::Result<Vec<u8>> {
    let origin = [-1000.0, 120.0, -2000.0];
    let instances = golden_trees(origin);
    let mut info = golden_forest_info(origin, vec![golden_beech(), golden_pine()]);
    info.terrain = vec![SourceFile {
        path: "terrain/valley.png".into(),
        sha256: [0x73; 32],
        bytes: 30_000,
    }];
    Ok(instances::encode(&instances::Forest {
        info,
        instances,
        heightmap: Some(HeightmapOptions {
            size: Some([2000.0, 2000.0]),
            height_range: Some([-12.5, 480.5]),
        }),
    })?)
}

/// The golden file's deciduous species: a leafless texture, and seasons with several
/// keyframes, so both optional fields and multi-key curves are pinned.
fn golden_beech() -> SpeciesRecord {
    SpeciesRecord {
        name: "beech".into(),
        texel: "trees/broadleaf.texel".into(),
        texel_sha256: [0xb1; 32],
        leafless_texel: Some("trees/bare.texel".into()),
        leafless_sha256: Some([0xb2; 32]),
        model_height: 12.5,
        spacing: 4.0,
        height_min: 10.0,
        height_max: 20.0,
        traits: Traits {
            form: Form::Broadleaf,
            light: Light::ShadeTolerant,
            leaf_habit: LeafHabit::Deciduous,
            leaf_out: LeafOut::Successive,
            autumn_color: AutumnColor::Yellow,
        },
        seasons: Seasons {
            foliage: vec![
                ColorKey {
                    day: 120.0,
                    albedo: [0.05, 0.12, 0.03],
                },
                ColorKey {
                    day: 300.0,
                    albedo: [0.25, 0.12, 0.03],
                },
            ],
            leaf_fraction: vec![
                FractionKey {
                    day: 100.0,
                    value: 0.0,
                },
                FractionKey {
                    day: 130.0,
                    value: 1.0,
                },
                FractionKey {
                    day: 310.0,
                    value: 1.0,
                },
                FractionKey {
                    day: 330.0,
                    value: 0.0,
                },
            ],
        },
    }
}

/// The golden file's evergreen species: no leafless texture and single-key seasons, the
/// other side of each field the beech pins.
fn golden_pine() -> SpeciesRecord {
    SpeciesRecord {
        name: "red pine".into(),
        texel: "trees/conifer.texel".into(),
        texel_sha256: [0xc1; 32],
        leafless_texel: None,
        leafless_sha256: None,
        model_height: 14.2,
        spacing: 3.0,
        height_min: 8.0,
        height_max: 16.0,
        traits: Traits {
            form: Form::Conifer,
            light: Light::SunLoving,
            leaf_habit: LeafHabit::Evergreen,
            leaf_out: LeafOut::Simultaneous,
            autumn_color: AutumnColor::None,
        },
        seasons: Seasons {
            foliage: vec![ColorKey {
                day: 1.0,
                albedo: [0.04, 0.08, 0.03],
            }],
            leaf_fraction: vec![FractionKey {
                day: 1.0,
                value: 1.0,
            }],
        },
    }
}

/// The golden file's twelve trees, given in the encoding's own units (centimetres and codes)
/// so each lands exactly on a value the encoding can hold and decodes to what was written.
fn golden_trees(origin: [f64; 3]) -> Vec<Instance> {
    // (x, z, y) in centimetres from the origin, species, rotation code, scale, variation.
    let trees: [(i64, i64, i64, u8, u16, f32, u16); 12] = [
        (0, 0, 0, 0, 0, 1.0, 0),
        (350, 120, 15, 1, 16384, 0.8, 1),
        (700, 80, 31, 0, 32768, 1.25, 65535),
        (1050, 400, -20, 1, 65535, 0.5, 7),
        (900, 1500, 250, 0, 1, 1.6, 1234),
        (200, 1400, 260, 1, 49152, 0.7, 40000),
        (-300, 900, 100, 0, 8192, 1.0, 2),
        (-1200, -600, -400, 1, 24576, 1.1, 3),
        (123_456, 654_321, 9_999, 0, 40960, 0.9, 4),
        (2_100_000_000, 5, 0, 1, 100, 1.0, 5),
        (-2_100_000_000, 5, 0, 0, 200, 1.0, 6),
        (1, 2, 3, 1, 300, 1.5, 8),
    ];
    trees
        .iter()
        .map(|&(x, z, y, species, rotation, scale, variation)| Instance {
            species,
            position: [
                origin[0] + x as f64 * 0.01,
                origin[1] + y as f64 * 0.01,
                origin[2] + z as f64 * 0.01,
            ],
            rotation: decode_rotation(rotation),
            scale: instances::decode_scale(instances::encode_scale(scale)),
            variation,
        })
        .collect()
}

/// The golden file's header: every field set to a value that tells it apart, sources with
/// recognisable fake hashes, and the largest `max_count` so its full width is pinned.
fn golden_forest_info(origin: [f64; 3], species: Vec<SpeciesRecord>) -> ForestInfo {
    let source = |path: &str, fill: u8, bytes: u64| SourceFile {
        path: path.into(),
        sha256: [fill; 32],
        bytes,
    };
    ForestInfo {
        generator: "texel-forest golden file".into(),
        terrain: vec![
            source("terrain/mountain.gltf", 0x71, 4096),
            source("terrain/mountain.bin", 0x72, 1_048_576),
        ],
        species_file: source("species/forest.json", 0x5f, 4017),
        seed: 42,
        region: [-1000.0, -2000.0, 1000.0, 0.0],
        raster_cell: 7.8125,
        max_count: u64::MAX,
        truncated: false,
        terrain_min: [-1000.0, 100.0, -2000.0],
        terrain_max: [1000.0, 480.5, 0.0],
        origin,
        species,
    }
}
