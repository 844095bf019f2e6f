//! Every real tree model in ../shared/realdata bakes through the CLI, quirks included; skipped
//! where that folder is absent. Nothing here assumes which pack a model comes from: each
//! model's depfile is checked against the files its own glTF references.

mod common;

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use common::*;

/// The JSON of a `.gltf` or the JSON chunk of a `.glb`, read independently of the importer.
fn gltf_json(path: &Path) -> serde_json::Value {
    let bytes = std::fs::read(path).unwrap();
    let json = if bytes.starts_with(b"glTF") {
        let n = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        bytes[20..20 + n].to_vec()
    } else {
        bytes
    };
    serde_json::from_slice(&json).unwrap()
}

/// Files a glTF must depend on (itself, its external buffers, the images its meshes' materials
/// take base colour from) and the files it may depend on (every external URI it names).
fn referenced_files(path: &Path) -> (BTreeSet<PathBuf>, BTreeSet<PathBuf>) {
    let doc = gltf_json(path);
    let dir = path.parent().unwrap();
    let external = |uri: Option<&str>| uri.filter(|u| !u.starts_with("data:")).map(|u| dir.join(u));
    let list = |key: &str| doc[key].as_array().cloned().unwrap_or_default();
    let buffers: Vec<PathBuf> = list("buffers")
        .iter()
        .filter_map(|b| external(b["uri"].as_str()))
        .collect();
    let images = list("images");
    let textures = list("textures");
    let materials = list("materials");
    let mut must: BTreeSet<PathBuf> = buffers.iter().cloned().collect();
    must.insert(path.to_path_buf());
    for mesh in list("meshes") {
        for primitive in mesh["primitives"].as_array().unwrap() {
            let Some(m) = primitive["material"].as_u64() else {
                continue;
            };
            let texture = &materials[m as usize]["pbrMetallicRoughness"]["baseColorTexture"];
            if let Some(t) = texture["index"].as_u64() {
                let image = textures[t as usize]["source"].as_u64().unwrap();
                must.extend(external(images[image as usize]["uri"].as_str()));
            }
        }
    }
    let mut may = must.clone();
    may.extend(images.iter().filter_map(|i| external(i["uri"].as_str())));
    (must, may)
}

/// The prerequisites of a one-rule depfile (no escaped spaces in these names).
fn depfile_prerequisites(text: &str) -> BTreeSet<PathBuf> {
    let (_, deps) = text.trim_end().split_once(": ").unwrap();
    deps.split(' ').map(PathBuf::from).collect()
}

#[test]
fn every_real_tree_bakes_and_inspects() {
    let Some(trees) = realdata_trees() else {
        return;
    };
    assert!(!trees.is_empty());
    let dir = tempfile::tempdir().unwrap();
    for path in trees {
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        let out = format!("{name}.texel");
        let o = run(
            &[
                "bake",
                path.to_str().unwrap(),
                "-o",
                &out,
                "--depfile",
                "t.d",
            ],
            dir.path(),
        );
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let t =
            texel_forest::formats::texel::decode(&std::fs::read(dir.path().join(&out)).unwrap())
                .unwrap();
        assert!(
            t.info.mesh_coverage.iter().all(|&c| c > 0.05),
            "{name}: {:?}",
            t.info.mesh_coverage
        );

        let deps = depfile_prerequisites(&std::fs::read_to_string(dir.path().join("t.d")).unwrap());
        let (must, may) = referenced_files(&path);
        assert!(
            must.is_subset(&deps),
            "{name}: {deps:?} lacks some of {must:?}"
        );
        assert!(
            deps.is_subset(&may),
            "{name}: {deps:?} names files beyond {may:?}"
        );

        // Every model here has a trunk: it must keep wood, as density or as a solid, whatever
        // its materials' alpha modes say, or a leafless render would lose the tree.
        let l0 = &t.levels[0];
        let wood: f64 = l0.density[0]
            .iter()
            .chain(&l0.solid[0])
            .map(|&d| d as f64)
            .sum();
        assert!(wood > 0.0, "{name}: no wood");
        let o = run(
            &["inspect", &out, "--projection", "z", "-o", "p.png"],
            dir.path(),
        );
        assert!(o.status.success(), "{name}: {}", stderr(&o));
    }
}
