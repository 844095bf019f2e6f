//! `texel export` end to end: a glTF whose instances put each tree's model where the mesh
//! renderer draws it, that the Khronos glTF-Validator accepts; tables of the trees; refusal of
//! stale sources before anything is written.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use glam::{DVec3, Mat4, Quat, Vec3};
use serde_json::Value;

use common::*;
use texel_forest::formats::{container, instances, texel};
use texel_forest::render::Placed;

/// The JSON and binary chunks of a GLB.
fn read_glb(path: &Path) -> (Value, Vec<u8>) {
    let bytes = std::fs::read(path).unwrap();
    assert_eq!(&bytes[..4], b"glTF");
    let u32_at = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    assert_eq!(u32_at(8), bytes.len());
    let json_len = u32_at(12);
    let json = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let bin_at = 20 + json_len;
    let bin = if bin_at < bytes.len() {
        bytes[bin_at + 8..bin_at + 8 + u32_at(bin_at)].to_vec()
    } else {
        Vec::new()
    };
    (json, bin)
}

/// The JSON of a `.gltf` text and its one buffer, decoded from its base64 data URI.
fn read_gltf_text(path: &Path) -> (Value, Vec<u8>) {
    use base64::Engine as _;
    let json: Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    let uri = json["buffers"][0]["uri"].as_str().unwrap();
    let data = uri
        .strip_prefix("data:application/octet-stream;base64,")
        .unwrap();
    let bin = base64::engine::general_purpose::STANDARD
        .decode(data)
        .unwrap();
    assert_eq!(json["buffers"][0]["byteLength"], bin.len());
    (json, bin)
}

/// The elements of a float accessor, `width` floats each.
fn floats(json: &Value, bin: &[u8], accessor: u64, width: usize) -> Vec<Vec<f32>> {
    let a = &json["accessors"][accessor as usize];
    assert_eq!(a["componentType"], 5126);
    let v = &json["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
    let start = v["byteOffset"].as_u64().unwrap_or(0) + a["byteOffset"].as_u64().unwrap_or(0);
    let stride = v["byteStride"].as_u64().unwrap_or(4 * width as u64);
    (0..a["count"].as_u64().unwrap())
        .map(|i| {
            (0..width)
                .map(|c| {
                    let at = (start + i * stride + 4 * c as u64) as usize;
                    f32::from_le_bytes(bin[at..at + 4].try_into().unwrap())
                })
                .collect()
        })
        .collect()
}

fn forest(dir: &Path) -> instances::Forest {
    let bytes = container::read_file(&dir.join("forest.instances")).unwrap();
    instances::decode(&bytes).unwrap()
}

/// The glTF model a forest's species was baked from, as the importer reads it.
fn source_model(dir: &Path, forest: &instances::Forest, species: usize) -> PathBuf {
    let file = dir.join(&forest.info.species[species].texel);
    let t = texel::decode(&container::read_file(&file).unwrap()).unwrap();
    file.parent().unwrap().join(&t.info.sources[0].path)
}

/// Bounds of `points`.
fn bounds(points: impl Iterator<Item = Vec3>) -> (Vec3, Vec3) {
    points.fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(p), hi.max(p)),
    )
}

