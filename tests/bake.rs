//! `texel bake` end to end: outputs, determinism, depfiles, and bad inputs.

mod common;

use common::*;
use glam::Vec3;
use serde_json::json;
use texel_forest::procedural::builder::{self, MaterialSpec, ModelBuilder};

#[test]
fn every_fixture_bakes_and_inspects() {
    let dir = tempfile::tempdir().unwrap();
    for tree in FIXTURE_TREES {
        let input = fixture(tree);
        let out = dir.path().join("t.texel");
        let o = run(
            &["bake", input.to_str().unwrap(), "-o", "t.texel", "--quiet"],
            dir.path(),
        );
        assert!(o.status.success(), "{tree}: {}", stderr(&o));
        assert!(
            stderr(&o).is_empty(),
            "--quiet prints nothing: {}",
            stderr(&o)
        );
        let bytes = std::fs::read(&out).unwrap();
        let texel = texel_forest::formats::texel::decode(&bytes).unwrap();
        assert_eq!(texel.levels[0].dims.iter().max(), Some(&32));
        assert_eq!(texel.levels.last().unwrap().dims, [1, 1, 1]);

        let o = run(&["inspect", "t.texel"], dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
        let text = String::from_utf8(o.stdout).unwrap();
        for field in [
            "resolution",
            "levels",
            "density",
            "fill ratio",
            "coverage",
            "sha256",
        ] {
            assert!(text.contains(field), "{field} missing from:\n{text}");
        }
        let o = run(&["inspect", "t.texel", "--json"], dir.path());
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["density_model"], "Transmittance");
        assert_eq!(v["sources"][0]["sha256"].as_str().unwrap().len(), 64);

        for args in [
            &["--projection", "y"][..],
            &["--slice", "z=3"][..],
            &["--projection", "x", "--level", "2"][..],
        ] {
            let mut a = vec!["inspect", "t.texel", "-o", "p.png"];
            a.extend_from_slice(args);
            let o = run(&a, dir.path());
            assert!(o.status.success(), "{args:?}: {}", stderr(&o));
            let img = image::open(dir.path().join("p.png")).unwrap();
            assert!(img.width() >= 32 && img.height() >= 32);
        }
    }
}

#[test]
fn same_inputs_give_the_same_bytes_for_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let input = fixture("trees/broadleaf.gltf");
    let i = input.to_str().unwrap();
    for (threads, name) in [("1", "a.texel"), ("2", "b.texel"), ("2", "c.texel")] {
        let o = run(&["--threads", threads, "bake", i, "-o", name], dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let occupancy = ["--density", "occupancy"];
    for (threads, name) in [("1", "d.texel"), ("2", "e.texel")] {
        let mut a = vec!["--threads", threads, "bake", i, "-o", name];
        a.extend_from_slice(&occupancy);
        assert!(run(&a, dir.path()).status.success());
    }
    let read = |n: &str| std::fs::read(dir.path().join(n)).unwrap();
    assert_eq!(read("a.texel"), read("b.texel"), "1 thread vs 2 threads");
    assert_eq!(read("b.texel"), read("c.texel"), "twice");
    assert_eq!(
        read("d.texel"),
        read("e.texel"),
        "occupancy, 1 vs 2 threads"
    );
}

#[test]
fn depfile_lists_the_gltf_its_buffer_and_its_image() {
    let dir = tempfile::tempdir().unwrap();
    let input = fixture("trees/broadleaf.gltf");
    let o = run(
        &[
            "bake",
            input.to_str().unwrap(),
            "-o",
            "out dir/b.texel",
            "--depfile",
            "b.d",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let dep = std::fs::read_to_string(dir.path().join("b.d")).unwrap();
    assert!(dep.starts_with("out\\ dir/b.texel: "), "{dep}");
    for f in ["broadleaf.gltf", "broadleaf.bin", "broadleaf_0.png"] {
        assert!(dep.contains(f), "{f} missing from {dep}");
    }
    assert_eq!(dep.lines().count(), 1);
    // The texel records its sources relative to itself.
    let texel = texel_forest::formats::texel::decode(
        &std::fs::read(dir.path().join("out dir/b.texel")).unwrap(),
    )
    .unwrap();
    let rel = &texel.info.sources[0].path;
    assert!(
        rel.ends_with("fixtures/trees/broadleaf.gltf") && rel.starts_with(".."),
        "{rel}"
    );
}

/// A tiny glTF: one primitive of `positions` (indexed as given) with `mode`, written as a
/// `.gltf` with the buffer in a data URI, then adjusted by `edit`.
fn tiny_gltf(
    positions: &[[f32; 3]],
    mode: u32,
    edit: impl FnOnce(&mut serde_json::Value),
) -> Vec<u8> {
    let bin: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let doc = json!({
        "asset": { "version": "2.0" },
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 }, "mode": mode }] }],
        "accessors": [{ "bufferView": 0, "componentType": 5126, "count": positions.len(), "type": "VEC3" }],
        "bufferViews": [{ "buffer": 0, "byteLength": bin.len() }],
        "buffers": [{ "byteLength": bin.len() }],
    });
    let mut doc: serde_json::Value =
        serde_json::from_slice(&builder::gltf_with_data_uri(doc, &bin)).unwrap();
    edit(&mut doc);
    serde_json::to_vec(&doc).unwrap()
}

