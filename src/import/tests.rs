//! Import of the glTF features trees use, each on a small hand-written document.

use base64::Engine as _;
use glam::{Vec2, Vec3, Vec4};
use serde_json::{Value, json};

use super::{AlphaMode, load};

/// Appends `bytes` to `bin` (4-byte aligned) and returns a bufferView over them.
fn view(bin: &mut Vec<u8>, views: &mut Vec<Value>, bytes: &[u8]) -> usize {
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    views.push(json!({ "buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len() }));
    bin.extend_from_slice(bytes);
    views.len() - 1
}

fn f32s(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// Writes `doc` with `bin` as a data URI into a temporary `.gltf` and imports it.
fn import(mut doc: Value, bin: &[u8]) -> super::Model {
    doc["asset"] = json!({ "version": "2.0" });
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bin)
    );
    doc["buffers"] = json!([{ "byteLength": bin.len(), "uri": uri }]);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    load(&path).unwrap()
}

const SQUARE: [f32; 12] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0];

fn triangle_normal(m: &super::Mesh, t: usize) -> Vec3 {
    let [a, b, c] = m.triangles[t].vertices.map(|v| m.positions[v as usize]);
    (b - a).cross(c - a).normalize()
}

#[test]
fn strips_and_fans_become_the_specified_triangles() {
    let (mut bin, mut views) = (vec![], vec![]);
    let v = view(&mut bin, &mut views, &f32s(&SQUARE));
    let doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [
            { "attributes": { "POSITION": 0 }, "mode": 5 },
            { "attributes": { "POSITION": 0 }, "mode": 6 },
        ] }],
        "accessors": [{ "bufferView": v, "componentType": 5126, "count": 4, "type": "VEC3" }],
        "bufferViews": views,
    });
    let m = import(doc, &bin).mesh;
    // Strip 0 1 2 3 -> (0 1 2), (1 3 2); fan -> (1 2 0), (2 3 0). Strip triangles keep one
    // facing (+z) as the specification's alternation intends.
    let strip: Vec<[u32; 3]> = m.triangles[..2].iter().map(|t| t.vertices).collect();
    assert_eq!(strip, vec![[0, 1, 2], [1, 3, 2]]);
    assert!(triangle_normal(&m, 0).z > 0.99 && triangle_normal(&m, 1).z > 0.99);
    let fan: Vec<[u32; 3]> = m.triangles[2..]
        .iter()
        .map(|t| t.vertices.map(|v| v - 4))
        .collect();
    assert_eq!(fan, vec![[1, 2, 0], [2, 3, 0]]);
}

/// A tetrahedron with outward faces, as a non-indexed triangle list.
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

#[test]
fn node_transforms_compose_and_mirroring_keeps_faces_outward() {
    let (mut bin, mut views) = (vec![], vec![]);
    let v = view(&mut bin, &mut views, &f32s(TETRA.as_flattened()));
    let translate_matrix = [
        1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 10.0, 0.0, 0.0, 1.0,
    ];
    let doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [
            { "matrix": translate_matrix, "children": [1, 2] },
            { "mesh": 0, "translation": [0.0, 5.0, 0.0], "scale": [2.0, 2.0, 2.0] },
            { "mesh": 0, "scale": [1.0, 1.0, -1.0], "rotation": [0.0, std::f32::consts::FRAC_1_SQRT_2, 0.0, std::f32::consts::FRAC_1_SQRT_2] },
        ],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 } }] }],
        "accessors": [{ "bufferView": v, "componentType": 5126, "count": 12, "type": "VEC3" }],
        "bufferViews": views,
    });
    let m = import(doc, &bin).mesh;
    assert_eq!(m.triangles.len(), 8);
    // Parent matrix (x + 10) then child TRS (scale 2, y + 5): corner (0, 1, 0) -> (10, 7, 0).
    assert_eq!(m.positions[1], Vec3::new(10.0, 7.0, 0.0));
    for copy in 0..2 {
        let tris = copy * 4..copy * 4 + 4;
        let centre = tris
            .clone()
            .flat_map(|t| m.triangles[t].vertices)
            .map(|v| m.positions[v as usize])
            .sum::<Vec3>()
            / 12.0;
        for t in tris {
            let c = m.triangles[t]
                .vertices
                .map(|v| m.positions[v as usize])
                .iter()
                .sum::<Vec3>()
                / 3.0;
            assert!(
                triangle_normal(&m, t).dot(c - centre) > 0.0,
                "copy {copy} triangle {t} faces inwards"
            );
        }
    }
}

