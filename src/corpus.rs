//! The tree models the benchmarks, the accuracy report and the tests run over: the procedural
//! fixtures, always, and the real models in `../shared/realdata/trees` where that folder exists.

use std::path::{Path, PathBuf};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The fixture trees, in a fixed order.
pub fn fixture_trees() -> Vec<PathBuf> {
    ["conifer.glb", "broadleaf.gltf", "bare.glb"]
        .iter()
        .map(|f| root().join("fixtures/trees").join(f))
        .collect()
}

/// Every `.glb` and `.gltf` below `../shared/realdata/trees`, sorted; `None` where it is absent.
pub fn real_trees() -> Option<Vec<PathBuf>> {
    let dirs = std::fs::read_dir(root().join("../shared/realdata/trees")).ok()?;
    let mut found: Vec<PathBuf> = dirs
        .flatten()
        .flat_map(|d| std::fs::read_dir(d.path()).into_iter().flatten().flatten())
        .map(|e| e.path())
        .filter(|p| matches!(p.extension().and_then(|e| e.to_str()), Some("glb" | "gltf")))
        .collect();
    found.sort();
    Some(found)
}