/// Checks that every species' instanced nodes put its trees where the mesh renderer puts
/// them: for each of a few trees, the bounds of the exported vertices, placed by the instance
/// transforms, equal the bounds of the imported model's triangles placed by the renderer's
/// transform. Returns the number of trees checked.
fn check_instances(dir: &Path, glb: &Path) -> usize {
    let (json, bin) = read_glb(glb);
    let forest = forest(dir);
    let required: Vec<&str> = json["extensionsRequired"]
        .as_array()
        .unwrap()
        .iter()
        .map(|e| e.as_str().unwrap())
        .collect();
    assert!(
        required.contains(&"EXT_mesh_gpu_instancing"),
        "{required:?}"
    );
    let nodes = json["nodes"].as_array().unwrap();
    let root = &json["scenes"][0]["nodes"];
    let trees = root
        .as_array()
        .unwrap()
        .iter()
        .map(|n| &nodes[n.as_u64().unwrap() as usize])
        .find(|n| n["name"] == "trees")
        .expect("a trees node");
    let mut checked = 0;
    for species_node in trees["children"].as_array().unwrap() {
        let species_node = &nodes[species_node.as_u64().unwrap() as usize];
        let s = forest
            .info
            .species
            .iter()
            .position(|r| species_node["name"] == r.name.as_str())
            .expect("a species of the forest");
        let members: Vec<usize> = (0..forest.instances.len())
            .filter(|&i| forest.instances[i].species as usize == s)
            .collect();
        let model = texel_forest::import::load(&source_model(dir, &forest, s)).unwrap();
        for (j, &i) in members
            .iter()
            .enumerate()
            .step_by(members.len().div_ceil(4))
        {
            let tree = Placed::of(&forest.instances[i]).transform(0, DVec3::ZERO);
            let rendered = bounds(
                model
                    .mesh
                    .corners()
                    .into_iter()
                    .flatten()
                    .map(|p| tree.point_to_world(p, Vec3::ZERO).0),
            );
            let mut exported = Vec::new();
            for child in species_node["children"].as_array().unwrap() {
                let node = &nodes[child.as_u64().unwrap() as usize];
                assert!(node.get("translation").is_none() && node.get("matrix").is_none());
                let attributes = &node["extensions"]["EXT_mesh_gpu_instancing"]["attributes"];
                // What the validator cannot check (it does not know the extension): the
                // attributes' types, one element per tree, unit quaternions.
                for (name, kind) in [
                    ("TRANSLATION", "VEC3"),
                    ("ROTATION", "VEC4"),
                    ("SCALE", "VEC3"),
                ] {
                    let a = &json["accessors"][attributes[name].as_u64().unwrap() as usize];
                    assert_eq!(
                        (a["type"].as_str(), a["componentType"].as_u64()),
                        (Some(kind), Some(5126))
                    );
                }
                let row = |name: &str, width: usize| {
                    let all = floats(&json, &bin, attributes[name].as_u64().unwrap(), width);
                    assert_eq!(all.len(), members.len(), "one {name} per tree");
                    all[j].clone()
                };
                let (t, r, sc) = (row("TRANSLATION", 3), row("ROTATION", 4), row("SCALE", 3));
                assert!((Quat::from_slice(&r).length() - 1.0).abs() < 1e-6);
                let m = Mat4::from_scale_rotation_translation(
                    Vec3::from_slice(&sc),
                    Quat::from_slice(&r),
                    Vec3::from_slice(&t),
                );
                let mesh = &json["meshes"][node["mesh"].as_u64().unwrap() as usize];
                for p in mesh["primitives"].as_array().unwrap() {
                    let positions = floats(
                        &json,
                        &bin,
                        p["attributes"]["POSITION"].as_u64().unwrap(),
                        3,
                    );
                    exported.extend(
                        positions
                            .iter()
                            .map(|v| m.transform_point3(Vec3::from_slice(v))),
                    );
                }
            }
            let exported = bounds(exported.into_iter());
            let size = rendered.1.abs().max_element();
            for (a, b) in [(exported.0, rendered.0), (exported.1, rendered.1)] {
                assert!(
                    (a - b).abs().max_element() <= 2e-6 * size,
                    "species {s} tree {i}: exported bounds {exported:?}, rendered {rendered:?}"
                );
            }
            checked += 1;
        }
    }
    checked
}

