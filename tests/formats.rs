//! `.texel` readers never panic and never trust sizes: random, truncated and corrupted inputs
//! give errors. And the format is pinned by a golden file.

mod common;

use proptest::prelude::*;
use texel_forest::bake::{self, BakeSettings};
use texel_forest::formats::{instances, texel};
use texel_forest::import;

fn valid_file() -> Vec<u8> {
    let model = import::load(&common::fixture("trees/conifer.glb")).unwrap();
    let t = bake::bake(
        &model.mesh,
        &BakeSettings {
            resolution: 8,
            fine: 32,
            ..Default::default()
        },
    )
    .unwrap();
    texel::encode(&t).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn random_bytes_are_refused(bytes in proptest::collection::vec(any::<u8>(), 0..2048)) {
        prop_assert!(texel::decode(&bytes).is_err());
    }

    #[test]
    fn random_bytes_after_a_valid_magic_are_refused(bytes in proptest::collection::vec(any::<u8>(), 0..2048)) {
        let mut b = texel::MAGIC.to_vec();
        b.extend_from_slice(&bytes);
        prop_assert!(texel::decode(&b).is_err());
    }
}

#[test]
fn every_truncation_is_refused() {
    let bytes = valid_file();
    assert!(texel::decode(&bytes).is_ok());
    for n in (0..bytes.len())
        .step_by(7)
        .chain(bytes.len() - 8..bytes.len())
    {
        let e = texel::decode(&bytes[..n]).unwrap_err().to_string();
        assert!(e.contains("truncated") || e.contains("magic"), "{n}: {e}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Flipped bytes anywhere are caught (mostly by the checksum).
    #[test]
    fn corrupted_files_are_refused(at in any::<prop::sample::Index>(), flip in 1u8..=255) {
        let mut bytes = valid_file();
        let i = at.index(bytes.len());
        bytes[i] ^= flip;
        prop_assert!(texel::decode(&bytes).is_err());
    }
}

/// A file whose checksum is right but whose header asks for absurd sizes is refused before any
/// allocation: the header is re-encoded with huge dimensions and a fresh checksum.
#[test]
fn absurd_sizes_with_a_valid_checksum_are_refused() {
    use texel_forest::formats::container;
    let bytes = valid_file();
    let c = container::read(&bytes, texel::MAGIC, "texel", 1).unwrap();
    // Find the first level's dims (5 x 8 x 5 cells) in the header and blow one up.
    let mut header = c.header.clone();
    let dims: Vec<u8> = [5u32, 8, 5].iter().flat_map(|d| d.to_le_bytes()).collect();
    let dims_at = header
        .windows(12)
        .position(|w| w == dims.as_slice())
        .unwrap();
    header[dims_at..dims_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
    let forged = container::write(texel::MAGIC, 1, 0, &header, &c.payload).unwrap();
    let e = texel::decode(&forged).unwrap_err().to_string();
    assert!(e.contains("corrupt header"), "{e}");
}

/// Golden file: `fixtures/formats/conifer-8.texel` is the conifer baked at 8 cells. It pins
/// the byte layout (and the bake) end to end; if it changes on purpose, regenerate it with
/// `make fixtures` and say why in the commit.
#[test]
fn golden_texel_decodes_and_is_reproduced() {
    let golden =
        std::fs::read(common::fixture("formats/conifer-8.texel")).expect("run `make fixtures`");
    let t = texel::decode(&golden).unwrap();
    assert_eq!(t.levels[0].dims, [5, 8, 5]);
    assert_eq!(&golden[..8], b"\x89TEXEL\r\n");
    assert_eq!(&golden[8..12], &[1, 0, 7, 0]);
    let fresh = golden_bytes();
    assert!(
        fresh == golden,
        "the bake or the format changed: regenerate with `make fixtures` if intended"
    );
}

/// The golden bytes, as `make fixtures` writes them (sources recorded by name only).
fn golden_bytes() -> Vec<u8> {
    texel_forest::procedural::golden_texel(&common::fixture("trees/conifer.glb")).unwrap()
}

/// A small valid `.instances` file.
fn valid_forest_file() -> Vec<u8> {
    use texel_forest::formats::instances::{Forest, ForestInfo, SpeciesRecord};
    use texel_forest::place::Instance;
    use texel_forest::provenance::SourceFile;
    use texel_forest::species::SpeciesFile;
    let species = SpeciesFile::load(&common::fixture("species/forest.json")).unwrap();
    let s = &species.species[0];
    let source = SourceFile {
        path: "t.glb".into(),
        sha256: [5; 32],
        bytes: 1,
    };
    let info = ForestInfo {
        generator: "test".into(),
        terrain: vec![source.clone()],
        species_file: source,
        seed: 1,
        region: [0.0, 0.0, 100.0, 100.0],
        raster_cell: 5.0,
        max_count: u64::MAX,
        truncated: false,
        terrain_min: [0.0; 3],
        terrain_max: [100.0; 3],
        origin: [0.0; 3],
        species: vec![SpeciesRecord {
            name: s.name.clone(),
            texel: "a.texel".into(),
            texel_sha256: [1; 32],
            leafless_texel: None,
            leafless_sha256: None,
            model_height: 10.0,
            spacing: s.spacing,
            height_min: s.height.min,
            height_max: s.height.max,
            traits: s.traits,
            seasons: s.seasons.clone(),
        }],
    };
    let instances = (0..200)
        .map(|i| Instance {
            species: 0,
            position: [(i % 20) as f64 * 5.0, 50.0, (i / 20) as f64 * 5.0],
            rotation: i as f32 * 0.1,
            scale: 1.5,
            variation: i as u16,
        })
        .collect();
    instances::encode(&Forest {
        info,
        instances,
        heightmap: None,
    })
    .unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn instances_random_bytes_after_the_magic_are_refused(bytes in proptest::collection::vec(any::<u8>(), 0..2048)) {
        let mut b = instances::MAGIC.to_vec();
        b.extend_from_slice(&bytes);
        prop_assert!(instances::decode(&b).is_err());
    }

    #[test]
    fn instances_corrupted_files_are_refused(at in any::<prop::sample::Index>(), flip in 1u8..=255) {
        let mut bytes = valid_forest_file();
        let i = at.index(bytes.len());
        bytes[i] ^= flip;
        prop_assert!(instances::decode(&bytes).is_err());
    }
}

#[test]
fn instances_truncations_are_refused() {
    let bytes = valid_forest_file();
    assert_eq!(instances::decode(&bytes).unwrap().instances.len(), 200);
    for n in 0..bytes.len() {
        assert!(instances::decode(&bytes[..n]).is_err(), "{n}");
    }
}

/// Golden 1.1 file: `fixtures/formats/forest-12-heightmap.instances`, the golden forest on a
/// heightmap, with the conversion after `count`.
#[test]
fn golden_heightmap_instances_decode_and_are_reproduced() {
    let golden = std::fs::read(common::fixture("formats/forest-12-heightmap.instances"))
        .expect("run `make fixtures`");
    assert!(
        texel_forest::procedural::golden_heightmap_instances().unwrap() == golden,
        "the format changed: regenerate with `make fixtures` if intended"
    );
    let f = instances::decode(&golden).unwrap();
    let h = f.heightmap.expect("a 1.1 file records the conversion");
    assert_eq!(h.size, Some([2000.0, 2000.0]));
    assert_eq!(h.height_range, Some([-12.5, 480.5]));
    assert_eq!(f.instances.len(), 12);
}

/// Golden file: `fixtures/formats/forest-12.instances`, written by hand in
/// `procedural::golden_instances`; `formats/instances.md` pins its decoded values.
#[test]
fn golden_instances_decode_and_are_reproduced() {
    let golden =
        std::fs::read(common::fixture("formats/forest-12.instances")).expect("run `make fixtures`");
    assert!(
        texel_forest::procedural::golden_instances().unwrap() == golden,
        "the format changed: regenerate with `make fixtures` if intended"
    );
    let f = instances::decode(&golden).unwrap();
    assert_eq!(f.info.species.len(), 2);
    assert_eq!(f.instances.len(), 12);
    let o = f.info.origin;
    let cm = |i: usize| {
        let p = f.instances[i].position;
        [0, 2, 1].map(|a| ((p[a] - o[a]) / 0.01).round() as i64)
    };
    // The values formats/instances.md lists.
    assert_eq!(cm(1), [350, 120, 15]);
    assert_eq!(cm(7), [-1200, -600, -400]);
    assert_eq!(cm(9), [2_100_000_000, 5, 0]);
    assert_eq!(cm(10), [-2_100_000_000, 5, 0]);
    let t = &f.instances[3];
    assert_eq!(
        (
            t.species,
            instances::encode_rotation(t.rotation),
            instances::encode_scale(t.scale),
            t.variation
        ),
        (1, 65535, instances::encode_scale(0.5), 7)
    );
    assert_eq!(instances::encode_scale(0.5), 30720);
}

/// `fixtures/formats/invalid/`: one file for every refusal the specs list. Each is what the
/// generator makes, and each is refused with its own message (not merely refused).
#[test]
fn every_invalid_file_is_refused_with_its_message() {
    let dir = common::fixture("formats/invalid");
    let golden = std::fs::read(common::fixture("formats/forest-12.instances")).unwrap();
    let files = texel_forest::procedural::invalid::invalid_files(&golden);
    let mut committed: Vec<String> = std::fs::read_dir(&dir)
        .expect("run `make fixtures`")
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    committed.sort();
    let mut made: Vec<String> = files.iter().map(|f| f.name.clone()).collect();
    made.sort();
    assert_eq!(committed, made, "run `make fixtures`");
    for f in &files {
        let bytes = std::fs::read(dir.join(&f.name)).unwrap();
        assert!(
            bytes == f.bytes,
            "{}: differs from the generator's; run `make fixtures`",
            f.name
        );
        // Read as the CLI reads it: no further than the preamble allows.
        let bytes = texel_forest::formats::container::read_file(&dir.join(&f.name)).unwrap();
        let e = if f.name.ends_with(".texel") {
            texel::decode(&bytes).map(|_| ()).map_err(|e| e.to_string())
        } else {
            instances::decode(&bytes)
                .map(|_| ())
                .map_err(|e| e.to_string())
        };
        let e = e.err().unwrap_or_else(|| panic!("{}: accepted", f.name));
        assert!(
            e.contains(f.refusal),
            "{}: {e:?} does not say {:?}",
            f.name,
            f.refusal
        );
    }
}