#[test]
fn normalized_sparse_accessors_and_vertex_colors_decode() {
    let (mut bin, mut views) = (vec![], vec![]);
    let p = view(&mut bin, &mut views, &f32s(&SQUARE[..9]));
    // COLOR_0 as normalized unsigned bytes, RGBA.
    let c = view(
        &mut bin,
        &mut views,
        &[255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 128],
    );
    // Sparse substitution: vertex 2 moves to (0, 3, 0).
    let si = view(&mut bin, &mut views, &2u16.to_le_bytes());
    let sv = view(&mut bin, &mut views, &f32s(&[0.0, 3.0, 0.0]));
    let doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0, "COLOR_0": 1 } }] }],
        "accessors": [
            { "bufferView": p, "componentType": 5126, "count": 3, "type": "VEC3",
              "sparse": { "count": 1, "indices": { "bufferView": si, "componentType": 5123 }, "values": { "bufferView": sv } } },
            { "bufferView": c, "componentType": 5121, "normalized": true, "count": 3, "type": "VEC4" },
        ],
        "bufferViews": views,
    });
    let m = import(doc, &bin).mesh;
    assert_eq!(m.positions[2], Vec3::new(0.0, 3.0, 0.0));
    assert_eq!(m.colors[0], Vec4::new(1.0, 0.0, 0.0, 1.0));
    assert!((m.colors[2].w - 128.0 / 255.0).abs() < 1e-6);
    // Base colour at a vertex is factor x COLOR_0 (default material: white).
    assert_eq!(
        m.base_color(&m.triangles[0], [0.0, 1.0, 0.0]),
        Vec4::new(0.0, 1.0, 0.0, 1.0)
    );
}

/// A vertex colour that is no number would bake to a NaN albedo (or, as alpha, cut every
/// leaf of a masked material): refused by field, element and value.
#[test]
fn vertex_colors_that_are_not_finite_are_refused() {
    for (bad, shown) in [(f32::NAN, "NaN"), (f32::INFINITY, "inf")] {
        let (mut bin, mut views) = (vec![], vec![]);
        let p = view(&mut bin, &mut views, &f32s(&SQUARE[..9]));
        let c = view(
            &mut bin,
            &mut views,
            &f32s(&[1.0, 0.5, 0.2, 1.0, 0.3, 0.4, 0.5, 1.0, 0.1, 0.2, 0.3, bad]),
        );
        let doc = json!({
            "scenes": [{ "nodes": [0] }],
            "nodes": [{ "mesh": 0 }],
            "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0, "COLOR_0": 1 } }] }],
            "accessors": [
                { "bufferView": p, "componentType": 5126, "count": 3, "type": "VEC3" },
                { "bufferView": c, "componentType": 5126, "count": 3, "type": "VEC4" },
            ],
            "bufferViews": views,
        });
        let dir = tempfile::tempdir().unwrap();
        let e = load(&write_gltf(doc, &bin, dir.path()))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("meshes[0].primitives[0].attributes.COLOR_0")
                && e.contains("element 2 is not finite")
                && e.contains(shown),
            "{e}"
        );
    }
}