#[test]
fn exports_instances_where_the_mesh_renderer_draws_the_trees_and_tables_of_them() {
    let dir = small_forest();
    let d = dir.path();
    let args = [
        "export",
        "forest.instances",
        "-o",
        "out/forest.glb",
        "--with-terrain",
        "--csv",
        "trees.csv",
        "--json",
        "trees.json",
        "--depfile",
        "export.d",
    ];
    let o = run(&args, d);
    assert!(o.status.success(), "{}", stderr(&o));
    let checked = check_instances(d, &d.join("out/forest.glb"));
    assert!(checked >= 6, "{checked} trees checked");

    // Named .gltf, the same document as JSON text, its buffer inline as a data URI: the GLB's
    // JSON with that URI added, and its binary chunk.
    let o = run(
        &[
            "export",
            "forest.instances",
            "-o",
            "out/forest.gltf",
            "--with-terrain",
        ],
        d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let (mut text, inline) = read_gltf_text(&d.join("out/forest.gltf"));
    let (json, bin) = read_glb(&d.join("out/forest.glb"));
    assert_eq!(inline, bin);
    text["buffers"][0].as_object_mut().unwrap().remove("uri");
    assert_eq!(text, json);

    // The terrain rides along as a plain mesh; the images are embedded.
    let (json, _) = read_glb(&d.join("out/forest.glb"));
    assert!(json["scenes"][0]["nodes"].as_array().unwrap().len() == 2);
    for image in json["images"].as_array().into_iter().flatten() {
        assert!(image.get("uri").is_none() && image.get("bufferView").is_some());
        assert_eq!(image["mimeType"], "image/png");
    }

    // Tables: a row per tree, in the forest's order.
    let forest = forest(d);
    let csv = std::fs::read_to_string(d.join("trees.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(
        lines[0],
        "x,y,z,rotation_deg,scale,height_m,species,variation"
    );
    assert_eq!(lines.len(), forest.instances.len() + 1);
    for (line, t) in lines[1..].iter().zip(&forest.instances) {
        let f: Vec<&str> = line.split(',').collect();
        let s = &forest.info.species[t.species as usize];
        let x: f64 = f[0].parse().unwrap();
        let rot: f64 = f[3].parse().unwrap();
        let height: f64 = f[5].parse().unwrap();
        assert!((x - t.position[0]).abs() < 0.006, "{line}");
        assert!(
            (rot - f64::from(t.rotation).to_degrees()).abs() < 6e-4,
            "{line}"
        );
        assert!(
            (height - f64::from(t.scale) * s.model_height).abs() < 6e-4,
            "{line}"
        );
        assert_eq!(f[6], s.name);
        assert_eq!(f[7], t.variation.to_string());
    }
    let table: Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("trees.json")).unwrap()).unwrap();
    let trees = table["trees"].as_array().unwrap();
    assert_eq!(trees.len(), forest.instances.len());
    assert_eq!(
        trees[0]["species"],
        forest.info.species[forest.instances[0].species as usize]
            .name
            .as_str()
    );

    // The depfile names the forest, the texels and their models.
    let dep = std::fs::read_to_string(d.join("export.d")).unwrap();
    for needle in [
        "forest.instances",
        "conifer.texel",
        "conifer.glb",
        "mountain.glb",
    ] {
        assert!(dep.contains(needle), "{needle} not in {dep}");
    }

    // An input is never an output, found however late.
    let texel = std::fs::read(d.join("trees/conifer.texel")).unwrap();
    let o = run(
        &["export", "forest.instances", "-o", "trees/conifer.texel"],
        d,
    );
    assert_error(&o, &["-o", "conifer.texel", "is also an input"]);
    assert_eq!(std::fs::read(d.join("trees/conifer.texel")).unwrap(), texel);

    // The same forest gives the same bytes.
    let first: Vec<Vec<u8>> = ["out/forest.glb", "trees.csv", "trees.json"]
        .iter()
        .map(|f| std::fs::read(d.join(f)).unwrap())
        .collect();
    let o = run(&args, d);
    assert!(o.status.success(), "{}", stderr(&o));
    for (f, bytes) in ["out/forest.glb", "trees.csv", "trees.json"]
        .iter()
        .zip(first)
    {
        assert_eq!(std::fs::read(d.join(f)).unwrap(), bytes, "{f} changed");
    }
}

