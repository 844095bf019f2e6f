//! Writes small seed inputs for the `gltf` and `exr` fuzz targets into `<DIR>/gltf/` and
//! `<DIR>/exr/` (the other targets are seeded from the project's fixtures):
//!
//!     cargo run --example make_seeds -- corpus
//!     cargo run --example make_seeds -- corpus --raw FILE.texel... FILE.instances...
//!
//! With `--raw`, it instead writes seeds for `texel_raw` and `instances_raw`: each container
//! file given, opened and decompressed, as `minor: u16 LE, header length: u32 LE, header,
//! payload` (the input those targets wrap back into a container).
//!
//! glTF seeds are self-contained (data URIs or GLB chunks, since the fuzz target's path has no
//! neighbouring files) and each exercises a few import features: index types, strips and fans,
//! sparse and strided and normalized accessors, textures in PNG and JPEG with samplers and
//! KHR_texture_transform, node hierarchies with matrices and mirroring, cameras and lights.
//! EXR seeds are 8x6 RGBA images in every compression the exr crate writes, scan lines and
//! tiles, half and float samples, mip maps and several layers.

use std::path::{Path, PathBuf};

use base64::Engine as _;
use serde_json::{Value, json};

fn main() {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "corpus".into()));
    if std::env::args().nth(2).as_deref() == Some("--raw") {
        for file in std::env::args().skip(3) {
            raw_seed(&dir, Path::new(&file));
        }
        return;
    }
    let gltf = dir.join("gltf");
    let exr = dir.join("exr");
    std::fs::create_dir_all(&gltf).unwrap();
    std::fs::create_dir_all(&exr).unwrap();
    gltf_seeds(&gltf);
    exr_seeds(&exr);
}

/// A container file as the input of the `*_raw` targets.
fn raw_seed(dir: &Path, file: &Path) {
    use texel_forest::formats::{container, instances, texel};
    let bytes = std::fs::read(file).unwrap();
    let (target, magic, format, major) = if bytes.starts_with(texel::MAGIC) {
        ("texel_raw", texel::MAGIC, "texel", texel::MAJOR)
    } else if bytes.starts_with(instances::MAGIC) {
        (
            "instances_raw",
            instances::MAGIC,
            "instances",
            instances::MAJOR,
        )
    } else {
        println!("skipped {}: not a texel or instances file", file.display());
        return;
    };
    let opened = match container::open(&bytes, magic, format, major) {
        Ok(o) => o,
        Err(e) => return println!("skipped {}: {e}", file.display()),
    };
    let payload = match opened.payload() {
        Ok(p) => p,
        Err(e) => return println!("skipped {}: {e}", file.display()),
    };
    let mut out = Vec::new();
    out.extend_from_slice(&opened.minor.to_le_bytes());
    out.extend_from_slice(&(opened.header.len() as u32).to_le_bytes());
    out.extend_from_slice(opened.header);
    out.extend_from_slice(&payload);
    let dir = dir.join(target);
    std::fs::create_dir_all(&dir).unwrap();
    write(&dir, &file.file_name().unwrap().to_string_lossy(), &out);
}

// ---------------------------------------------------------------------------------------------
// glTF

#[derive(Default)]
struct Bin {
    bytes: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    fn view(&mut self, data: &[u8], stride: Option<usize>) -> usize {
        while !self.bytes.len().is_multiple_of(4) {
            self.bytes.push(0);
        }
        let mut v =
            json!({ "buffer": 0, "byteOffset": self.bytes.len(), "byteLength": data.len() });
        if let Some(s) = stride {
            v["byteStride"] = json!(s);
        }
        self.views.push(v);
        self.bytes.extend_from_slice(data);
        self.views.len() - 1
    }

    fn accessor(&mut self, a: Value) -> usize {
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn f32s(&mut self, v: &[f32], ty: &str, minmax: bool) -> usize {
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, None);
        let n = match ty {
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            _ => 1,
        };
        let mut a =
            json!({ "bufferView": view, "componentType": 5126, "count": v.len() / n, "type": ty });
        if minmax && n == 3 {
            let mut lo = [f32::MAX; 3];
            let mut hi = [f32::MIN; 3];
            for p in v.chunks(3) {
                for c in 0..3 {
                    lo[c] = lo[c].min(p[c]);
                    hi[c] = hi[c].max(p[c]);
                }
            }
            a["min"] = json!(lo);
            a["max"] = json!(hi);
        }
        self.accessor(a)
    }