const TETRA: [[f32; 3]; 12] = [
    [0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [0.0, 0.0, 0.0],
    [0.0, 0.0, 1.0],
    [0.0, 1.0, 0.0],
];

fn assert_bake_fails(name: &str, bytes: &[u8], needles: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join(name), bytes).unwrap();
    let o = run(
        &["bake", name, "-o", "out.texel", "--depfile", "out.d"],
        dir.path(),
    );
    let mut all = vec![name];
    all.extend_from_slice(needles);
    assert_error(&o, &all);
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .map(|e| e.file_name())
        .collect();
    assert_eq!(
        left,
        vec![std::ffi::OsString::from(name)],
        "no output, depfile or temporary left behind"
    );
}

#[test]
fn a_valid_tiny_model_bakes() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("t.gltf"), tiny_gltf(&TETRA, 4, |_| {})).unwrap();
    let o = run(&["bake", "t.gltf", "-o", "t.texel"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    // A triangle list cut short (the validator's MESH_PRIMITIVE_INCOMPATIBLE_MODE, a
    // warning): its whole triangles bake, and the leftover vertex is warned of.
    std::fs::write(
        dir.path().join("cut.gltf"),
        tiny_gltf(&TETRA, 4, |d| d["accessors"][0]["count"] = json!(10)),
    )
    .unwrap();
    let o = run(&["bake", "cut.gltf", "-o", "cut.texel"], dir.path());
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("attributes.POSITION: 10 vertices") && err.contains("the last 1 make none"),
        "{err}"
    );
}

