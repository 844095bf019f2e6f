//! A small polygon-model builder and glTF 2.0 writer, for the procedural fixtures and for tests
//! that need a glTF file with a particular property (or a particular defect).

use base64::Engine as _;
use glam::{Vec2, Vec3};
use serde_json::{Value, json};

/// How a material covers: opaque, or alpha-masked by a texture.
#[derive(Clone, Debug)]
pub struct MaterialSpec {
    pub name: String,
    /// Linear RGBA `baseColorFactor`.
    pub color: [f32; 4],
    /// An RGBA8 texture (sRGB colour, linear alpha) and an alpha cutoff.
    pub mask: Option<(image::RgbaImage, f32)>,
}

#[derive(Clone, Debug, Default)]
struct Part {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    indices: Vec<u32>,
}

/// Geometry grouped by material; each material becomes one primitive.
#[derive(Clone, Debug, Default)]
pub struct ModelBuilder {
    materials: Vec<MaterialSpec>,
    parts: Vec<Part>,
}

impl ModelBuilder {
    pub fn material(&mut self, spec: MaterialSpec) -> usize {
        self.materials.push(spec);
        self.parts.push(Part::default());
        self.materials.len() - 1
    }

    pub fn triangle_count(&self) -> usize {
        self.parts.iter().map(|p| p.indices.len() / 3).sum()
    }

    fn vertex(&mut self, m: usize, p: Vec3, n: Vec3, uv: Vec2) -> u32 {
        let part = &mut self.parts[m];
        part.positions.push(p);
        part.normals.push(n.normalize_or(Vec3::Y));
        part.uvs.push(uv);
        part.positions.len() as u32 - 1
    }

    pub fn triangle(&mut self, m: usize, a: u32, b: u32, c: u32) {
        self.parts[m].indices.extend([a, b, c]);
    }

    /// A closed tube along `path` (centre, radius) with `sides` faces and flat end caps: a
    /// watertight solid, the way a branch should be modelled.
    pub fn tube(&mut self, m: usize, path: &[(Vec3, f32)], sides: usize) {
        if path.len() < 2 {
            return;
        }
        let mut rings: Vec<Vec<u32>> = Vec::with_capacity(path.len());
        // A frame carried along the path (parallel transport) keeps the rings from twisting.
        let first_dir = (path[1].0 - path[0].0).normalize_or(Vec3::Y);
        let mut side = first_dir.any_orthonormal_vector();
        for (i, &(centre, radius)) in path.iter().enumerate() {
            let dir = if i + 1 < path.len() {
                path[i + 1].0 - centre
            } else {
                centre - path[i - 1].0
            }
            .normalize_or(Vec3::Y);
            side = (side - dir * side.dot(dir)).normalize_or(dir.any_orthonormal_vector());
            let up = dir.cross(side);
            let ring = (0..sides)
                .map(|s| {
                    let a = s as f32 / sides as f32 * std::f32::consts::TAU;
                    let n = side * a.cos() + up * a.sin();
                    self.vertex(
                        m,
                        centre + n * radius,
                        n,
                        Vec2::new(s as f32 / sides as f32, i as f32),
                    )
                })
                .collect();
            rings.push(ring);
        }
        for w in rings.windows(2) {
            for s in 0..sides {
                let (a, b) = (w[0][s], w[0][(s + 1) % sides]);
                let (c, d) = (w[1][s], w[1][(s + 1) % sides]);
                self.triangle(m, a, b, d);
                self.triangle(m, a, d, c);
            }
        }
        // Caps reuse the ring vertices so every edge is shared by exactly two triangles.
        let (first, last) = (&rings[0], &rings[rings.len() - 1]);
        let start = self.vertex(m, path[0].0, -first_dir, Vec2::ZERO);
        let end_dir = (path[path.len() - 1].0 - path[path.len() - 2].0).normalize_or(Vec3::Y);
        let end = self.vertex(m, path[path.len() - 1].0, end_dir, Vec2::ZERO);
        for s in 0..sides {
            let (a, b) = (first[s], first[(s + 1) % sides]);
            self.triangle(m, start, b, a);
            let (a, b) = (last[s], last[(s + 1) % sides]);
            self.triangle(m, end, a, b);
        }
    }