    fn indices(&mut self, idx: &[u32], component: u32) -> usize {
        let bytes: Vec<u8> = match component {
            5121 => idx.iter().map(|&i| i as u8).collect(),
            5123 => idx.iter().flat_map(|&i| (i as u16).to_le_bytes()).collect(),
            _ => idx.iter().flat_map(|&i| i.to_le_bytes()).collect(),
        };
        let view = self.view(&bytes, None);
        self.accessor(json!({ "bufferView": view, "componentType": component, "count": idx.len(), "type": "SCALAR" }))
    }
}

fn data_uri(mime: &str, bytes: &[u8]) -> String {
    format!(
        "data:{mime};base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// Finishes `doc` with `bin` as a data-URI buffer (`.gltf`).
fn as_gltf(mut doc: Value, bin: Bin) -> Vec<u8> {
    doc["asset"] = json!({ "version": "2.0", "generator": "texel-forest fuzz seeds" });
    doc["buffers"] = json!([{ "byteLength": bin.bytes.len(), "uri": data_uri("application/octet-stream", &bin.bytes) }]);
    doc["bufferViews"] = json!(bin.views);
    doc["accessors"] = json!(bin.accessors);
    serde_json::to_vec_pretty(&doc).unwrap()
}

/// Finishes `doc` with `bin` as the binary chunk (`.glb`).
fn as_glb(mut doc: Value, mut bin: Bin) -> Vec<u8> {
    doc["asset"] = json!({ "version": "2.0", "generator": "texel-forest fuzz seeds" });
    while !bin.bytes.len().is_multiple_of(4) {
        bin.bytes.push(0);
    }
    doc["buffers"] = json!([{ "byteLength": bin.bytes.len() }]);
    doc["bufferViews"] = json!(bin.views);
    doc["accessors"] = json!(bin.accessors);
    let mut json = serde_json::to_vec(&doc).unwrap();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + bin.bytes.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x4E4F_534Au32.to_le_bytes());
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x004E_4942u32.to_le_bytes());
    out.extend_from_slice(&bin.bytes);
    out
}

fn write(dir: &Path, name: &str, bytes: &[u8]) {
    std::fs::write(dir.join(name), bytes).unwrap();
    println!("{} ({} bytes)", dir.join(name).display(), bytes.len());
}

/// A unit box: 8 corners, 12 outward triangles.
fn cube(center: [f32; 3], half: [f32; 3]) -> (Vec<f32>, Vec<u32>) {
    let mut p = Vec::new();
    for i in 0..8 {
        for c in 0..3 {
            let s = if (i >> c) & 1 == 1 { 1.0 } else { -1.0 };
            p.push(center[c] + s * half[c]);
        }
    }
    let idx = vec![
        0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6,
        1, 3, 5, 3, 7, 5,
    ];
    (p, idx)
}

/// Leaf quads around a point: positions, uvs, indices.
fn leaves(center: [f32; 3], n: usize) -> (Vec<f32>, Vec<f32>, Vec<u32>) {
    let (mut p, mut uv, mut idx) = (Vec::new(), Vec::new(), Vec::new());
    for k in 0..n {
        let a = k as f32 * 2.399;
        let (s, c) = a.sin_cos();
        let o = [
            center[0] + 0.8 * c,
            center[1] + 0.3 * (k as f32 % 3.0),
            center[2] + 0.8 * s,
        ];
        let base = (p.len() / 3) as u32;
        for (dx, dy, u, v) in [
            (-0.2, 0.0, 0.0, 1.0),
            (0.2, 0.0, 1.0, 1.0),
            (-0.2, 0.4, 0.0, 0.0),
            (0.2, 0.4, 1.0, 0.0),
        ] {
            p.extend_from_slice(&[o[0] + dx * s, o[1] + dy, o[2] - dx * c]);
            uv.extend_from_slice(&[u, v]);
        }
        idx.extend_from_slice(&[base, base + 1, base + 2, base + 2, base + 1, base + 3]);
    }
    (p, uv, idx)
}

