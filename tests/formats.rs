//! `.texel` readers never panic and never trust sizes: random, truncated and corrupted inputs
//! give errors. And the format is pinned by a golden file.

mod common;

use proptest::prelude::*;
use texel_forest::bake::{self, BakeSettings};
use texel_forest::formats::texel;
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
    texel::encode(&t)
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
    let forged = container::write(texel::MAGIC, 1, 0, &header, &c.payload);
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
    assert_eq!(&golden[8..12], &[1, 0, 0, 0]);
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