    /// A closed axis-aligned box from `lo` to `hi`, faces wound outwards.
    pub fn cuboid(&mut self, m: usize, lo: Vec3, hi: Vec3) {
        let corners = crate::geom::box_corners(lo.to_array(), hi.to_array());
        let corner = |i: usize| Vec3::from(corners[i]);
        // Each face as four corner indices, counter-clockwise seen from outside.
        const FACES: [([usize; 4], [f32; 3]); 6] = [
            ([0, 4, 6, 2], [-1.0, 0.0, 0.0]),
            ([1, 3, 7, 5], [1.0, 0.0, 0.0]),
            ([0, 1, 5, 4], [0.0, -1.0, 0.0]),
            ([2, 6, 7, 3], [0.0, 1.0, 0.0]),
            ([0, 2, 3, 1], [0.0, 0.0, -1.0]),
            ([4, 5, 7, 6], [0.0, 0.0, 1.0]),
        ];
        for (face, normal) in FACES {
            let ids: Vec<u32> = face
                .iter()
                .enumerate()
                .map(|(k, &c)| {
                    self.vertex(
                        m,
                        corner(c),
                        Vec3::from(normal),
                        Vec2::new((k == 1 || k == 2) as u8 as f32, (k >= 2) as u8 as f32),
                    )
                })
                .collect();
            self.triangle(m, ids[0], ids[1], ids[2]);
            self.triangle(m, ids[0], ids[2], ids[3]);
        }
    }

    /// A height grid of `[nx, nz]` vertices: `heights[i + nx * j]` at (x0 + i cell, z0 + j cell), two triangles per
    /// quad facing up, with smooth vertex normals.
    pub fn grid(
        &mut self,
        m: usize,
        [x0, z0]: [f32; 2],
        cell: f32,
        [nx, nz]: [usize; 2],
        heights: &[f32],
    ) {
        let h = |i: usize, j: usize| heights[i.min(nx - 1) + nx * j.min(nz - 1)];
        let base = self.parts[m].positions.len() as u32;
        for j in 0..nz {
            for i in 0..nx {
                let dx = h(i + 1, j) - h(i.saturating_sub(1), j);
                let dz = h(i, j + 1) - h(i, j.saturating_sub(1));
                let normal = Vec3::new(-dx, 2.0 * cell, -dz);
                let p = Vec3::new(x0 + i as f32 * cell, h(i, j), z0 + j as f32 * cell);
                let uv = Vec2::new(i as f32 / (nx - 1) as f32, j as f32 / (nz - 1) as f32);
                self.vertex(m, p, normal, uv);
            }
        }
        for j in 0..nz - 1 {
            for i in 0..nx - 1 {
                let v = |a: usize, b: usize| base + (a + nx * b) as u32;
                // Counter-clockwise seen from above (+y): x east, z south.
                self.triangle(m, v(i, j), v(i, j + 1), v(i + 1, j));
                self.triangle(m, v(i + 1, j), v(i, j + 1), v(i + 1, j + 1));
            }
        }
    }