fn png_rgba() -> Vec<u8> {
    let img = image::RgbaImage::from_fn(4, 4, |x, y| {
        image::Rgba([
            (x * 60) as u8,
            (y * 60) as u8,
            40,
            if (x + y) % 2 == 0 { 255 } else { 0 },
        ])
    });
    encode(
        image::DynamicImage::ImageRgba8(img),
        image::ImageFormat::Png,
    )
}

fn png_rgb() -> Vec<u8> {
    let img = image::RgbImage::from_fn(3, 2, |x, y| {
        image::Rgb([(x * 80) as u8, (y * 120) as u8, 30])
    });
    encode(image::DynamicImage::ImageRgb8(img), image::ImageFormat::Png)
}

fn png_gray16() -> Vec<u8> {
    let img = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(2, 2, |x, y| {
        image::Luma([(x * 30000 + y * 1000) as u16])
    });
    encode(
        image::DynamicImage::ImageLuma16(img),
        image::ImageFormat::Png,
    )
}

fn jpeg_rgb() -> Vec<u8> {
    let img = image::RgbImage::from_fn(8, 8, |x, y| {
        image::Rgb([(x * 30) as u8, (y * 30) as u8, 90])
    });
    encode(
        image::DynamicImage::ImageRgb8(img),
        image::ImageFormat::Jpeg,
    )
}

fn encode(img: image::DynamicImage, format: image::ImageFormat) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, format).unwrap();
    out.into_inner()
}