/// Two crossed vertical quads, a billboard tree: seen edge-on from above and, each quad, from
/// one side. The transmittance fit keeps what the sides see: a column that sees nothing of a
/// quad seen edge-on does not empty the cells the other views fill (it emptied the texture
/// before: 0.000 against the mesh's 0.966 along x and z). A texture that does lose the view,
/// here by an extinction far too small for the cards, is warned of with what to do.
#[test]
fn a_billboards_silhouette_is_kept_and_a_lost_one_warned_about() {
    let quads: Vec<[f32; 3]> = [
        [[-2.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 6.0, 0.0]],
        [[-2.0, 0.0, 0.0], [2.0, 6.0, 0.0], [-2.0, 6.0, 0.0]],
        [[0.0, 0.0, -2.0], [0.0, 0.0, 2.0], [0.0, 6.0, 2.0]],
        [[0.0, 0.0, -2.0], [0.0, 6.0, 2.0], [0.0, 6.0, -2.0]],
    ]
    .concat();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("x.gltf"), tiny_gltf(&quads, 4, |_| {})).unwrap();
    let bake = |extra: &[&str]| {
        let a = ["bake", "x.gltf", "-o", "x.texel", "--resolution", "16"];
        let o = run(&[&a[..], extra].concat(), dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o)
    };
    let err = bake(&[]);
    assert!(!err.contains("warning"), "{err}");
    let texel =
        texel_forest::formats::texel::decode(&std::fs::read(dir.path().join("x.texel")).unwrap())
            .unwrap();
    for axis in [0, 2] {
        let (mesh, texture) = (texel.info.mesh_coverage[axis], texel.texture_coverage(axis));
        assert!(mesh > 0.95, "axis {axis}: the mesh blocks {mesh}");
        assert!(
            (texture - mesh).abs() < 0.02,
            "axis {axis}: the texture blocks {texture} where the mesh blocks {mesh}"
        );
    }
    let err = bake(&["--density", "occupancy", "--gamma", "0.01"]);
    for needle in ["warning: ", "x.gltf", "along x", "along z", "--gamma"] {
        assert!(err.contains(needle), "{needle:?} not in {err}");
    }
    let err = bake(&["--density", "occupancy"]);
    assert!(!err.contains("warning"), "{err}");
}

/// The triangles of a closed box from `lo` to `hi`, outward-facing.
fn closed_box(lo: [f32; 3], hi: [f32; 3]) -> Vec<[f32; 3]> {
    let c = |i: usize| std::array::from_fn(|a| if i >> a & 1 == 1 { hi[a] } else { lo[a] });
    let faces = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    faces
        .iter()
        .flat_map(|f| [f[0], f[1], f[2], f[0], f[2], f[3]].map(c))
        .collect()
}

/// A closed sphere of `radius` about `centre`, outward-facing, as a triangle soup.
fn closed_sphere(centre: [f32; 3], radius: f32) -> Vec<[f32; 3]> {
    let (rings, segments) = (12, 24);
    let at = |i: usize, j: usize| {
        // The poles exactly, so that their triangles share them.
        if i == 0 || i == rings {
            let y = if i == 0 { radius } else { -radius };
            return [centre[0], centre[1] + y, centre[2]];
        }
        let (theta, phi) = (
            std::f32::consts::PI * i as f32 / rings as f32,
            std::f32::consts::TAU * (j % segments) as f32 / segments as f32,
        );
        [
            centre[0] + radius * theta.sin() * phi.cos(),
            centre[1] + radius * theta.cos(),
            centre[2] + radius * theta.sin() * phi.sin(),
        ]
    };
    let mut out = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j), at(i + 1, j + 1));
            if i > 0 {
                out.extend([a, b, c]);
            }
            if i + 1 < rings {
                out.extend([b, d, c]);
            }
        }
    }
    out
}

/// A low-poly tree (a closed ball of a crown on a thin closed trunk) keeps its crown as a
/// solid, drawn as an opaque surface, on the levels fine enough for its shape, and its trunk
/// as density: the file is 1.3, its silhouette along every axis is the mesh's within 0.02,
/// and `inspect` says which levels draw solids.
#[test]
fn a_thick_closed_crown_is_baked_as_a_solid() {
    let mut tris = closed_sphere([0.0, 4.0, 0.0], 2.0);
    tris.extend(closed_box([-0.1, 0.0, -0.1], [0.1, 3.0, 0.1]));
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("x.gltf"), tiny_gltf(&tris, 4, |_| {})).unwrap();
    let o = run(
        &["bake", "x.gltf", "-o", "x.texel", "--resolution", "16"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("warning"), "{}", stderr(&o));
    let texel =
        texel_forest::formats::texel::decode(&std::fs::read(dir.path().join("x.texel")).unwrap())
            .unwrap();
    let l0 = &texel.levels[0];
    assert!(l0.has_solid(), "level 0 draws no solid");
    assert!(!texel.levels.last().unwrap().has_solid());
    // The trunk is density, below the crown.
    let trunk = l0.density[0].iter().sum::<f32>();
    assert!(trunk > 0.0, "no trunk in the density");
    for axis in 0..3 {
        let (mesh, texture) = (texel.info.mesh_coverage[axis], texel.texture_coverage(axis));
        assert!(
            (texture - mesh).abs() < 0.02,
            "axis {axis}: the texture blocks {texture} where the mesh blocks {mesh}"
        );
    }
    let o = run(&["inspect", "x.texel"], dir.path());
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("texel 1.4") && out.contains("solids"), "{out}");
    // A fine grid too large for the solids' vote (2^25 fine cells) keeps them as density.
    let o = run(
        &[
            "bake",
            "x.gltf",
            "-o",
            "y.texel",
            "--resolution",
            "16",
            "--fine",
            "1024",
        ],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&run(&["inspect", "y.texel"], dir.path()).stdout).to_string();
    assert!(
        out.contains("texel 1.4") && !out.contains("solids"),
        "{out}"
    );
}