/// Accessors without a bufferView are zeros that no byte of the file pays for: a few
/// hundred bytes could ask for gigabytes of them, shared by many primitives. Past 2^24 values
/// in a file they are refused, before any is allocated.
#[test]
fn accessors_of_zeros_are_bounded() {
    let doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [
            { "attributes": { "POSITION": 0 } },
            { "attributes": { "POSITION": 0 } },
        ] }],
        "accessors": [{ "componentType": 5126, "count": 4_000_000, "type": "VEC3" }],
    });
    let dir = tempfile::tempdir().unwrap();
    let e = load(&write_gltf(doc, &[0; 4], dir.path()))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("meshes[0].primitives[1].attributes.POSITION (accessors[0])")
            && e.contains("has no bufferView"),
        "{e}"
    );
}

/// A triangle's positions and texture coordinates and a 2 x 1 PNG (left texel sRGB 188,
/// linear ~0.5; right texel black with alpha 0), each in a view of one buffer: the buffer,
/// the views, and the views' indices.
fn textured_triangle() -> (Vec<u8>, Vec<Value>, [usize; 3]) {
    let img = image::RgbaImage::from_raw(2, 1, vec![188, 188, 188, 255, 0, 0, 0, 0]).unwrap();
    let png = crate::png::encode(&img);
    let (mut bin, mut views) = (vec![], vec![]);
    let p = view(&mut bin, &mut views, &f32s(&SQUARE[..9]));
    let uv = view(
        &mut bin,
        &mut views,
        &f32s(&[0.25, 0.5, 0.25, 0.5, 0.25, 0.5]),
    );
    let i = view(&mut bin, &mut views, &png);
    (bin, views, [p, uv, i])
}

/// The images of one file are bounded together by `--max-pixels`, not each alone: four
/// image entries of one 16k x 16k PNG took 5.2 GB.
#[test]
fn a_files_images_are_bounded_in_all_by_max_pixels() {
    let (bin, views, [p, uv, i]) = textured_triangle();
    let primitive =
        |m: usize| json!({ "attributes": { "POSITION": 0, "TEXCOORD_0": 1 }, "material": m });
    let material =
        |t: usize| json!({ "pbrMetallicRoughness": { "baseColorTexture": { "index": t } } });
    let doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [primitive(0), primitive(1)] }],
        "materials": [material(0), material(1)],
        "textures": [{ "source": 0 }, { "source": 1 }],
        "images": [{ "bufferView": i, "mimeType": "image/png" }, { "bufferView": i, "mimeType": "image/png" }],
        "accessors": [
            { "bufferView": p, "componentType": 5126, "count": 3, "type": "VEC3" },
            { "bufferView": uv, "componentType": 5126, "count": 3, "type": "VEC2" },
        ],
        "bufferViews": views,
    });
    let dir = tempfile::tempdir().unwrap();
    let path = write_gltf(doc, &bin, dir.path());
    let limits = |pixels| crate::limits::Limits {
        pixels,
        ..Default::default()
    };
    super::load_with(&path, &limits(4)).unwrap();
    let e = super::load_with(&path, &limits(3)).unwrap_err().to_string();
    assert!(
        e.contains("images[1]") && e.contains("past 3 pixels in all (--max-pixels)"),
        "{e}"
    );
    // Two textures of one image (their own samplers, say) decode it once, and count it once.
    let mut doc: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    doc["textures"][1]["source"] = json!(0);
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let m = super::load_with(&path, &limits(2)).unwrap();
    assert!(std::sync::Arc::ptr_eq(
        &m.mesh.textures[0].texels,
        &m.mesh.textures[1].texels
    ));
}

