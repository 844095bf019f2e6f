//! The glTF being written: its top-level arrays as JSON values, one binary buffer, the
//! extensions its parts use, and the binary container (GLB) they are packed into.

use std::collections::BTreeSet;

use serde_json::{Value, json};

/// A glTF document under construction. Indices into each array are final once pushed.
#[derive(Default)]
pub struct Gltf {
    pub nodes: Vec<Value>,
    pub meshes: Vec<Value>,
    pub materials: Vec<Value>,
    pub textures: Vec<Value>,
    pub images: Vec<Value>,
    pub samplers: Vec<Value>,
    pub accessors: Vec<Value>,
    pub buffer_views: Vec<Value>,
    /// The one buffer: the GLB's binary chunk.
    pub bin: Vec<u8>,
    pub extensions_used: BTreeSet<String>,
    pub extensions_required: BTreeSet<String>,
}

/// GLB chunk types.
const JSON_CHUNK: u32 = 0x4E4F_534A;
const BIN_CHUNK: u32 = 0x004E_4942;

/// `glTF` magic, little-endian.
const GLB_MAGIC: u32 = 0x4654_6C67;

impl Gltf {
    /// A buffer view of `bytes`, appended to the binary chunk at a 4-byte boundary (which
    /// keeps every accessor inside aligned to its component size); `stride` and `target` as
    /// the source had them.
    pub fn view(&mut self, bytes: &[u8], stride: Option<&Value>, target: Option<&Value>) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut v = json!({
            "buffer": 0,
            "byteOffset": self.bin.len(),
            "byteLength": bytes.len(),
        });
        if let Some(s) = stride {
            v["byteStride"] = s.clone();
        }
        if let Some(t) = target {
            v["target"] = t.clone();
        }
        self.bin.extend_from_slice(bytes);
        self.buffer_views.push(v);
        self.buffer_views.len() - 1
    }

    /// A tightly packed float accessor of `values`, `width` per element (`VEC3`, `VEC4`).
    pub fn floats(&mut self, values: &[f32], width: usize) -> usize {
        debug_assert!(width == 3 || width == 4);
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, None, None);
        self.accessors.push(json!({
            "bufferView": view,
            "componentType": 5126,
            "count": values.len() / width,
            "type": if width == 3 { "VEC3" } else { "VEC4" },
        }));
        self.accessors.len() - 1
    }

    /// The node `node`, appended; its index.
    pub fn node(&mut self, node: Value) -> usize {
        self.nodes.push(node);
        self.nodes.len() - 1
    }

    /// The binary glTF of everything pushed, with one scene whose roots are `roots`; `None`
    /// if it would pass the 4 GiB a GLB's 32-bit lengths can describe.
    pub fn into_glb(self, generator: &str, roots: &[usize]) -> Option<Vec<u8>> {
        let (root, bin) = self.into_root(generator, roots);
        let mut text = serde_json::to_vec(&Value::Object(root)).expect("JSON values serialise");
        while !text.len().is_multiple_of(4) {
            text.push(b' ');
        }
        let mut chunks = vec![(JSON_CHUNK, text)];
        if !bin.is_empty() {
            chunks.push((BIN_CHUNK, bin));
        }
        let total = 12 + chunks.iter().map(|(_, c)| 8 + c.len()).sum::<usize>();
        let total_u32 = u32::try_from(total).ok()?;
        let mut out = Vec::with_capacity(total);
        out.extend(GLB_MAGIC.to_le_bytes());
        out.extend(2u32.to_le_bytes());
        out.extend(total_u32.to_le_bytes());
        for (kind, data) in chunks {
            // Each chunk is shorter than the total, which fits.
            out.extend((data.len() as u32).to_le_bytes());
            out.extend(kind.to_le_bytes());
            out.extend(data);
        }
        Some(out)
    }

    /// The same document as a `.gltf` text: the JSON the GLB holds, its buffer inline as a
    /// base64 data URI (one self-contained file, as a `.glb` is).
    pub fn into_text(self, generator: &str, roots: &[usize]) -> Vec<u8> {
        use base64::Engine as _;
        let (mut root, bin) = self.into_root(generator, roots);
        if let Some(Value::Array(buffers)) = root.get_mut("buffers") {
            buffers[0]["uri"] = json!(format!(
                "data:application/octet-stream;base64,{}",
                base64::engine::general_purpose::STANDARD.encode(&bin)
            ));
        }
        serde_json::to_vec(&Value::Object(root)).expect("JSON values serialise")
    }

    /// The document's JSON root (one buffer, without a URI) and that buffer, padded to 4 bytes.
    fn into_root(
        mut self,
        generator: &str,
        roots: &[usize],
    ) -> (serde_json::Map<String, Value>, Vec<u8>) {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut root = serde_json::Map::new();
        root.insert(
            "asset".into(),
            json!({ "version": "2.0", "generator": generator }),
        );
        root.insert("scene".into(), json!(0));
        // A scene's node list may not be empty: an empty forest is a scene without one.
        let scene = if roots.is_empty() {
            json!({ "name": "forest" })
        } else {
            json!({ "name": "forest", "nodes": roots })
        };
        root.insert("scenes".into(), json!([scene]));
        let arrays = [
            ("nodes", self.nodes),
            ("meshes", self.meshes),
            ("materials", self.materials),
            ("textures", self.textures),
            ("images", self.images),
            ("samplers", self.samplers),
            ("accessors", self.accessors),
            ("bufferViews", self.buffer_views),
        ];
        for (name, array) in arrays {
            if !array.is_empty() {
                root.insert(name.into(), Value::Array(array));
            }
        }
        if !self.bin.is_empty() {
            root.insert("buffers".into(), json!([{ "byteLength": self.bin.len() }]));
        }
        for (name, set) in [
            ("extensionsUsed", &self.extensions_used),
            ("extensionsRequired", &self.extensions_required),
        ] {
            if !set.is_empty() {
                root.insert(name.into(), json!(set));
            }
        }
        (root, self.bin)
    }
}