fn gltf_seeds(dir: &Path) {
    // 1. One triangle, no indices, default material.
    {
        let mut b = Bin::default();
        let p = b.f32s(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], "VEC3", true);
        let doc = json!({
            "scene": 0,
            "scenes": [{ "nodes": [0] }],
            "nodes": [{ "mesh": 0 }],
            "meshes": [{ "primitives": [{ "attributes": { "POSITION": p } }] }],
        });
        write(dir, "triangle.gltf", &as_gltf(doc, b));
    }
    // 2. A small tree: a bark trunk (u16 indices) and textured, alpha-masked leaves (u8 and u32
    //    indices), vertex colours, sampler, texture transform; as .gltf and as .glb.
    for glb in [false, true] {
        let mut b = Bin::default();
        let (tp, ti) = cube([0.0, 1.0, 0.0], [0.15, 1.0, 0.15]);
        let trunk_p = b.f32s(&tp, "VEC3", true);
        let trunk_i = b.indices(&ti, 5123);
        let (lp, luv, li) = leaves([0.0, 2.0, 0.0], 6);
        let leaf_p = b.f32s(&lp, "VEC3", true);
        let leaf_uv = b.f32s(&luv, "VEC2", false);
        let colors: Vec<u8> = (0..lp.len() / 3)
            .flat_map(|i| [200, (i * 10) as u8, 50, 255])
            .collect();
        let cv = b.view(&colors, None);
        let leaf_c = b.accessor(json!({ "bufferView": cv, "componentType": 5121, "normalized": true, "count": lp.len() / 3, "type": "VEC4" }));
        let leaf_i8 = b.indices(&li[..12], 5121);
        let leaf_i32 = b.indices(&li[12..], 5125);
        let png = png_rgba();
        let image = if glb {
            let v = b.view(&png, None);
            json!({ "bufferView": v, "mimeType": "image/png" })
        } else {
            json!({ "uri": data_uri("image/png", &png) })
        };
        let doc = json!({
            "scene": 0,
            "scenes": [{ "nodes": [0] }],
            "nodes": [
                { "name": "tree", "children": [1, 2], "translation": [1.0, 0.0, -2.0], "rotation": [0.0, 0.3826834, 0.0, 0.9238795], "scale": [1.0, 1.2, 1.0] },
                { "name": "trunk", "mesh": 0 },
                { "name": "crown", "mesh": 1, "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0.5,0,1] }
            ],
            "meshes": [
                { "name": "trunk", "primitives": [{ "attributes": { "POSITION": trunk_p }, "indices": trunk_i, "material": 0 }] },
                { "name": "crown", "primitives": [
                    { "attributes": { "POSITION": leaf_p, "TEXCOORD_0": leaf_uv, "COLOR_0": leaf_c }, "indices": leaf_i8, "material": 1 },
                    { "attributes": { "POSITION": leaf_p, "TEXCOORD_0": leaf_uv }, "indices": leaf_i32, "material": 1 }
                ] }
            ],
            "materials": [
                { "name": "bark", "pbrMetallicRoughness": { "baseColorFactor": [0.3, 0.2, 0.1, 1.0] } },
                { "name": "leaves", "alphaMode": "MASK", "alphaCutoff": 0.4, "doubleSided": true,
                  "pbrMetallicRoughness": { "baseColorTexture": { "index": 0, "texCoord": 0,
                      "extensions": { "KHR_texture_transform": { "offset": [0.1, 0.0], "rotation": 0.2, "scale": [2.0, 1.0] } } } } }
            ],
            "textures": [{ "source": 0, "sampler": 0 }],
            "samplers": [{ "magFilter": 9728, "wrapS": 33648, "wrapT": 33071 }],
            "images": [image],
            "extensionsUsed": ["KHR_texture_transform"],
        });
        if glb {
            write(dir, "tree.glb", &as_glb(doc, b));
        } else {
            write(dir, "tree.gltf", &as_gltf(doc, b));
        }
    }
    // 3. Strips, fans, points and lines; no scenes (roots are the nodes nobody parents).
    {
        let mut b = Bin::default();
        let sq = b.f32s(
            &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0],
            "VEC3",
            true,
        );
        let strip_i = b.indices(&[0, 1, 2, 3], 5123);
        let doc = json!({
            "nodes": [{ "mesh": 0, "children": [1] }, { "mesh": 1, "scale": [-1.0, 1.0, 1.0] }],
            "meshes": [
                { "primitives": [
                    { "attributes": { "POSITION": sq }, "mode": 5 },
                    { "attributes": { "POSITION": sq }, "mode": 6 },
                    { "attributes": { "POSITION": sq }, "mode": 0 },
                    { "attributes": { "POSITION": sq }, "mode": 1 }
                ] },
                { "primitives": [{ "attributes": { "POSITION": sq }, "indices": strip_i, "mode": 5, "material": 0 }] }
            ],
            "materials": [{ "name": "needle", "alphaMode": "BLEND", "pbrMetallicRoughness": { "baseColorFactor": [0.1, 0.5, 0.1, 0.5] } }],
        });
        write(dir, "modes.gltf", &as_gltf(doc, b));
    }
    // 4. Sparse and strided accessors; a sparse accessor without a buffer view.
    {
        let mut b = Bin::default();
        // Interleaved position (12 bytes) + uv (8 bytes), stride 20.
        let verts: [[f32; 5]; 4] = [
            [0.0, 0.0, 0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0, 1.0, 0.0],
            [0.0, 1.0, 0.0, 0.0, 1.0],
            [1.0, 1.0, 0.5, 1.0, 1.0],
        ];
        let bytes: Vec<u8> = verts
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let iv = b.view(&bytes, Some(20));
        let pos = b.accessor(json!({ "bufferView": iv, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0,0,0], "max": [1,1,0.5] }));
        let uv = b.accessor(json!({ "bufferView": iv, "byteOffset": 12, "componentType": 5126, "count": 4, "type": "VEC2" }));
        let si: Vec<u8> = [1u16, 3].iter().flat_map(|x| x.to_le_bytes()).collect();
        let siv = b.view(&si, None);
        let sv: Vec<u8> = [2.0f32, 0.0, 0.0, 2.0, 2.0, 1.0]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let svv = b.view(&sv, None);
        let sparse_pos = b.accessor(json!({ "bufferView": iv, "componentType": 5126, "count": 4, "type": "VEC3",
            "sparse": { "count": 2, "indices": { "bufferView": siv, "componentType": 5123 }, "values": { "bufferView": svv } } }));
        let sparse_only = b.accessor(json!({ "componentType": 5126, "count": 4, "type": "VEC3",
            "sparse": { "count": 2, "indices": { "bufferView": siv, "componentType": 5123 }, "values": { "bufferView": svv } } }));
        let idx = b.indices(&[0, 1, 2, 2, 1, 3], 5125);
        let png = png_rgb();
        let doc = json!({
            "scenes": [{ "nodes": [0, 1, 2] }],
            "nodes": [{ "mesh": 0 }, { "mesh": 1, "translation": [0, 0, 1] }, { "mesh": 2, "translation": [0, 0, 2] }],
            "meshes": [
                { "primitives": [{ "attributes": { "POSITION": pos, "TEXCOORD_0": uv }, "indices": idx, "material": 0 }] },
                { "primitives": [{ "attributes": { "POSITION": sparse_pos }, "indices": idx }] },
                { "primitives": [{ "attributes": { "POSITION": sparse_only }, "indices": idx }] }
            ],
            "materials": [{ "name": "foliage", "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }],
            "textures": [{ "source": 0 }],
            "images": [{ "uri": data_uri("image/png", &png) }],
        });
        write(dir, "sparse-strided.gltf", &as_gltf(doc, b));
    }
    // 5. Quantized positions (normalized shorts and bytes) and texcoords, KHR_mesh_quantization.
    {
        let mut b = Bin::default();
        let p: Vec<u8> = [
            [0i16, 0, 0, 0],
            [32767, 0, 0, 0],
            [0, 32767, 0, 0],
            [0, 0, -32767, 0],
        ]
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
        let pv = b.view(&p, Some(8));
        let pos = b.accessor(json!({ "bufferView": pv, "componentType": 5122, "normalized": true, "count": 4, "type": "VEC3" }));
        let uvb: Vec<u8> = vec![0, 0, 255, 0, 0, 255, 255, 255];
        let uvv = b.view(&uvb, None);
        let uv = b.accessor(json!({ "bufferView": uvv, "componentType": 5121, "normalized": true, "count": 4, "type": "VEC2" }));
        let cb: Vec<u8> = [
            65535u16, 0, 0, 0, 65535, 0, 0, 0, 65535, 30000, 30000, 30000,
        ]
        .iter()
        .flat_map(|x| x.to_le_bytes())
        .collect();
        let cv = b.view(&cb, None);
        let col = b.accessor(json!({ "bufferView": cv, "componentType": 5123, "normalized": true, "count": 4, "type": "VEC3" }));
        let idx = b.indices(&[0, 1, 2, 0, 2, 3, 0, 3, 1, 1, 3, 2], 5121);
        let jpg = jpeg_rgb();
        let doc = json!({
            "scenes": [{ "nodes": [0] }],
            "nodes": [{ "mesh": 0, "scale": [4.0, 4.0, 4.0] }],
            "meshes": [{ "primitives": [{ "attributes": { "POSITION": pos, "TEXCOORD_1": uv, "COLOR_0": col }, "indices": idx, "material": 0 }] }],
            "materials": [{ "name": "crown", "pbrMetallicRoughness": { "baseColorTexture": { "index": 0, "texCoord": 1 } } }],
            "textures": [{ "source": 0, "sampler": 0 }],
            "samplers": [{ "wrapS": 33071, "wrapT": 10497 }],
            "images": [{ "uri": data_uri("image/jpeg", &jpg) }],
            "extensionsUsed": ["KHR_mesh_quantization"],
            "extensionsRequired": ["KHR_mesh_quantization"],
        });
        write(dir, "quantized-jpeg.gltf", &as_gltf(doc, b));
    }
    // 6. Cameras, a directional light, a skinned-looking node, an empty scene and a second
    //    scene selected by `scene`; and a gray 16-bit PNG in a GLB.
    {
        let mut b = Bin::default();
        let (cp, ci) = cube([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
        let p = b.f32s(&cp, "VEC3", true);
        let i = b.indices(&ci, 5123);
        let png = png_gray16();
        let iv = b.view(&png, None);
        let doc = json!({
            "scene": 1,
            "scenes": [{}, { "nodes": [0, 1, 2] }],
            "nodes": [
                { "name": "cam", "camera": 0, "translation": [0, 2, 10] },
                { "name": "sun", "rotation": [-0.3826834, 0, 0, 0.9238795],
                  "extensions": { "KHR_lights_punctual": { "light": 0 } } },
                { "name": "box", "mesh": 0, "skin": 0, "matrix": [-1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1] }
            ],
            "cameras": [{ "name": "view", "type": "perspective", "perspective": { "yfov": 0.7, "znear": 0.1, "aspectRatio": 1.5 } },
                        { "type": "orthographic", "orthographic": { "xmag": 1, "ymag": 1, "znear": 0.1, "zfar": 100 } }],
            "skins": [{ "joints": [2] }],
            "meshes": [{ "primitives": [{ "attributes": { "POSITION": p }, "indices": i, "material": 0 }] }],
            "materials": [{ "name": "Leaf", "alphaMode": "MASK", "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } }],
            "textures": [{ "source": 0 }],
            "images": [{ "bufferView": iv, "mimeType": "image/png" }],
            "extensions": { "KHR_lights_punctual": { "lights": [
                { "name": "sun", "type": "directional", "intensity": 3.0, "color": [1.0, 0.9, 0.8] },
                { "type": "point", "intensity": 1.0 }
            ] } },
            "extensionsUsed": ["KHR_lights_punctual", "EXT_mesh_gpu_instancing"],
        });
        write(dir, "camera-light.glb", &as_glb(doc, b));
    }
    // 7. Instancing: one mesh referenced by many nodes in a two-level hierarchy.
    {
        let mut b = Bin::default();
        let (cp, ci) = cube([0.0, 0.5, 0.0], [0.5, 0.5, 0.5]);
        let p = b.f32s(&cp, "VEC3", true);
        let i = b.indices(&ci, 5125);
        let mut nodes = vec![json!({ "children": (1..9).collect::<Vec<_>>() })];
        for k in 0..8 {
            nodes.push(json!({ "mesh": 0, "translation": [k as f32 * 1.5, 0, (k % 3) as f32] }));
        }
        let doc = json!({
            "scenes": [{ "nodes": [0] }],
            "nodes": nodes,
            "meshes": [{ "primitives": [{ "attributes": { "POSITION": p }, "indices": i }] }],
        });
        write(dir, "instanced.gltf", &as_gltf(doc, b));
    }
}

// ---------------------------------------------------------------------------------------------
// OpenEXR

fn exr_seeds(dir: &Path) {
    use exr::prelude::*;
    let size = Vec2(8, 6);
    let pixel = |p: Vec2<usize>| {
        (
            p.x() as f32 / 8.0,
            p.y() as f32 / 6.0,
            0.25,
            if (p.x() + p.y()) % 3 == 0 { 0.0 } else { 1.0 },
        )
    };
    let half_pixel = |p: Vec2<usize>| {
        let (r, g, b, a) = pixel(p);
        (
            f16::from_f32(r),
            f16::from_f32(g),
            f16::from_f32(b),
            f16::from_f32(a),
        )
    };
    let compressions = [
        ("none", Compression::Uncompressed),
        ("rle", Compression::RLE),
        ("zip1", Compression::ZIP1),
        ("zip16", Compression::ZIP16),
        ("piz", Compression::PIZ),
        ("pxr24", Compression::PXR24),
        ("b44", Compression::B44),
        ("b44a", Compression::B44A),
    ];
    let save = |name: &str, result: std::result::Result<(), exr::error::Error>| match result {
        Ok(()) => println!("{}", dir.join(name).display()),
        Err(e) => println!("skipped {name}: {e}"),
    };
    for (cname, compression) in compressions {
        for tiled in [false, true] {
            let blocks = if tiled {
                Blocks::Tiles(Vec2(4, 4))
            } else {
                Blocks::ScanLines
            };
            let encoding = Encoding {
                compression,
                blocks,
                line_order: LineOrder::Increasing,
            };
            let kind = if tiled { "tiles" } else { "lines" };
            // Half everywhere; float for a few.
            let name = format!("rgba-half-{cname}-{kind}.exr");
            let layer = Layer::new(
                size,
                LayerAttributes::named("half"),
                encoding,
                SpecificChannels::rgba(half_pixel),
            );
            save(
                &name,
                Image::from_layer(layer).write().to_file(dir.join(&name)),
            );
            if matches!(cname, "none" | "zip16" | "piz" | "pxr24") && !tiled {
                let name = format!("rgba-float-{cname}-{kind}.exr");
                let layer = Layer::new(
                    size,
                    LayerAttributes::named("float"),
                    encoding,
                    SpecificChannels::rgba(pixel),
                );
                save(
                    &name,
                    Image::from_layer(layer).write().to_file(dir.join(&name)),
                );
            }
        }
    }
    // A data window off the origin, decreasing line order, a u32 channel and no name.
    {
        let mut attributes = LayerAttributes::default();
        attributes.layer_position = Vec2(-3, 5);
        let channels = AnyChannels::sort(smallvec::smallvec![
            AnyChannel::new("R", FlatSamples::F32(vec![0.5; 48])),
            AnyChannel::new("G", FlatSamples::F16(vec![f16::from_f32(0.25); 48])),
            AnyChannel::new("B", FlatSamples::U32(vec![7; 48])),
            AnyChannel::new("A", FlatSamples::F32(vec![1.0; 48])),
            AnyChannel::new("Z", FlatSamples::F32(vec![10.0; 48])),
        ]);
        let layer = Layer::new(
            size,
            attributes,
            Encoding {
                compression: Compression::ZIP1,
                blocks: Blocks::ScanLines,
                line_order: LineOrder::Decreasing,
            },
            channels,
        );
        let name = "mixed-types-offset.exr";
        save(
            name,
            Image::from_layer(layer).write().to_file(dir.join(name)),
        );
    }
    // Missing alpha (compare reports the missing channel).
    {
        let layer = Layer::new(
            size,
            LayerAttributes::named("rgb"),
            Encoding::FAST_LOSSLESS,
            SpecificChannels::rgb(|p: Vec2<usize>| (p.x() as f32, p.y() as f32, 0.0f32)),
        );
        let name = "rgb-no-alpha.exr";
        save(
            name,
            Image::from_layer(layer).write().to_file(dir.join(name)),
        );
    }
    // Two layers (multi-part file).
    {
        let a = Layer::new(
            size,
            LayerAttributes::named("beauty"),
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(smallvec::smallvec![
                AnyChannel::new("R", FlatSamples::F16(vec![f16::ONE; 48])),
                AnyChannel::new("G", FlatSamples::F16(vec![f16::ONE; 48])),
                AnyChannel::new("B", FlatSamples::F16(vec![f16::ONE; 48])),
                AnyChannel::new("A", FlatSamples::F16(vec![f16::ONE; 48])),
            ]),
        );
        let b = Layer::new(
            Vec2(4, 3),
            LayerAttributes::named("depth"),
            Encoding::UNCOMPRESSED,
            AnyChannels::sort(smallvec::smallvec![AnyChannel::new(
                "Z",
                FlatSamples::F32(vec![3.0; 12])
            )]),
        );
        let image = Image::empty(ImageAttributes::new(IntegerBounds::from_dimensions(size)))
            .with_layer(a)
            .with_layer(b);
        let name = "two-layers.exr";
        save(name, image.write().to_file(dir.join(name)));
    }
    // Mip maps (tiled, rounding up).
    {
        let sizes: Vec<_> = exr::meta::mip_map_levels(exr::math::RoundingMode::Up, size).collect();
        let level = |v: f32| Levels::Mip {
            level_data: sizes
                .iter()
                .map(|(_, s)| FlatSamples::F16(vec![f16::from_f32(v); s.area()]))
                .collect(),
            rounding_mode: exr::math::RoundingMode::Up,
        };
        let channels = AnyChannels::sort(smallvec::smallvec![
            AnyChannel::new("R", level(0.1)),
            AnyChannel::new("G", level(0.2)),
            AnyChannel::new("B", level(0.3)),
            AnyChannel::new("A", level(1.0)),
        ]);
        let layer = Layer::new(
            size,
            LayerAttributes::named("mips"),
            Encoding {
                compression: Compression::ZIP1,
                blocks: Blocks::Tiles(Vec2(4, 4)),
                line_order: LineOrder::Increasing,
            },
            channels,
        );
        let name = "mip-maps.exr";
        save(
            name,
            Image::from_layer(layer).write().to_file(dir.join(name)),
        );
    }
}