    /// A single-sided card: `centre` +- `u` / 2 +- `v` / 2, UVs spanning the texture.
    pub fn card(&mut self, m: usize, centre: Vec3, u: Vec3, v: Vec3) {
        let n = u.cross(v);
        let corners = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)];
        let ids: Vec<u32> = corners
            .iter()
            .map(|&(a, b)| self.vertex(m, centre + u * a + v * b, n, Vec2::new(a + 0.5, 0.5 - b)))
            .collect();
        self.triangle(m, ids[0], ids[1], ids[2]);
        self.triangle(m, ids[0], ids[2], ids[3]);
    }

    /// The model as a glTF document (JSON), its binary buffer and its image files. With
    /// `external = Some(stem)` the buffer is `stem.bin` and images are `stem_N.png` beside the
    /// `.gltf`; with `None` the buffer is the GLB chunk and images live in it.
    pub fn to_gltf(&self, external: Option<&str>, generator: &str) -> GltfFiles {
        let mut buffer = Buffer::default();
        let mut images = Images::default();
        let materials: Vec<Value> = self
            .materials
            .iter()
            .map(|spec| material_json(spec, external, &mut buffer, &mut images))
            .collect();
        let mut accessors = Vec::new();
        let mut primitives = Vec::new();
        for (m, part) in self.parts.iter().enumerate() {
            if part.indices.is_empty() {
                continue;
            }
            primitives.push(primitive_json(m, part, &mut buffer, &mut accessors));
        }
        buffer.align();
        let Buffer { bin, views } = buffer;
        let mut buffer_json = json!({ "byteLength": bin.len() });
        if let Some(stem) = external {
            buffer_json["uri"] = json!(format!("{stem}.bin"));
        }
        let mut doc = json!({
            "asset": { "version": "2.0", "generator": generator },
            "scene": 0,
            "scenes": [{ "nodes": [0] }],
            "nodes": [{ "name": "tree", "mesh": 0 }],
            "meshes": [{ "primitives": primitives }],
            "materials": materials,
            "accessors": accessors,
            "bufferViews": views,
            "buffers": [buffer_json],
        });
        if !images.images.is_empty() {
            doc["images"] = json!(images.images);
            doc["textures"] = json!(images.textures);
            doc["samplers"] =
                json!([{ "magFilter": 9729, "minFilter": 9987, "wrapS": 33071, "wrapT": 33071 }]);
        }
        GltfFiles {
            doc,
            bin,
            images: images.files,
        }
    }
}

/// The binary buffer as it fills, and the glTF buffer views that cut it up.
#[derive(Default)]
struct Buffer {
    bin: Vec<u8>,
    views: Vec<Value>,
}

impl Buffer {
    /// Pads to a multiple of 4 bytes: glTF wants every view, and the buffer's end, aligned
    /// for the largest component type.
    fn align(&mut self) {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
    }

    /// Appends `data` as a new view (with `target`, for vertex and index data); returns the
    /// view's index.
    fn push_view(&mut self, data: &[u8], target: Option<u32>) -> usize {
        self.align();
        let mut view =
            json!({ "buffer": 0, "byteOffset": self.bin.len(), "byteLength": data.len() });
        if let Some(t) = target {
            view["target"] = json!(t);
        }
        self.bin.extend_from_slice(data);
        self.views.push(view);
        self.views.len() - 1
    }
}

/// The masks' pictures as glTF images and textures, and the image files an external layout
/// writes beside the `.gltf`.
#[derive(Default)]
struct Images {
    images: Vec<Value>,
    textures: Vec<Value>,
    files: Vec<(String, Vec<u8>)>,
}

/// One material; a masked one also gets its texture, stored in the buffer or as a file beside
/// the document as `external` says.
fn material_json(
    spec: &MaterialSpec,
    external: Option<&str>,
    buffer: &mut Buffer,
    images: &mut Images,
) -> Value {
    let mut pbr =
        json!({ "baseColorFactor": spec.color, "metallicFactor": 0.0, "roughnessFactor": 0.9 });
    let mut material = json!({ "name": spec.name, "doubleSided": true });
    if let Some((img, cutoff)) = &spec.mask {
        let png = crate::png::encode(img);
        match external {
            Some(stem) => {
                let name = format!("{stem}_{}.png", images.images.len());
                images.images.push(json!({ "uri": name }));
                images.files.push((name, png));
            }
            None => {
                let view = buffer.push_view(&png, None);
                images
                    .images
                    .push(json!({ "bufferView": view, "mimeType": "image/png" }));
            }
        }
        images
            .textures
            .push(json!({ "source": images.images.len() - 1, "sampler": 0 }));
        pbr["baseColorTexture"] = json!({ "index": images.textures.len() - 1 });
        material["alphaMode"] = json!("MASK");
        material["alphaCutoff"] = json!(cutoff);
    }
    material["pbrMetallicRoughness"] = pbr;
    material
}