#[test]
fn base_color_textures_are_decoded_from_srgb_and_transformed() {
    let (bin, views, [p, uv, i]) = textured_triangle();
    let doc = json!({
        "extensionsUsed": ["KHR_texture_transform"],
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [
            { "attributes": { "POSITION": 0, "TEXCOORD_0": 1 }, "material": 0 },
            { "attributes": { "POSITION": 0, "TEXCOORD_0": 1 }, "material": 1 },
        ] }],
        "materials": [
            { "name": "Leaves", "alphaMode": "MASK", "alphaCutoff": 0.4,
              "pbrMetallicRoughness": { "baseColorFactor": [1.0, 0.5, 1.0, 1.0], "baseColorTexture": { "index": 0 } } },
            { "pbrMetallicRoughness": { "baseColorTexture": { "index": 0,
              "extensions": { "KHR_texture_transform": { "offset": [0.5, 0.0] } } } } },
        ],
        "textures": [{ "source": 0, "sampler": 0 }],
        "samplers": [{ "magFilter": 9728, "wrapS": 33071, "wrapT": 33071 }],
        "images": [{ "bufferView": i, "mimeType": "image/png" }],
        "accessors": [
            { "bufferView": p, "componentType": 5126, "count": 3, "type": "VEC3" },
            { "bufferView": uv, "componentType": 5126, "count": 3, "type": "VEC2" },
        ],
        "bufferViews": views,
    });
    let m = import(doc, &bin).mesh;
    assert_eq!(m.materials[0].alpha_mode, AlphaMode::Mask { cutoff: 0.4 });
    assert_eq!(m.materials[0].name, "Leaves");
    let left = m.base_color(&m.triangles[0], [1.0, 0.0, 0.0]);
    assert!(
        (left.x - 0.5029).abs() < 1e-3 && (left.y - 0.2515).abs() < 1e-3,
        "{left:?}"
    );
    assert_eq!(m.uvs[0], Vec2::new(0.25, 0.5));
    // The transform shifts u by half the texture: the transparent black texel.
    let right = m.base_color(&m.triangles[1], [1.0, 0.0, 0.0]);
    assert_eq!(right, Vec4::ZERO);
}

#[test]
fn points_and_lines_are_skipped_with_a_warning() {
    let (mut bin, mut views) = (vec![], vec![]);
    let v = view(&mut bin, &mut views, &f32s(&SQUARE));
    let doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [
            { "attributes": { "POSITION": 0 }, "mode": 1 },
            { "attributes": { "POSITION": 0 }, "mode": 4, "indices": 1 },
        ] }],
        "accessors": [
            { "bufferView": v, "componentType": 5126, "count": 4, "type": "VEC3" },
            { "bufferView": view(&mut bin, &mut views, &[0, 1, 2]), "componentType": 5121, "count": 3, "type": "SCALAR" },
        ],
        "bufferViews": views,
    });
    let model = import(doc, &bin);
    assert_eq!(model.mesh.triangles.len(), 1);
    assert_eq!(model.warnings.len(), 1);
    assert!(model.warnings[0].contains("Lines"), "{:?}", model.warnings);
}

#[test]
fn camera_nodes_and_directional_lights_are_placed_by_their_world_transforms() {
    let (doc, bin) = cameras_and_lights();
    let m = import(doc, &bin);
    assert_eq!(m.cameras.len(), 1);
    let c = &m.cameras[0];
    assert_eq!(c.name, "overlook");
    assert!(
        (c.eye - glam::DVec3::new(100.0, 60.0, 0.0)).length() < 1e-9,
        "{}",
        c.eye
    );
    assert!(
        (c.forward - glam::DVec3::NEG_X).length() < 1e-6,
        "{}",
        c.forward
    );
    assert!((c.up - glam::DVec3::Y).length() < 1e-6, "{}", c.up);
    assert!((c.yfov - 0.6).abs() < 1e-6);
    assert_eq!(m.suns.len(), 1);
    let s = &m.suns[0];
    assert_eq!(s.name, "sun");
    assert!(
        (s.towards - glam::DVec3::Y).length() < 1e-6,
        "{}",
        s.towards
    );
    assert_eq!(s.intensity, 3.0);
}

