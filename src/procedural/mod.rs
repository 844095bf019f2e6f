//! Procedural models for the fixtures, the tests and the benchmarks. `fixture_files` is what
//! `make fixtures` writes under `fixtures/`; a test checks the committed files still match it.

pub mod builder;
pub mod terrain;
pub mod trees;

use std::path::Path;

use sha2::{Digest, Sha256};
use trees::Deciduous;

use crate::bake::{self, BakeSettings};
use crate::formats::texel;
use crate::volume::SourceFile;

const GENERATOR: &str = "texel-forest procedural fixtures";

/// PNG bytes of an RGBA image, with fixed encoder settings so the bytes are reproducible.
pub fn png(img: &image::RgbaImage) -> Vec<u8> {
    use image::ImageEncoder;
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new_with_quality(
        &mut out,
        image::codecs::png::CompressionType::Best,
        image::codecs::png::FilterType::Adaptive,
    )
    .write_image(
        img.as_raw(),
        img.width(),
        img.height(),
        image::ExtendedColorType::Rgba8,
    )
    .expect("encoding a PNG in memory cannot fail");
    out
}

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
    let bytes = std::fs::read(conifer_glb)?;
    let model = crate::import::load(conifer_glb)?;
    let mut t = bake::bake(
        &model.mesh,
        &BakeSettings {
            resolution: 8,
            fine: 32,
            ..BakeSettings::default()
        },
    )?;
    let sha256: [u8; 32] = Sha256::digest(&bytes).into();
    t.info.sources = vec![SourceFile {
        path: "../trees/conifer.glb".into(),
        sha256,
        bytes: bytes.len() as u64,
    }];
    t.info.inputs_sha256 = Sha256::digest(sha256).into();
    Ok(texel::encode(&t)?)
}