/// The wood's normal distribution (texel 1.4) is its surfaces': a bar along x, thinner than
/// a cell, has its faces' normals along y and z, half each, and none along x but at its ends,
/// at every level (where the wood is, by wood density).
#[test]
fn a_thin_bar_bakes_the_normal_distribution_of_its_faces() {
    let tris = closed_box([-2.0, -0.05, -0.05], [2.0, 0.05, 0.05]);
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("bar.gltf"), tiny_gltf(&tris, 4, |_| {})).unwrap();
    let o = run(
        &["bake", "bar.gltf", "-o", "bar.texel", "--resolution", "16"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(dir.path().join("bar.texel")).unwrap();
    assert_eq!(&bytes[8..12], &[1, 0, 4, 0], "a texel 1.4 file");
    let texel = texel_forest::formats::texel::decode(&bytes).unwrap();
    for (n, level) in texel.levels.iter().enumerate() {
        assert_eq!(level.wood_normals.len(), level.cell_count(), "level {n}");
        let mut mean = [0.0f64; 6];
        let mass: f64 = level.density[0].iter().map(|&d| f64::from(d)).sum();
        for (m, &d) in level.wood_normals.iter().zip(&level.density[0]) {
            for k in 0..6 {
                mean[k] += f64::from(m[k]) * f64::from(d) / mass;
            }
        }
        let want = [0.0, 0.5, 0.5, 0.0, 0.0, 0.0];
        for k in 0..6 {
            assert!(
                (mean[k] - want[k]).abs() < 0.03,
                "level {n}: the wood's moment {mean:?}, the bar's {want:?}"
            );
        }
    }
}

#[test]
fn bad_gltf_inputs_give_one_clear_error_and_no_output() {
    assert_bake_fails(
        "points.gltf",
        &tiny_gltf(&TETRA, 0, |_| {}),
        &["no triangles"],
    );
    let quad = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 0.0, 1.0],
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
    ];
    assert_bake_fails("quad.gltf", &tiny_gltf(&quad, 4, |_| {}), &["flat", "Y"]);
    let mut nan = TETRA;
    nan[4][1] = f32::NAN;
    assert_bake_fails(
        "nan.gltf",
        &tiny_gltf(&nan, 4, |_| {}),
        &["POSITION", "not finite"],
    );
    let draco = tiny_gltf(&TETRA, 4, |d| {
        d["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
        d["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
    });
    assert_bake_fails(
        "draco.gltf",
        &draco,
        &["KHR_draco_mesh_compression", "not supported"],
    );
    let missing = tiny_gltf(&TETRA, 4, |d| {
        d["buffers"][0] = json!({ "byteLength": 144, "uri": "gone.bin" })
    });
    assert_bake_fails("missing.gltf", &missing, &["buffers[0]", "gone.bin"]);
    let short = tiny_gltf(&TETRA, 4, |d| d["accessors"][0]["count"] = json!(13));
    assert_bake_fails("short.gltf", &short, &["POSITION", "bufferView 0"]);
    let bad_index = tiny_gltf(&TETRA, 4, |d| {
        d["meshes"][0]["primitives"][0]["indices"] = json!(1);
        d["accessors"].as_array_mut().unwrap().push(json!({ "bufferView": 0, "byteOffset": 12, "componentType": 5125, "count": 3, "type": "SCALAR" }));
    });
    assert_bake_fails("index.gltf", &bad_index, &["indices", "out of range"]);
    let cycle = tiny_gltf(&TETRA, 4, |d| {
        d["nodes"] = json!([{ "mesh": 0, "children": [1] }, { "children": [0] }])
    });
    assert_bake_fails("cycle.gltf", &cycle, &["cyclic"]);
    // What glTF forbids and a reader could only guess at: an empty accessor, a negative alpha
    // cutoff. (A triangle list cut short is only warned of: `a_valid_tiny_model_bakes`.)
    let empty = tiny_gltf(&TETRA, 4, |d| d["accessors"][0]["count"] = json!(0));
    assert_bake_fails(
        "empty.gltf",
        &empty,
        &["accessors[0].count", "at least one"],
    );
    let cutoff = tiny_gltf(&TETRA, 4, |d| {
        d["materials"] = json!([{ "alphaMode": "MASK", "alphaCutoff": -1 }]);
        d["meshes"][0]["primitives"][0]["material"] = json!(0);
    });
    assert_bake_fails("cutoff.gltf", &cutoff, &["materials[0].alphaCutoff"]);
    let remote = tiny_gltf(&TETRA, 4, |d| {
        d["buffers"][0]["uri"] = json!("https://example.com/a.bin")
    });
    assert_bake_fails("remote.gltf", &remote, &["not a relative path"]);
    assert_bake_fails(
        "junk.glb",
        b"glTF\x02\x00\x00\x00\xff\xff\xff\xff",
        &["GLB", "truncated"],
    );
    assert_bake_fails("text.gltf", b"this is not json", &["not a glTF file"]);
}

#[test]
fn missing_input_and_bad_flags_are_reported() {
    let dir = tempfile::tempdir().unwrap();
    assert_error(
        &run(&["bake", "nope.glb", "-o", "x.texel"], dir.path()),
        &["nope.glb", "cannot read"],
    );
    let input = fixture("trees/conifer.glb");
    let i = input.to_str().unwrap();
    assert_error(
        &run(&["bake", i, "-o", "x.texel", "--fine", "100"], dir.path()),
        &["--fine 100", "multiple"],
    );
    assert_error(
        &run(&["bake", i, "-o", "x.texel", "--gamma", "3"], dir.path()),
        &["--gamma", "occupancy"],
    );
    assert_error(
        &run(
            &["bake", i, "-o", "x.texel", "--foliage", "(unclosed"],
            dir.path(),
        ),
        &["--foliage"],
    );
    // A malformed command line is a usage error: status 2.
    assert_eq!(run(&["bake", i], dir.path()).status.code(), Some(2));
    assert_eq!(
        run(
            &["bake", i, "-o", "x.texel", "--density", "fog"],
            dir.path()
        )
        .status
        .code(),
        Some(2)
    );
    assert!(
        std::fs::read_dir(dir.path()).unwrap().next().is_none(),
        "nothing written"
    );
}

#[test]
fn alpha_masked_leaf_cards_bake_as_leaves_not_as_quads() {
    // The same cards twice: alpha-masked by the leaf texture, and opaque.
    let build = |masked: bool| {
        let mut b = ModelBuilder::default();
        let mask = masked.then(|| (texel_forest::procedural::trees::leaf_texture(), 0.5));
        let m = b.material(MaterialSpec {
            name: "card".into(),
            color: [0.2, 0.5, 0.1, 1.0],
            mask,
        });
        for i in 0..8 {
            for j in 0..8 {
                b.card(
                    m,
                    Vec3::new(i as f32 * 0.5, 1.0 + j as f32 * 0.5, 0.0),
                    Vec3::X * 0.4,
                    Vec3::Y * 0.4,
                );
            }
        }
        // A post, so the model is not flat.
        let w = b.material(MaterialSpec {
            name: "bark".into(),
            color: [0.1; 4],
            mask: None,
        });
        b.tube(
            w,
            &[
                (Vec3::new(1.75, 0.0, 0.0), 0.05),
                (Vec3::new(1.75, 0.0, 1.0), 0.05),
            ],
            6,
        );
        let f = b.to_gltf(None, "test");
        builder::glb(&f.doc, &f.bin)
    };
    let dir = tempfile::tempdir().unwrap();
    let mut coverage = vec![];
    for (name, masked) in [("masked.glb", true), ("opaque.glb", false)] {
        std::fs::write(dir.path().join(name), build(masked)).unwrap();
        let o = run(&["bake", name, "-o", "t.texel"], dir.path());
        assert!(o.status.success(), "{}", stderr(&o));
        let t = texel_forest::formats::texel::decode(
            &std::fs::read(dir.path().join("t.texel")).unwrap(),
        )
        .unwrap();
        coverage.push(t.info.mesh_coverage[2]);
        if masked {
            assert!(
                t.info.foliage_triangles == 128,
                "alpha-masked cards are foliage"
            );
        }
    }
    // The leaf shape covers a bit over half of its card.
    let ratio = coverage[0] / coverage[1];
    assert!(
        (0.4..0.75).contains(&ratio),
        "masked / opaque coverage {ratio}"
    );
}

/// Leaf cards masked by the leaf texture, and a post whose material is `MASK` too but whose
/// texture is opaque (as real asset packs mark bark): written with external images, so a
/// test can swap one. Returns the glTF's file name in `dir`.
fn masked_bark_model(dir: &std::path::Path) -> &'static str {
    let mut b = ModelBuilder::default();
    let leaf = b.material(MaterialSpec {
        name: "Card_A".into(),
        color: [0.2, 0.5, 0.1, 1.0],
        mask: Some((texel_forest::procedural::trees::leaf_texture(), 0.2)),
    });
    for i in 0..4 {
        b.card(
            leaf,
            Vec3::new(i as f32 * 0.5, 1.5, 0.0),
            Vec3::X * 0.4,
            Vec3::Y * 0.4,
        );
    }
    let opaque = image::RgbaImage::from_pixel(8, 8, image::Rgba([90, 60, 40, 255]));
    let bark = b.material(MaterialSpec {
        name: "Bark_A".into(),
        color: [1.0; 4],
        mask: Some((opaque, 0.2)),
    });
    b.tube(
        bark,
        &[
            (Vec3::new(0.75, 0.0, 0.0), 0.1),
            (Vec3::new(0.75, 1.5, 0.0), 0.08),
        ],
        8,
    );
    let f = b.to_gltf(Some("tree"), "test");
    std::fs::write(dir.join("tree.bin"), &f.bin).unwrap();
    for (name, png) in &f.images {
        std::fs::write(dir.join(name), png).unwrap();
    }
    let mut doc = f.doc.clone();
    doc["buffers"][0]["uri"] = json!("tree.bin");
    std::fs::write(dir.join("tree.gltf"), serde_json::to_vec(&doc).unwrap()).unwrap();
    "tree.gltf"
}