/// Nodes whose transform is none, and indices naming no camera or light, are refused by
/// field, where they were read as the identity or skipped; an orthographic camera is kept by
/// name only.
#[test]
fn impossible_nodes_are_refused_and_orthographic_cameras_named() {
    let (good, bin) = cameras_and_lights();
    type Break = fn(&mut Value);
    let cases: Vec<(Break, &str)> = vec![
        (
            |d| d["nodes"][1]["rotation"] = json!([0.0, 0.0, 0.0, 0.0]),
            "nodes[1].rotation",
        ),
        (
            // Column-major: element 11 is the bottom row's third entry, a projection.
            |d| d["nodes"][1]["matrix"] = json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0.5, 0, 0, 0, 1]),
            "nodes[1].matrix",
        ),
        (
            |d| d["nodes"][3]["extensions"]["KHR_lights_punctual"]["light"] = json!(5),
            "nodes[3].extensions.KHR_lights_punctual.light",
        ),
        (|d| d["nodes"][2]["camera"] = json!(4), "nodes[2].camera"),
        (
            // Shared children make a walk's paths exponential in depth: refused at once.
            |d| d["nodes"][1]["children"] = json!([2]),
            "nodes[1].children: node 2 is already a child of nodes[0]",
        ),
        (
            |d| d["nodes"][0]["children"] = json!([1, 1, 2, 3, 4]),
            "nodes[0].children: lists node 1 twice",
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (break_it, needle) in cases {
        let mut doc = good.clone();
        break_it(&mut doc);
        let path = write_gltf(doc, &bin, dir.path());
        let e = load(&path).unwrap_err().to_string();
        assert!(e.contains(needle), "{needle:?} not in {e:?}");
    }
    // A sun scaled to nothing (as exporters hide objects) has no direction to shine from: it
    // is no sun, with a warning, and the rest of the file is read.
    let mut doc = good.clone();
    doc["nodes"][3]["scale"] = json!([0.0, 0.0, 0.0]);
    let m = load(&write_gltf(doc, &bin, dir.path())).unwrap();
    assert!(m.suns.is_empty());
    assert!(
        m.warnings
            .iter()
            .any(|w| w.contains("nodes[3]") && w.contains("not a sun")),
        "{:?}",
        m.warnings
    );
    // A rotation exporters round off unit length is a rotation.
    let mut doc = good.clone();
    doc["nodes"][1]["rotation"] = json!([0.0, 0.0, 0.0, 0.999]);
    load(&write_gltf(doc, &bin, dir.path())).unwrap();
    let mut doc = good;
    doc["cameras"][0] = json!({ "type": "orthographic", "name": "plan",
        "orthographic": { "xmag": 1.0, "ymag": 1.0, "znear": 0.1, "zfar": 10.0 } });
    let m = load(&write_gltf(doc, &bin, dir.path())).unwrap();
    assert!(m.cameras.is_empty());
    assert_eq!(m.orthographic, ["plan"]);
}

/// A tetrahedron under a moved parent with a turned camera, a directional light shining down
/// and a point light.
fn cameras_and_lights() -> (Value, Vec<u8>) {
    let (mut bin, mut views) = (vec![], vec![]);
    let v = view(&mut bin, &mut views, &f32s(TETRA.as_flattened()));
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let doc = json!({
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": { "KHR_lights_punctual": { "lights": [
            { "type": "point", "name": "lamp" },
            { "type": "directional", "name": "sun", "intensity": 3.0, "color": [1.0, 0.9, 0.8] },
        ] } },
        "scenes": [{ "nodes": [0] }],
        "nodes": [
            { "translation": [100.0, 50.0, 0.0], "children": [1, 2, 3, 4] },
            { "mesh": 0 },
            // Turned 90 degrees about +Y: looks along -X.
            { "camera": 0, "translation": [0.0, 10.0, 0.0], "rotation": [0.0, h, 0.0, h] },
            // Turned -90 degrees about +X: shines straight down, so the sun is at the zenith.
            { "extensions": { "KHR_lights_punctual": { "light": 1 } }, "rotation": [-h, 0.0, 0.0, h] },
            // Point lights are not suns.
            { "extensions": { "KHR_lights_punctual": { "light": 0 } } },
        ],
        "cameras": [{ "type": "perspective", "name": "overlook",
                      "perspective": { "yfov": 0.6, "znear": 0.1 } }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": 0 } }] }],
        "accessors": [{ "bufferView": v, "componentType": 5126, "count": 12, "type": "VEC3" }],
        "bufferViews": views,
    });
    (doc, bin)
}

