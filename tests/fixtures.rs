//! The committed fixtures are exactly what the generator writes (`make fixtures`).

#[test]
fn regenerating_the_fixtures_gives_the_committed_bytes() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    for (name, bytes) in texel_forest::procedural::fixture_files() {
        let committed = std::fs::read(root.join(&name))
            .unwrap_or_else(|e| panic!("fixtures/{name}: {e}; run `make fixtures`"));
        assert!(
            committed == bytes,
            "fixtures/{name} differs from the generator's output; run `make fixtures` and review"
        );
    }
}

#[test]
fn fixture_trees_are_within_the_triangle_budget() {
    for tree in ["conifer.glb", "broadleaf.gltf", "bare.glb"] {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fixtures/trees")
            .join(tree);
        let model = texel_forest::import::load(&path).unwrap();
        let n = model.mesh.triangles.len();
        assert!((2_000..=50_000).contains(&n), "{tree}: {n} triangles");
        assert!(model.warnings.is_empty(), "{tree}: {:?}", model.warnings);
    }
}