fn bake_and_read(dir: &std::path::Path, extra: &[&str]) -> texel_forest::volume::Texel {
    let mut args = vec!["bake", "tree.gltf", "-o", "t.texel", "--resolution", "8"];
    args.extend_from_slice(extra);
    let o = run(&args, dir);
    assert!(o.status.success(), "{}", stderr(&o));
    texel_forest::formats::texel::decode(&std::fs::read(dir.join("t.texel")).unwrap()).unwrap()
}

#[test]
fn mask_marked_bark_stays_wood_and_flags_override_both_ways() {
    use texel_forest::volume::PartReason;
    let dir = tempfile::tempdir().unwrap();
    masked_bark_model(dir.path());
    let part = |t: &texel_forest::volume::Texel, name: &str| {
        let m = t.info.materials.iter().find(|m| m.name == name).unwrap();
        (m.foliage, m.reason)
    };
    let wood_mass = |t: &texel_forest::volume::Texel| -> f64 {
        t.levels[0].density[0].iter().map(|&d| d as f64).sum()
    };

    let t = bake_and_read(dir.path(), &[]);
    assert_eq!(part(&t, "Bark_A"), (false, PartReason::Solid));
    assert_eq!(part(&t, "Card_A"), (true, PartReason::AlphaCuts));
    assert!(
        t.info
            .materials
            .iter()
            .any(|m| m.name == "Card_A" && m.cut > 0.2)
    );
    assert!(wood_mass(&t) > 0.0, "the trunk keeps its wood density");

    // --wood wins over the mask; --foliage over the mask's silence.
    let t = bake_and_read(dir.path(), &["--wood", "card"]);
    assert_eq!(part(&t, "Card_A"), (false, PartReason::WoodPattern));
    assert_eq!(t.info.foliage_triangles, 0);
    assert_eq!(t.info.parameters.wood_pattern.as_deref(), Some("card"));
    let t = bake_and_read(dir.path(), &["--foliage", "bark|card"]);
    assert_eq!(part(&t, "Bark_A"), (true, PartReason::FoliagePattern));
    assert_eq!(t.info.foliage_triangles, t.info.triangles);

    // inspect says which materials went where, as text and JSON.
    bake_and_read(dir.path(), &[]);
    let text = String::from_utf8(run(&["inspect", "t.texel"], dir.path()).stdout).unwrap();
    let line = |name: &str| text.lines().find(|l| l.contains(name)).unwrap().to_string();
    assert!(
        line("Bark_A").contains("wood") && line("Bark_A").contains("solid"),
        "{text}"
    );
    assert!(
        line("Card_A").contains("foliage") && line("Card_A").contains("alpha cuts"),
        "{text}"
    );
    let o = run(&["inspect", "t.texel", "--json"], dir.path());
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["materials"][0]["reason"], "alpha_cuts");
    assert_eq!(v["format"], "texel 1.7");
    // Albedo statistics are over the cells with density of their part, and say so; the raw
    // size is the file's own R, not a figure recomputed from a channel list.
    let albedo = v["channels"]
        .as_array()
        .unwrap()
        .iter()
        .find(|c| c["name"] == "albedo_foliage.g")
        .unwrap();
    assert_eq!(albedo["over"], "foliage");
    let bytes = std::fs::read(dir.path().join("t.texel")).unwrap();
    let raw = u64::from_le_bytes(bytes[16..24].try_into().unwrap());
    assert_eq!(v["raw_bytes"], raw);
    assert!(
        text.contains("over cells") && text.contains("with foliage"),
        "{text}"
    );
}