/// Writes `doc` with `bin` as a data URI into `dir`/`name` (a `.gltf`).
fn write_gltf(mut doc: Value, bin: &[u8], dir: &std::path::Path) -> std::path::PathBuf {
    doc["asset"] = json!({ "version": "2.0" });
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bin)
    );
    doc["buffers"] = json!([{ "byteLength": bin.len(), "uri": uri }]);
    let path = dir.join("camera.gltf");
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    path
}

/// A unit quaternion (x, y, z, w) turning `degrees` about +Y.
fn about_y(degrees: f64) -> [f32; 4] {
    let h = degrees.to_radians() / 2.0;
    [0.0, h.sin() as f32, 0.0, h.cos() as f32]
}

/// The viewing direction of a camera turned `degrees` about +Y: its -Z turned.
fn turned_forward(degrees: f64) -> glam::DVec3 {
    let a = degrees.to_radians();
    glam::DVec3::new(-a.sin(), 0.0, -a.cos())
}

/// A parent whose translation steps (STEP) and a camera below it that moves (LINEAR) and
/// turns (LINEAR: spherical), the rotation keys stored as normalised shorts, as quantised
/// exporters write them.
fn animated_camera(dir: &std::path::Path) -> std::path::PathBuf {
    let (mut bin, mut views) = (vec![], vec![]);
    let times = view(&mut bin, &mut views, &f32s(&[0.0, 2.0]));
    let step_times = view(&mut bin, &mut views, &f32s(&[0.0, 1.0]));
    let moves = view(
        &mut bin,
        &mut views,
        &f32s(&[0.0, 10.0, 0.0, 20.0, 10.0, 0.0]),
    );
    let steps = view(
        &mut bin,
        &mut views,
        &f32s(&[0.0, 0.0, 0.0, 0.0, 0.0, 10.0]),
    );
    let shorts: Vec<u8> = [about_y(0.0), about_y(90.0)]
        .as_flattened()
        .iter()
        .flat_map(|&x| ((x * 32767.0).round() as i16).to_le_bytes())
        .collect();
    let turns = view(&mut bin, &mut views, &shorts);
    let doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [
            { "children": [1] },
            { "camera": 0 },
        ],
        "cameras": [{ "type": "perspective", "name": "flyer",
                      "perspective": { "yfov": 0.5, "znear": 0.1 } }],
        "animations": [{
            "channels": [
                { "sampler": 0, "target": { "node": 1, "path": "translation" } },
                { "sampler": 1, "target": { "node": 1, "path": "rotation" } },
                { "sampler": 2, "target": { "node": 0, "path": "translation" } },
            ],
            "samplers": [
                { "input": 0, "output": 2 },
                { "input": 0, "output": 4, "interpolation": "LINEAR" },
                { "input": 1, "output": 3, "interpolation": "STEP" },
            ],
        }],
        "accessors": [
            { "bufferView": times, "componentType": 5126, "count": 2, "type": "SCALAR",
              "min": [0.0], "max": [2.0] },
            { "bufferView": step_times, "componentType": 5126, "count": 2, "type": "SCALAR",
              "min": [0.0], "max": [1.0] },
            { "bufferView": moves, "componentType": 5126, "count": 2, "type": "VEC3" },
            { "bufferView": steps, "componentType": 5126, "count": 2, "type": "VEC3" },
            { "bufferView": turns, "componentType": 5122, "normalized": true, "count": 2,
              "type": "VEC4" },
        ],
        "bufferViews": views,
    });
    write_gltf(doc, &bin, dir)
}

