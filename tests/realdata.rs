//! Every real tree model in ../shared/realdata bakes through the CLI, quirks included; skipped
//! where that folder is absent.

mod common;

use common::*;

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
        let dep = std::fs::read_to_string(dir.path().join("t.d")).unwrap();
        if path.extension().is_some_and(|e| e == "gltf") {
            // KayKit models: external buffer and a shared texture atlas.
            assert!(
                dep.contains(".bin") && dep.contains("forest_texture.png"),
                "{dep}"
            );
        }
        // Kenney models name their leaf materials "leafs...": foliage by the default pattern.
        if name.starts_with("tree_") {
            assert!(t.info.foliage_triangles > 0, "{name}");
        }
        let o = run(
            &["inspect", &out, "--projection", "z", "-o", "p.png"],
            dir.path(),
        );
        assert!(o.status.success(), "{name}: {}", stderr(&o));
    }
}