#[test]
fn a_mask_over_a_texture_without_alpha_is_worth_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    masked_bark_model(dir.path());
    // The bark's texture, re-encoded as RGB: no alpha channel at all.
    let rgb = image::RgbImage::from_pixel(8, 8, image::Rgb([90, 60, 40]));
    rgb.save(dir.path().join("tree_1.png")).unwrap();
    let o = run(
        &["bake", "tree.gltf", "-o", "t.texel", "--resolution", "8"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("texel: warning:") && err.contains("Bark_A") && err.contains("no alpha"),
        "{err}"
    );
}

#[test]
fn valid_but_empty_files_and_compressed_ones_get_the_right_advice() {
    assert_bake_fails(
        "empty.gltf",
        br#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{}]}"#,
        &["nothing to bake"],
    );
    assert_bake_fails(
        "noscenes.gltf",
        br#"{"asset":{"version":"2.0"},"scene":0,"nodes":[]}"#,
        &["scene", "scene 0 does not exist", "no scenes"],
    );
    let meshopt = tiny_gltf(&TETRA, 4, |d| {
        d["extensionsUsed"] = json!(["EXT_meshopt_compression"]);
        d["extensionsRequired"] = json!(["EXT_meshopt_compression"]);
    });
    assert_bake_fails(
        "meshopt.gltf",
        &meshopt,
        &["EXT_meshopt_compression", "gltfpack without -c"],
    );
    let tiny = TETRA.map(|p| p.map(|c| c * 1e-30));
    assert_bake_fails(
        "speck.gltf",
        &tiny_gltf(&tiny, 4, |_| {}),
        &["smaller than", "metres"],
    );
    // A model its node puts a trillion metres out: its vertices, as 32-bit floats, round to
    // a grid 119 km wide, and it was called flat.
    let far = tiny_gltf(&TETRA, 4, |d| {
        d["nodes"][0]["translation"] = json!([1e12, 0.0, 0.0]);
    });
    assert_bake_fails(
        "far.gltf",
        &far,
        &[
            "reaches 1.0e12 m from its scene's origin",
            "nearer the origin",
        ],
    );
}