#[test]
fn an_animated_camera_follows_linear_step_and_spherical_keys_through_its_parents() {
    let dir = tempfile::tempdir().unwrap();
    let path = animated_camera(dir.path());
    let limits = crate::limits::Limits::default();
    let (a, _) = super::load_camera_animation(&path, None, &limits).unwrap();
    assert_eq!((a.name.as_str(), a.start, a.end), ("flyer", 0.0, 2.0));
    // Quantised to shorts, the keys' quaternions are a few 1e-5 off.
    let close = |x: glam::DVec3, y: glam::DVec3, what: &str| {
        assert!((x - y).length() < 1e-4, "{what}: {x} against {y}");
    };
    // (time, eye, turn about +Y): the parent steps by 10 along +Z at 1 s, the camera slides
    // 20 along +X over 2 s and turns a quarter turn; before and after the keys, the ends.
    for (t, eye, degrees) in [
        (-1.0, [0.0, 10.0, 0.0], 0.0),
        (0.5, [5.0, 10.0, 0.0], 22.5),
        (1.0, [10.0, 10.0, 10.0], 45.0),
        (1.5, [15.0, 10.0, 10.0], 67.5),
        (9.0, [20.0, 10.0, 10.0], 90.0),
    ] {
        let c = a.at(t);
        close(c.eye, glam::DVec3::from(eye), &format!("eye at {t} s"));
        close(
            c.forward,
            turned_forward(degrees),
            &format!("forward at {t} s"),
        );
        close(c.up, glam::DVec3::Y, &format!("up at {t} s"));
        assert_eq!(c.yfov, f64::from(0.5f32));
    }
    // By name, the same camera; a name the file lacks is refused with the names it has.
    assert!(super::load_camera_animation(&path, Some("flyer"), &limits).is_ok());
    let e = super::load_camera_animation(&path, Some("drone"), &limits)
        .unwrap_err()
        .to_string();
    assert!(e.contains("drone") && e.contains("flyer"), "{e}");
    // An orthographic camera asked for by name is told apart from a missing one.
    let mut doc: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    doc["nodes"][0]["camera"] = json!(1);
    doc["nodes"][0]["name"] = json!("map");
    doc["cameras"]
        .as_array_mut()
        .unwrap()
        .push(json!({ "type": "orthographic",
        "orthographic": { "xmag": 1.0, "ymag": 1.0, "znear": 0.1, "zfar": 10.0 } }));
    std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
    let e = super::load_camera_animation(&path, Some("map"), &limits)
        .unwrap_err()
        .to_string();
    assert!(e.contains("\"map\" is orthographic"), "{e}");
}

#[test]
fn cubic_spline_keys_and_the_short_way_round_are_interpolated_as_gltf_specifies() {
    let (mut bin, mut views) = (vec![], vec![]);
    let times = view(&mut bin, &mut views, &f32s(&[0.0, 1.0]));
    // Triplets (in-tangent, value, out-tangent): from x = 0 leaving at slope 2 to x = 1
    // arriving flat.
    let cubic = view(
        &mut bin,
        &mut views,
        &f32s(&[
            0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, //
            0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0,
        ]),
    );
    // The same quarter turn as -q: slerp must take the short way, 45 degrees half way.
    let q = about_y(90.0).map(|x| -x);
    let turns = view(&mut bin, &mut views, &f32s(&[about_y(0.0), q].concat()));
    let doc = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "camera": 0 }],
        "cameras": [{ "type": "perspective", "perspective": { "yfov": 0.8, "znear": 0.1 } }],
        "animations": [{
            "channels": [
                { "sampler": 0, "target": { "node": 0, "path": "translation" } },
                { "sampler": 1, "target": { "node": 0, "path": "rotation" } },
            ],
            "samplers": [
                { "input": 0, "output": 1, "interpolation": "CUBICSPLINE" },
                { "input": 0, "output": 2 },
            ],
        }],
        "accessors": [
            { "bufferView": times, "componentType": 5126, "count": 2, "type": "SCALAR",
              "min": [0.0], "max": [1.0] },
            { "bufferView": cubic, "componentType": 5126, "count": 6, "type": "VEC3" },
            { "bufferView": turns, "componentType": 5126, "count": 2, "type": "VEC4" },
        ],
        "bufferViews": views,
    });
    let dir = tempfile::tempdir().unwrap();
    let path = write_gltf(doc, &bin, dir.path());
    let (a, _) =
        super::load_camera_animation(&path, None, &crate::limits::Limits::default()).unwrap();
    // Hermite at u = 1/2: h10 = 1/8 of the out-tangent 2, h01 = 1/2 of the value 1.
    let c = a.at(0.5);
    assert!((c.eye.x - 0.75).abs() < 1e-9, "{}", c.eye);
    assert!(
        (c.forward - turned_forward(45.0)).length() < 1e-6,
        "{}",
        c.forward
    );
    // At u = 1/4: h10 = 9/64, h01 = 5/32.
    assert!((a.at(0.25).eye.x - (2.0 * 9.0 / 64.0 + 5.0 / 32.0)).abs() < 1e-9);
}