/// One part's primitive: its positions, normals, UVs and indices each put in the buffer with
/// an accessor, in that order.
fn primitive_json(m: usize, part: &Part, buffer: &mut Buffer, accessors: &mut Vec<Value>) -> Value {
    let lo = part
        .positions
        .iter()
        .fold(Vec3::splat(f32::INFINITY), |a, &p| a.min(p));
    let hi = part
        .positions
        .iter()
        .fold(Vec3::splat(f32::NEG_INFINITY), |a, &p| a.max(p));
    let data = f32_bytes(part.positions.iter().map(|p| p.to_array()));
    let pv = buffer.push_view(&data, Some(34962));
    accessors.push(json!({ "bufferView": pv, "componentType": 5126, "count": part.positions.len(), "type": "VEC3", "min": lo.to_array(), "max": hi.to_array() }));
    let pos = accessors.len() - 1;
    let data = f32_bytes(part.normals.iter().map(|p| p.to_array()));
    let nv = buffer.push_view(&data, Some(34962));
    accessors.push(json!({ "bufferView": nv, "componentType": 5126, "count": part.normals.len(), "type": "VEC3" }));
    let nrm = accessors.len() - 1;
    let data = f32_bytes(part.uvs.iter().map(|p| p.to_array()));
    let uv = buffer.push_view(&data, Some(34962));
    accessors.push(
        json!({ "bufferView": uv, "componentType": 5126, "count": part.uvs.len(), "type": "VEC2" }),
    );
    let tex = accessors.len() - 1;
    let wide = part.positions.len() > u16::MAX as usize;
    let data: Vec<u8> = if wide {
        part.indices.iter().flat_map(|i| i.to_le_bytes()).collect()
    } else {
        part.indices
            .iter()
            .flat_map(|&i| (i as u16).to_le_bytes())
            .collect()
    };
    let iv = buffer.push_view(&data, Some(34963));
    accessors.push(json!({ "bufferView": iv, "componentType": if wide { 5125 } else { 5123 }, "count": part.indices.len(), "type": "SCALAR" }));
    let idx = accessors.len() - 1;
    json!({
        "attributes": { "POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": tex },
        "indices": idx,
        "material": m,
    })
}

/// Vectors as glTF stores them: their components, little-endian `f32`s one after another.
fn f32_bytes<const N: usize>(vectors: impl Iterator<Item = [f32; N]>) -> Vec<u8> {
    vectors.flatten().flat_map(f32::to_le_bytes).collect()
}

/// A glTF model as files: the JSON document, the binary buffer and any external images.
#[derive(Clone, Debug)]
pub struct GltfFiles {
    pub doc: Value,
    pub bin: Vec<u8>,
    pub images: Vec<(String, Vec<u8>)>,
}

/// A binary glTF file of `doc` with `bin` as its buffer.
pub fn glb(doc: &Value, bin: &[u8]) -> Vec<u8> {
    let mut json = serde_json::to_vec(doc).expect("JSON values serialise");
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    if !bin.is_empty() {
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(bin);
    }
    out
}

/// A `.gltf` document with its buffer inlined as a base64 data URI.
pub fn gltf_with_data_uri(mut doc: Value, bin: &[u8]) -> Vec<u8> {
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bin)
    );
    doc["buffers"][0]["uri"] = json!(uri);
    serde_json::to_vec_pretty(&doc).expect("JSON values serialise")
}
