//! glTF / GLB import (and, when the scene has triangles, a tiny bake of it).
#![no_main]

use libfuzzer_sys::fuzz_target;
use texel_forest::bake::{BakeSettings, bake};
use texel_forest::import::load_bytes;
use texel_forest::limits::Limits;

fuzz_target!(|data: &[u8]| {
    let path = std::path::Path::new("/nonexistent/fuzz.gltf");
    if let Ok(model) = load_bytes(path, data.to_vec(), &Limits::default())
        && !model.mesh.triangles.is_empty()
    {
        let settings = BakeSettings {
            resolution: 8,
            fine: 16,
            ..Default::default()
        };
        let _ = bake(&model.mesh, &settings);
    }
});