#[test]
fn broken_camera_animations_are_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let limits = crate::limits::Limits::default();
    let good: Value =
        serde_json::from_slice(&std::fs::read(animated_camera(dir.path())).unwrap()).unwrap();
    // Each case breaks the good file one way, and names what the error must name.
    type Break = fn(&mut Value);
    let cases: Vec<(Break, &str)> = vec![
        (
            // Key times 0, 0: not increasing.
            |d| d["accessors"][0]["bufferView"] = json!(3),
            "animations[0].samplers[0].input",
        ),
        (
            |d| d["accessors"][2]["count"] = json!(1),
            "animations[0].samplers[0].output",
        ),
        (
            |d| d["animations"][0]["channels"][0]["sampler"] = json!(7),
            "animations[0].channels[0].sampler",
        ),
        (
            |d| d["animations"][0]["channels"][0]["target"]["node"] = json!(9),
            "animations[0].channels[0].target.node",
        ),
        (
            |d| d["nodes"][1]["matrix"] = json!([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]),
            "matrix",
        ),
        (
            |d| d["animations"] = json!([]),
            "no animation moves a camera",
        ),
        (
            // Key times as integers: read, they would be whole seconds no exporter meant.
            |d| d["accessors"][0]["componentType"] = json!(5125),
            "animations[0].samplers[0].input: key times are UNSIGNED_INT, not FLOAT",
        ),
        (
            |d| d["accessors"][2]["componentType"] = json!(5123),
            "animations[0].samplers[0].output: Translation values are UNSIGNED_SHORT, which glTF does not allow",
        ),
        (
            // The rotation keys read from zeros: [0, 0, 0, 0] is no rotation.
            |d| d["accessors"][4]["bufferView"] = json!(3),
            "animations[0].samplers[1].output: key 0's rotation",
        ),
        (
            |d| d["nodes"][1]["children"] = json!([0]),
            "nodes[1].children: the node hierarchy is cyclic",
        ),
        (
            |d| d["nodes"][0]["children"] = json!([1, 6]),
            "nodes[0].children: node 6 does not exist",
        ),
        (
            |d| d["nodes"][0]["rotation"] = json!([0, 0, 0, 0]),
            "nodes[0].rotation",
        ),
    ];
    for (break_it, needle) in cases {
        let mut doc = good.clone();
        break_it(&mut doc);
        let path = dir.path().join("broken.gltf");
        std::fs::write(&path, serde_json::to_vec(&doc).unwrap()).unwrap();
        let e = super::load_camera_animation(&path, None, &limits)
            .unwrap_err()
            .to_string();
        assert!(e.contains(needle), "{needle:?} not in {e:?}");
        assert!(e.contains("broken.gltf"), "{e}");
    }
}
