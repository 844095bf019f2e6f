use glam::{DMat4, DQuat, DVec3, Mat4, Quat, Vec3};

use super::*;
use crate::render::Placed;
use crate::rng::Stream;

/// What a viewer does with an instanced node under identity parents: the instance's
/// translation, rotation and scale (as written, in f32) applied to a mesh-space point.
fn viewer_point(t: DVec3, r: DQuat, s: DVec3, p: Vec3) -> Vec3 {
    Mat4::from_scale_rotation_translation(s.as_vec3(), r.normalize().as_quat(), t.as_vec3())
        .transform_point3(p)
}

/// Each tree's instance transform, composed with the transform a model's hierarchy gives a
/// mesh (rotated, scaled non-uniformly, moved, even mirrored), puts every point of the mesh
/// where the renderer's own transform of the tree puts the model-space point.
#[test]
fn instances_put_a_meshs_points_where_the_renderer_draws_them() {
    let mut s = Stream::new(15, 0);
    let mut u = || s.unit();
    let meshes = [
        DMat4::IDENTITY,
        DMat4::from_scale_rotation_translation(
            DVec3::new(0.5, 2.0, 1.5),
            DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 0.7),
            DVec3::new(0.2, -0.05, 1.0),
        ),
        DMat4::from_scale_rotation_translation(
            DVec3::new(-1.0, 1.0, 1.0),
            DQuat::from_rotation_x(-std::f64::consts::FRAC_PI_2),
            DVec3::new(0.0, 3.0, 0.0),
        ),
    ];
    for k in 0..200 {
        let placed = Placed {
            look: 0,
            position: DVec3::new(u() * 2000.0 - 1000.0, u() * 800.0, u() * 2000.0 - 1000.0),
            rotation: (u() * std::f64::consts::TAU) as f32,
            scale: (0.2 + u() * 5.0) as f32,
        };
        let tree = placed.transform(0, DVec3::ZERO);
        let mesh = meshes[k % meshes.len()];
        let (t, r, sc) = decompose(&(tree.world_from_model() * mesh)).expect("a TRS");
        for _ in 0..8 {
            let p = Vec3::new(u() as f32 - 0.5, u() as f32 * 4.0, u() as f32 - 0.5);
            let model = mesh.transform_point3(p.as_dvec3()).as_vec3();
            let (renderer, _) = tree.point_to_world(model, Vec3::ZERO);
            let exported = viewer_point(t, r, sc, p);
            let size = renderer.abs().max_element().max(1.0);
            assert!(
                (exported - renderer).abs().max_element() <= 2e-6 * size,
                "tree {k}: exported {exported}, rendered {renderer}"
            );
        }
    }
}

/// The tree's own transform is a turn about +Y, counter-clockwise seen from above: +X turns
/// towards -Z.
#[test]
fn a_quarter_turn_takes_x_to_minus_z() {
    let placed = Placed {
        look: 0,
        position: DVec3::new(10.0, 2.0, -3.0),
        rotation: std::f32::consts::FRAC_PI_2,
        scale: 2.0,
    };
    let m = placed.transform(0, DVec3::ZERO).world_from_model();
    let p = m.transform_point3(DVec3::X);
    assert!((p - DVec3::new(10.0, 2.0, -5.0)).length() < 1e-6, "{p}");
    let (_, r, s) = decompose(&m).unwrap();
    assert!((s - DVec3::splat(2.0)).length() < 1e-6);
    let q = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2).as_dquat();
    assert!(r.dot(q).abs() > 1.0 - 1e-6, "{r}");
}

/// A transform with shear is no TRS, and is refused rather than written wrong.
#[test]
fn a_sheared_transform_is_not_a_trs() {
    let parent = DMat4::from_scale(DVec3::new(1.0, 3.0, 1.0));
    let child = DMat4::from_rotation_z(0.5);
    assert!(decompose(&(parent * child)).is_none());
    assert!(decompose(&(child * parent)).is_some());
}