/// Every extension name a JSON value uses: the keys of each `extensions` object inside it.
pub fn collect_extensions(value: &Value, used: &mut BTreeSet<String>) {
    match value {
        Value::Object(map) => {
            for (k, v) in map {
                if k == "extensions"
                    && let Value::Object(e) = v
                {
                    used.extend(e.keys().cloned());
                }
                collect_extensions(v, used);
            }
        }
        Value::Array(a) => a.iter().for_each(|v| collect_extensions(v, used)),
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The container: header, a JSON chunk padded with spaces and a binary chunk with zeros,
    /// both to 4 bytes, and the declared lengths those of the file and its chunks.
    #[test]
    fn a_glb_has_aligned_chunks_and_true_lengths() {
        let mut g = Gltf::default();
        g.view(&[1, 2, 3], None, None);
        g.floats(&[1.0, 2.0, 3.0], 3);
        let glb = g.into_glb("test", &[]).unwrap();
        let u32_at = |at: usize| u32::from_le_bytes(glb[at..at + 4].try_into().unwrap());
        assert_eq!(&glb[..4], b"glTF");
        assert_eq!(u32_at(4), 2);
        assert_eq!(u32_at(8) as usize, glb.len());
        let json_len = u32_at(12) as usize;
        assert_eq!(json_len % 4, 0);
        assert_eq!(u32_at(16), JSON_CHUNK);
        let bin_at = 20 + json_len;
        assert_eq!(u32_at(bin_at + 4), BIN_CHUNK);
        let bin_len = u32_at(bin_at) as usize;
        assert_eq!(bin_len, 16, "3 bytes, 1 of padding, 12 of floats");
        let json: Value = serde_json::from_slice(&glb[20..bin_at]).unwrap();
        assert_eq!(json["bufferViews"][1]["byteOffset"], 4);
        assert_eq!(json["buffers"][0]["byteLength"], 16);
        assert_eq!(bin_at + 8 + bin_len, glb.len());
    }
}