/// A red trunk running up into a closed green crown, as low-poly trees are built: the part
/// inside the crown is seen from nowhere, so no cell's albedo takes its red. (Each cell's
/// colour was the mean of every surface the scan's rays crossed in it, hidden ones too: the
/// crown's cells around the trunk came out brown where the mesh shows green.)
#[test]
fn a_surface_hidden_inside_a_solid_does_not_colour_the_texture() {
    let mut b = ModelBuilder::default();
    // Not "crown": that name reads as foliage by default, and this crown is a solid.
    let crown = b.material(MaterialSpec {
        name: "blob".into(),
        color: [0.05, 0.4, 0.05, 1.0],
        mask: None,
    });
    b.cuboid(crown, Vec3::new(-1.0, 1.0, -1.0), Vec3::new(1.0, 3.0, 1.0));
    let trunk = b.material(MaterialSpec {
        name: "trunk".into(),
        color: [0.6, 0.05, 0.05, 1.0],
        mask: None,
    });
    b.cuboid(trunk, Vec3::new(-0.3, 0.0, -0.3), Vec3::new(0.3, 2.6, 0.3));
    let f = b.to_gltf(None, "test");
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tree.glb"), builder::glb(&f.doc, &f.bin)).unwrap();
    let o = run(
        &["bake", "tree.glb", "-o", "t.texel", "--resolution", "16"],
        dir.path(),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let t =
        texel_forest::formats::texel::decode(&std::fs::read(dir.path().join("t.texel")).unwrap())
            .unwrap();
    let l = &t.levels[0];
    let origin = t.origin();
    let mut crown_cells = 0;
    for z in 0..l.dims[2] {
        for y in 0..l.dims[1] {
            for x in 0..l.dims[0] {
                let centre =
                    origin + (glam::DVec3::new(x as f64, y as f64, z as f64) + 0.5) * l.cell;
                // The crown's upper part: the trunk there is inside it, and the crown's floor,
                // where the trunk shows, is five cells or more below.
                // The crown is thick enough to be a solid (on level 0): its cells are those
                // of the solid or, where a level has none, of the density.
                let i = l.index(x, y, z);
                let wood = if l.has_solid() {
                    l.solid[0][i]
                } else {
                    l.density[0][i]
                };
                if centre.y < 2.0 || wood <= 0.0 {
                    continue;
                }
                crown_cells += 1;
                let [r, g, _] = l.albedo[0][l.index(x, y, z)];
                assert!(
                    r < 0.06 && g > 0.39,
                    "cell ({x}, {y}, {z}) at {centre}: albedo {r}, {g}, the crown's is 0.05, 0.4"
                );
            }
        }
    }
    assert!(crown_cells > 20, "{crown_cells} crown cells");
    // Below the crown the trunk is seen, and keeps its red.
    let y = ((0.5 - origin.y) / l.cell) as usize;
    let (x, z) = (
        ((0.0 - origin.x) / l.cell) as usize,
        ((0.0 - origin.z) / l.cell) as usize,
    );
    let [r, _, _] = l.albedo[0][l.index(x, y, z)];
    assert!(
        r > 0.4,
        "the seen trunk's albedo red is {r}, its material's 0.6"
    );
}