#[test]
fn a_model_changed_since_the_bake_is_refused_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    species_with_texels(d);
    // The conifer baked from a copy this test can change.
    std::fs::copy(fixture("trees/conifer.glb"), d.join("trees/conifer.glb")).unwrap();
    let o = bake_coarse(d, "trees/conifer.glb", "trees/conifer.texel");
    assert!(o.status.success(), "{}", stderr(&o));
    let o = place_on_mountain(d, &["--region=-120,-120,120,120"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut bytes = std::fs::read(d.join("trees/conifer.glb")).unwrap();
    bytes.push(b' ');
    std::fs::write(d.join("trees/conifer.glb"), bytes).unwrap();
    let o = run(
        &[
            "export",
            "forest.instances",
            "-o",
            "forest.glb",
            "--csv",
            "trees.csv",
        ],
        d,
    );
    assert_error(
        &o,
        &[
            "conifer.texel",
            "conifer.glb",
            "changed since it was baked",
            "re-run texel bake",
        ],
    );
    assert!(!d.join("forest.glb").exists() && !d.join("trees.csv").exists());
}

/// Species that share a texture share its model's one copy, however their records spell the
/// texture's path (a file named many ways was copied, and decoded, once per spelling); a
/// depfile still names every spelling. `place` writes the shortest path, so the forest is
/// edited to spell them otherwise.
#[test]
fn species_naming_one_texture_two_ways_share_one_model() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    species_with_texels(d);
    let o = place_on_mountain(d, &["--region=-120,-120,120,120"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let export = |d: &Path| {
        let o = run(
            &[
                "export",
                "forest.instances",
                "-o",
                "forest.glb",
                "--depfile",
                "e.d",
            ],
            d,
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let (json, _) = read_glb(&d.join("forest.glb"));
        json["meshes"].as_array().unwrap().len()
    };
    let plain = export(d);
    let mut f = forest(d);
    let mut seen = std::collections::HashSet::new();
    let mut respelt = 0;
    for s in &mut f.info.species {
        if !seen.insert(s.texel.clone()) {
            s.texel = format!("./trees/../{}", s.texel);
            respelt += 1;
        }
    }
    assert!(respelt > 0, "the fixture's species share no texture");
    std::fs::write(d.join("forest.instances"), instances::encode(&f).unwrap()).unwrap();
    assert_eq!(export(d), plain);
    let dep = std::fs::read_to_string(d.join("e.d")).unwrap();
    assert!(dep.contains("./trees/../trees/"), "{dep}");
    let o = render(d, &["-o", "f.exr", "--depfile", "f.d"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let dep = std::fs::read_to_string(d.join("f.d")).unwrap();
    assert!(dep.contains("./trees/../trees/"), "{dep}");
}

/// A forest whose origin lies where 32-bit floats cannot tell its trees apart is refused for
/// what it is, by the forest's name; it was blamed on the first model's node transform.
#[test]
fn a_forest_too_far_from_the_origin_for_gltf_floats_is_refused_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    species_with_texels(d);
    let o = place_on_mountain(d, &["--region=-60,-60,60,60"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut f = forest(d);
    f.info.origin = [1e300, 0.0, -1e300];
    for t in &mut f.instances {
        t.position = f.info.origin;
    }
    std::fs::write(d.join("far.instances"), instances::encode(&f).unwrap()).unwrap();
    let o = run(&["export", "far.instances", "-o", "far.glb"], d);
    assert_error(
        &o,
        &[
            "far.instances",
            "origin (1e300, 0, -1e300)",
            "32-bit floats",
        ],
    );
    assert!(!d.join("far.glb").exists());
    // The tables print positions as text, which holds them.
    let o = run(&["export", "far.instances", "--csv", "far.csv"], d);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn usage_errors_name_the_flags() {
    let dir = tempfile::tempdir().unwrap();
    let o = run(&["export", "forest.instances"], dir.path());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = run(
        &[
            "export",
            "forest.instances",
            "--csv",
            "t.csv",
            "--with-terrain",
        ],
        dir.path(),
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = run(
        &["export", "missing.instances", "--csv", "t.csv"],
        dir.path(),
    );
    assert_error(&o, &["missing.instances"]);
}

/// The Khronos glTF-Validator (npm `gltf-validator`), installed on first use under the
/// tests' temporary directory, as a `node` script; `None` (with a note) where node, npm or
/// the registry is unavailable. Installed once per test process: tests run in parallel, and
/// one that found the package's directory while another's install was still filling it
/// failed with "Cannot find module".
fn validator() -> Option<PathBuf> {
    static VALIDATOR: std::sync::OnceLock<Option<PathBuf>> = std::sync::OnceLock::new();
    VALIDATOR.get_or_init(install_validator).clone()
}

fn install_validator() -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("gltf-validator");
    let script = root.join("validate.js");
    if !root.join("node_modules/gltf-validator").exists() {
        std::fs::create_dir_all(&root).ok()?;
        let installed = Command::new("npm")
            // Offline, fail in seconds rather than retry for minutes.
            .args(["install", "--no-audit", "--no-fund", "--fetch-retries=1"])
            .args(["--fetch-timeout=20000", "--prefix"])
            .arg(&root)
            .arg("gltf-validator")
            .output();
        match installed {
            Ok(o) if o.status.success() => {}
            Ok(o) => {
                eprintln!("skipped: npm install gltf-validator failed: {}", stderr(&o));
                return None;
            }
            Err(e) => {
                eprintln!("skipped: npm is unavailable ({e})");
                return None;
            }
        }
    }
    std::fs::write(
        &script,
        "const v = require('gltf-validator');\n\
         const fs = require('fs');\n\
         const path = require('path');\n\
         const file = process.argv[2];\n\
         const bytes = new Uint8Array(fs.readFileSync(file));\n\
         const external = uri => new Promise((ok, no) => fs.readFile(\n\
           path.join(path.dirname(file), decodeURIComponent(uri)),\n\
           (e, d) => e ? no(e.toString()) : ok(new Uint8Array(d))));\n\
         v.validateBytes(bytes, { maxIssues: 10000, externalResourceFunction: external })\n\
           .then(r => console.log(JSON.stringify(r.issues)))\n\
           .catch(e => { console.error(e); process.exit(2); });\n",
    )
    .ok()?;
    Some(script)
}

/// What the validator says about a glTF file.
struct Report {
    errors: u64,
    /// The codes of the errors, each once.
    error_codes: std::collections::BTreeSet<String>,
    /// Every message, for people.
    text: String,
}

/// The validator's report on `file`, or `None` (with a note) where node is unavailable.
fn validate(script: &Path, file: &Path) -> Option<Report> {
    let o = Command::new("node")
        .arg(script)
        .arg(file)
        .current_dir(script.parent()?)
        .output();
    let o = match o {
        Ok(o) => o,
        Err(e) => {
            eprintln!("skipped: node is unavailable ({e})");
            return None;
        }
    };
    assert!(o.status.success(), "the validator failed: {}", stderr(&o));
    let issues: Value = serde_json::from_slice(&o.stdout).unwrap();
    let messages = issues["messages"].as_array().unwrap();
    let error_codes = messages
        .iter()
        .filter(|m| m["severity"] == 0)
        .map(|m| m["code"].as_str().unwrap().to_string())
        .collect();
    let shown: Vec<&Value> = messages.iter().take(20).collect();
    let text = serde_json::to_string_pretty(&shown).unwrap();
    eprintln!(
        "glTF-Validator on {}: {} errors, {} warnings, {} infos; first messages: {text}",
        file.display(),
        issues["numErrors"],
        issues["numWarnings"],
        issues["numInfos"]
    );
    Some(Report {
        errors: issues["numErrors"].as_u64().unwrap(),
        error_codes,
        text,
    })
}

#[test]
fn the_khronos_validator_finds_no_errors_in_an_export() {
    let Some(script) = validator() else { return };
    let dir = small_forest();
    let d = dir.path();
    let o = run(
        &[
            "export",
            "forest.instances",
            "-o",
            "forest.glb",
            "--with-terrain",
        ],
        d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let Some(report) = validate(&script, &d.join("forest.glb")) else {
        return;
    };
    assert_eq!(report.errors, 0, "{}", report.text);
}

/// A forest whose broadleaf species are drawn from `model`: baked, placed on the mountain
/// and exported to `forest.glb`. Checks that its instances sit where the renderer draws the
/// trees, and that the validator finds no error in the export that the model does not have
/// itself (a copy keeps a model's own faults).
fn export_with_broadleaf(model: &Path) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    species_with_texels(d);
    let o = bake_coarse(d, model.to_str().unwrap(), "trees/broadleaf.texel");
    assert!(o.status.success(), "{}", stderr(&o));
    let o = place_on_mountain(d, &["--region=-120,-120,120,120"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run(&["export", "forest.instances", "-o", "forest.glb"], d);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(check_instances(d, &d.join("forest.glb")) >= 4);
    if let Some(script) = validator()
        && let Some(exported) = validate(&script, &d.join("forest.glb"))
        && let Some(source) = validate(&script, model)
    {
        let added: Vec<&String> = exported
            .error_codes
            .difference(&source.error_codes)
            .collect();
        assert!(
            added.is_empty(),
            "{}: errors the model does not have: {added:?}\n{}",
            model.display(),
            exported.text
        );
        assert!(exported.errors <= source.errors, "{}", exported.text);
    }
    dir
}

/// The real model `name` from ../shared/realdata, or `None` (with a note) where it is absent.
fn real_tree(name: &str) -> Option<PathBuf> {
    let found = realdata_trees()?.into_iter().find(|p| p.ends_with(name));
    if found.is_none() {
        eprintln!("skipped: {name} is absent");
    }
    found
}

/// A real model with alpha-masked leaf cards, three external PNGs and an external buffer
/// (Quaternius' CommonTree_1): its materials and images arrive whole. The model itself has
/// validator errors (COLOR_0 a hair above 1: ACCESSOR_NON_CLAMPED), which the copy keeps.
#[test]
fn a_real_model_with_leaf_cards_exports_whole() {
    let Some(model) = real_tree("CommonTree_1.gltf") else {
        return;
    };
    let dir = export_with_broadleaf(&model);
    let (json, _) = read_glb(&dir.path().join("forest.glb"));
    let masked = json["materials"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|m| m["alphaMode"] == "MASK")
        .count();
    assert!(masked >= 1, "the leaf cards' alpha mask survives");
    assert!(
        json["images"].as_array().unwrap().len() >= 3,
        "every PNG is embedded"
    );
}

/// Real models as people publish them: Kenney's (a scene root that is another node's child,
/// an unused extension listed, the trunk 5 cm below the origin) and KayKit's (an external
/// buffer and texture atlas).
#[test]
fn real_models_from_other_exporters_export_where_they_are_drawn() {
    for name in ["tree_detailed_fall.glb", "Tree_1_A_Color1.gltf"] {
        let Some(model) = real_tree(name) else {
            return;
        };
        let dir = export_with_broadleaf(&model);
        let (json, _) = read_glb(&dir.path().join("forest.glb"));
        let used = json["extensionsUsed"].as_array().unwrap();
        assert!(
            !used.iter().any(|e| e == "KHR_materials_unlit"),
            "an extension the copied parts do not use is left out: {used:?}"
        );
    }
}