/// A model of two meshes under a turned, scaled parent, one image as a data URI, a texture
/// transform (required), an extension listed but unused, a skin and a camera.
fn two_mesh_model(dir: &std::path::Path) -> std::path::PathBuf {
    use base64::Engine as _;
    let b64 = |b: &[u8]| base64::engine::general_purpose::STANDARD.encode(b);
    let positions: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.5]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let png = crate::png::encode(&image::RgbaImage::from_pixel(
        1,
        1,
        image::Rgba([10, 200, 30, 255]),
    ));
    let q = DQuat::from_rotation_y(0.7).as_quat().to_array();
    let model = serde_json::json!({
        "asset": { "version": "2.0" },
        "extensionsUsed": ["KHR_texture_transform", "KHR_materials_unlit"],
        "extensionsRequired": ["KHR_texture_transform"],
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [
            { "name": "root", "translation": [1.0, 2.0, 3.0], "rotation": q,
              "scale": [2.0, 2.0, 2.0], "children": [1, 2] },
            { "name": "leaves", "mesh": 0, "translation": [0.0, 1.0, 0.0] },
            { "name": "trunk", "mesh": 1, "scale": [1.0, 3.0, 0.5], "camera": 0 }
        ],
        "cameras": [{ "type": "perspective", "perspective": { "yfov": 1.0, "znear": 0.1 } }],
        "skins": [{ "joints": [0] }],
        "meshes": [
            { "primitives": [{ "attributes": { "POSITION": 0 }, "material": 0 }] },
            { "name": "trunk mesh", "primitives": [{ "attributes": { "POSITION": 0 } }] }
        ],
        "materials": [{
            "name": "leaf", "alphaMode": "MASK", "alphaCutoff": 0.3,
            "pbrMetallicRoughness": { "baseColorTexture": { "index": 0,
                "extensions": { "KHR_texture_transform": { "scale": [2.0, 2.0] } } } }
        }],
        "textures": [{ "source": 0, "sampler": 0 }],
        "samplers": [{ "magFilter": 9728 }],
        "images": [{ "uri": format!("data:image/png;base64,{}", b64(&png)) }],
        "accessors": [{ "bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                        "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.5] }],
        "bufferViews": [{ "buffer": 0, "byteOffset": 4, "byteLength": 36 }],
        "buffers": [{ "byteLength": 40,
                      "uri": format!("data:application/octet-stream;base64,{}",
                                     b64(&[vec![0u8; 4], positions].concat())) }]
    });
    let path = dir.join("two-mesh.gltf");
    std::fs::write(&path, serde_json::to_vec(&model).unwrap()).unwrap();
    path
}

/// Each mesh of a node hierarchy is copied once with what it reaches, placed where the
/// importer (and so the bake and the renderer) puts its triangles; the image is embedded, the
/// texture transform kept and required, the unused extension left out, and the skin and the
/// camera dropped with a warning.
#[test]
fn a_hierarchy_of_meshes_copies_whole_and_places_as_the_importer_does() {
    let dir = tempfile::tempdir().unwrap();
    let path = two_mesh_model(dir.path());
    let mut raw = crate::import::RawGltf::open(&path, &crate::limits::Limits::default()).unwrap();
    let mut out = glb::Gltf::default();
    let copied = copy::copy_model(&mut raw, &mut out).unwrap();
    assert_eq!(copied.len(), 2);
    assert_eq!(copied[0].name.as_deref(), Some("leaves"));
    assert_eq!(
        (out.meshes.len(), out.accessors.len()),
        (2, 1),
        "one shared accessor"
    );
    assert_eq!((out.materials.len(), out.textures.len()), (1, 1));
    assert_eq!(out.images[0]["mimeType"], "image/png");
    assert!(out.images[0].get("uri").is_none());
    assert_eq!(out.materials[0]["alphaMode"], "MASK");
    let transform = "KHR_texture_transform".to_string();
    assert_eq!(out.extensions_used.iter().collect::<Vec<_>>(), [&transform]);
    assert_eq!(
        out.extensions_required.iter().collect::<Vec<_>>(),
        [&transform]
    );
    let warnings = raw.warnings().join("\n");
    assert!(warnings.contains("skins, cameras"), "{warnings}");
    // The view's bytes moved to the output's buffer from offset 4 of the source's.
    let view = &out.buffer_views[0];
    let at = view["byteOffset"].as_u64().unwrap() as usize;
    assert_eq!(
        f32::from_le_bytes(out.bin[at + 12..at + 16].try_into().unwrap()),
        1.0
    );

    let imported = crate::import::load(&path).unwrap().mesh;
    let corners = [Vec3::ZERO, Vec3::X, Vec3::new(0.0, 1.0, 0.5)];
    for (k, c) in copied.iter().enumerate() {
        for (v, p) in corners.iter().enumerate() {
            let placed = c.placed.world.transform_point3(p.as_dvec3()).as_vec3();
            let expected = imported.positions[imported.triangles[k].vertices[v] as usize];
            assert!(
                (placed - expected).length() < 1e-5,
                "{placed} != {expected}"
            );
        }
        assert!(decompose(&c.placed.world).is_some());
    }
}

/// A reference past the end of its array is an error naming the file and the field.
#[test]
fn a_missing_object_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let path = two_mesh_model(dir.path());
    let mut json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    json["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["index"] = 7.into();
    std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
    let mut raw = crate::import::RawGltf::open(&path, &crate::limits::Limits::default()).unwrap();
    let e = copy::copy_model(&mut raw, &mut glb::Gltf::default())
        .err()
        .expect("refused")
        .to_string();
    assert!(
        e.contains("two-mesh.gltf")
            && e.contains("baseColorTexture.index")
            && e.contains("textures[7] does not exist"),
        "{e}"
    );
}
