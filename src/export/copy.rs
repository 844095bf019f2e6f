//! Copies the meshes a model's default scene draws into the glTF being written, with everything
//! they reach (accessors, buffer views, materials, textures, samplers, images), each once and
//! renumbered. The JSON objects are copied as they are, with only their indices remapped and
//! their data moved into the one binary buffer, so materials (alpha masks, texture transforms,
//! normal maps, material extensions) arrive as the model's author made them.
//!
//! Not copied: skins (and the joint attributes that need them), animations, cameras and
//! lights — a forest's trees stand still. Each is dropped with a warning.

use std::collections::HashMap;

use serde_json::Value;

use super::glb::{Gltf, collect_extensions};
use crate::import::{ImportError, MeshNode, RawGltf};

/// The extension that gives a primitive several materials to choose from by name: its
/// choices name materials of the source file's root list, which is not copied.
const VARIANTS: &str = "KHR_materials_variants";

/// A mesh of the model, copied: its index in the output, and where the model puts it.
pub struct CopiedMesh {
    pub mesh: usize,
    pub placed: MeshNode,
    /// The node's name, else the mesh's.
    pub name: Option<String>,
}

/// The source's indices already copied, per array.
#[derive(Default)]
struct Maps {
    meshes: HashMap<usize, usize>,
    accessors: HashMap<usize, usize>,
    views: HashMap<usize, usize>,
    materials: HashMap<usize, usize>,
    textures: HashMap<usize, usize>,
    images: HashMap<usize, usize>,
    samplers: HashMap<usize, usize>,
}

struct Copier<'a> {
    raw: &'a mut RawGltf,
    out: &'a mut Gltf,
    maps: Maps,
}

/// Copies every mesh `raw`'s default scene draws into `out`. A node the scene reaches twice
/// with the same transform (as Kenney's exports list a child among the roots) is kept once.
pub fn copy_model(raw: &mut RawGltf, out: &mut Gltf) -> Result<Vec<CopiedMesh>, ImportError> {
    warn_dropped(raw);
    let mut placed: Vec<MeshNode> = Vec::new();
    for m in raw.mesh_nodes.clone() {
        if !placed
            .iter()
            .any(|p| p.mesh == m.mesh && p.world == m.world)
        {
            placed.push(m);
        }
    }
    let mut copier = Copier {
        raw,
        out,
        maps: Maps::default(),
    };
    let mut copied = Vec::new();
    for p in placed {
        let mesh = copier.mesh(p.mesh)?;
        let json = &copier.raw.json;
        let name = [&json["nodes"][p.node], &json["meshes"][p.mesh]]
            .iter()
            .find_map(|o| o["name"].as_str().map(str::to_string));
        copied.push(CopiedMesh {
            mesh,
            placed: p,
            name,
        });
    }
    copier.carry_root_extensions();
    Ok(copied)
}

/// Warns of the parts of the model that are not copied.
fn warn_dropped(raw: &mut RawGltf) {
    let count = |key: &str| raw.json[key].as_array().map_or(0, Vec::len);
    let mut dropped = Vec::new();
    for (key, what) in [
        ("skins", "skins"),
        ("animations", "animations"),
        ("cameras", "cameras"),
    ] {
        if count(key) > 0 {
            dropped.push(what);
        }
    }
    if raw.json["extensions"]["KHR_lights_punctual"].is_object() {
        dropped.push("lights");
    }
    if !dropped.is_empty() {
        let message = format!(
            "{}: its {} are not exported (the meshes are, in their rest pose)",
            raw.path().display(),
            dropped.join(", ")
        );
        raw.warn(message);
    }
}

/// The index a JSON value holds, if it is one.
fn index_of(v: &Value) -> Option<usize> {
    v.as_u64().and_then(|i| usize::try_from(i).ok())
}

impl Copier<'_> {
    fn invalid(&self, field: String, message: String) -> ImportError {
        ImportError::invalid(self.raw.path(), field, message)
    }

    /// `array[i]` of the source, or an error naming the reference `field` that asked for it.
    fn source(&self, array: &str, i: usize, field: &str) -> Result<Value, ImportError> {
        self.raw.json[array]
            .as_array()
            .and_then(|a| a.get(i))
            .cloned()
            .ok_or_else(|| self.invalid(field.to_string(), format!("{array}[{i}] does not exist")))
    }

    /// Remaps the index at `value[key]` (if present) with `copy`.
    fn remap(
        &mut self,
        value: &mut Value,
        key: &str,
        field: &str,
        copy: fn(&mut Self, usize, &str) -> Result<usize, ImportError>,
    ) -> Result<(), ImportError> {
        let Some(v) = value.get(key) else {
            return Ok(());
        };
        let field = format!("{field}.{key}");
        let i = index_of(v)
            .ok_or_else(|| self.invalid(field.clone(), "is not an index".to_string()))?;
        value[key] = Value::from(copy(self, i, &field)?);
        Ok(())
    }

    fn mesh(&mut self, i: usize) -> Result<usize, ImportError> {
        if let Some(&o) = self.maps.meshes.get(&i) {
            return Ok(o);
        }
        let field = format!("meshes[{i}]");
        let mut mesh = self.source("meshes", i, &field)?;
        let Some(primitives) = mesh["primitives"].as_array_mut().map(std::mem::take) else {
            return Err(self.invalid(field, "has no primitives".to_string()));
        };
        let mut copied = Vec::with_capacity(primitives.len());
        for (p, mut prim) in primitives.into_iter().enumerate() {
            let field = format!("{field}.primitives[{p}]");
            if let Some(attributes) = prim["attributes"].as_object_mut() {
                // Joints and weights move vertices with a skin, which is not copied.
                attributes.retain(|k, _| !k.starts_with("JOINTS_") && !k.starts_with("WEIGHTS_"));
            }
            let names: Vec<String> = prim["attributes"]
                .as_object()
                .map(|a| a.keys().cloned().collect())
                .unwrap_or_default();
            for name in names {
                let f = format!("{field}.attributes");
                self.remap(&mut prim["attributes"], &name, &f, Self::accessor)?;
            }
            self.remap(&mut prim, "indices", &field, Self::accessor)?;
            self.remap(&mut prim, "material", &field, Self::material)?;
            if let Some(targets) = prim["targets"].as_array().cloned() {
                let mut out = Vec::new();
                for (t, mut target) in targets.into_iter().enumerate() {
                    let names: Vec<String> = target
                        .as_object()
                        .map(|a| a.keys().cloned().collect())
                        .unwrap_or_default();
                    for name in names {
                        let f = format!("{field}.targets[{t}]");
                        self.remap(&mut target, &name, &f, Self::accessor)?;
                    }
                    out.push(target);
                }
                prim["targets"] = Value::Array(out);
            }
            if let Some(e) = prim.get_mut("extensions").and_then(Value::as_object_mut)
                && e.remove(VARIANTS).is_some()
            {
                let message = format!(
                    "{}: {field}: {VARIANTS} is not exported (the default material is)",
                    self.raw.path().display()
                );
                self.raw.warn(message);
            }
            copied.push(prim);
        }
        mesh["primitives"] = Value::Array(copied);
        collect_extensions(&mesh, &mut self.out.extensions_used);
        self.out.meshes.push(mesh);
        let o = self.out.meshes.len() - 1;
        self.maps.meshes.insert(i, o);
        Ok(o)
    }

    fn accessor(&mut self, i: usize, field: &str) -> Result<usize, ImportError> {
        if let Some(&o) = self.maps.accessors.get(&i) {
            return Ok(o);
        }
        let mut a = self.source("accessors", i, field)?;
        let f = format!("accessors[{i}]");
        self.remap(&mut a, "bufferView", &f, Self::view)?;
        for part in ["indices", "values"] {
            if a["sparse"][part].is_object() {
                let f = format!("{f}.sparse.{part}");
                self.remap(&mut a["sparse"][part], "bufferView", &f, Self::view)?;
            }
        }
        collect_extensions(&a, &mut self.out.extensions_used);
        self.out.accessors.push(a);
        let o = self.out.accessors.len() - 1;
        self.maps.accessors.insert(i, o);
        Ok(o)
    }

    /// A buffer view's bytes, moved into the output's buffer.
    fn view(&mut self, i: usize, field: &str) -> Result<usize, ImportError> {
        if let Some(&o) = self.maps.views.get(&i) {
            return Ok(o);
        }
        let v = self.source("bufferViews", i, field)?;
        let f = format!("bufferViews[{i}]");
        let number = |key: &str, default: Option<u64>| {
            v.get(key).map_or(default, Value::as_u64).ok_or_else(|| {
                self.invalid(format!("{f}.{key}"), "is missing or not a count".into())
            })
        };
        let (buffer, offset, length) = (
            number("buffer", None)?,
            number("byteOffset", Some(0))?,
            number("byteLength", None)?,
        );
        let buffer = usize::try_from(buffer).unwrap_or(usize::MAX);
        let bytes = self.raw.buffer(buffer, &format!("{f}.buffer"))?;
        let end = offset.saturating_add(length);
        let Some(slice) = usize::try_from(offset)
            .ok()
            .zip(usize::try_from(end).ok())
            .and_then(|(a, b)| bytes.get(a..b))
        else {
            let n = bytes.len();
            return Err(self.invalid(
                f,
                format!("bytes {offset}..{end} run past the end of buffer {buffer} ({n} bytes)"),
            ));
        };
        let slice = slice.to_vec();
        let o = self.out.view(&slice, v.get("byteStride"), v.get("target"));
        if let Some(name) = v.get("name") {
            self.out.buffer_views[o]["name"] = name.clone();
        }
        self.maps.views.insert(i, o);
        Ok(o)
    }

    fn material(&mut self, i: usize, field: &str) -> Result<usize, ImportError> {
        if let Some(&o) = self.maps.materials.get(&i) {
            return Ok(o);
        }
        let mut m = self.source("materials", i, field)?;
        self.texture_infos(&mut m, &format!("materials[{i}]"))?;
        collect_extensions(&m, &mut self.out.extensions_used);
        self.out.materials.push(m);
        let o = self.out.materials.len() - 1;
        self.maps.materials.insert(i, o);
        Ok(o)
    }

    /// Remaps every texture reference inside a material: each object under a key ending in
    /// `Texture` (`baseColorTexture`, `normalTexture`, the material extensions' textures).
    fn texture_infos(&mut self, value: &mut Value, field: &str) -> Result<(), ImportError> {
        let Some(map) = value.as_object_mut() else {
            return Ok(());
        };
        let keys: Vec<String> = map.keys().cloned().collect();
        for k in keys {
            let f = format!("{field}.{k}");
            let child = &mut value[&k];
            if k.ends_with("Texture") && child.get("index").is_some() {
                self.remap(child, "index", &f, Self::texture)?;
            }
            self.texture_infos(child, &f)?;
        }
        Ok(())
    }

    fn texture(&mut self, i: usize, field: &str) -> Result<usize, ImportError> {
        if let Some(&o) = self.maps.textures.get(&i) {
            return Ok(o);
        }
        let mut t = self.source("textures", i, field)?;
        let f = format!("textures[{i}]");
        self.remap(&mut t, "sampler", &f, Self::sampler)?;
        self.remap(&mut t, "source", &f, Self::image)?;
        // Image formats by extension (EXT_texture_webp, KHR_texture_basisu): their `source`.
        let names: Vec<String> = t["extensions"]
            .as_object()
            .map(|e| e.keys().cloned().collect())
            .unwrap_or_default();
        for name in names {
            let f = format!("{f}.extensions.{name}");
            self.remap(&mut t["extensions"][&name], "source", &f, Self::image)?;
        }
        collect_extensions(&t, &mut self.out.extensions_used);
        self.out.textures.push(t);
        let o = self.out.textures.len() - 1;
        self.maps.textures.insert(i, o);
        Ok(o)
    }

    fn sampler(&mut self, i: usize, field: &str) -> Result<usize, ImportError> {
        if let Some(&o) = self.maps.samplers.get(&i) {
            return Ok(o);
        }
        let s = self.source("samplers", i, field)?;
        collect_extensions(&s, &mut self.out.extensions_used);
        self.out.samplers.push(s);
        let o = self.out.samplers.len() - 1;
        self.maps.samplers.insert(i, o);
        Ok(o)
    }

    /// An image, embedded: a file or data URI becomes a buffer view with its MIME type.
    fn image(&mut self, i: usize, field: &str) -> Result<usize, ImportError> {
        if let Some(&o) = self.maps.images.get(&i) {
            return Ok(o);
        }
        let mut image = self.source("images", i, field)?;
        let f = format!("images[{i}]");
        if let Some(uri) = image.get("uri").and_then(Value::as_str).map(str::to_string) {
            let bytes = self.raw.uri(&uri, &format!("{f}.uri"))?;
            let mime = match sniff(&bytes) {
                Some(m) => m.to_string(),
                None => match image.get("mimeType").and_then(Value::as_str) {
                    Some(m) => m.to_string(),
                    None => {
                        return Err(self.invalid(
                            format!("{f}.uri"),
                            format!("{uri:?} is not a PNG, JPEG, WebP or KTX2 image"),
                        ));
                    }
                },
            };
            let object = image.as_object_mut().expect("source() found an object");
            object.remove("uri");
            object.insert("mimeType".into(), Value::from(mime));
            object.insert(
                "bufferView".into(),
                Value::from(self.out.view(&bytes, None, None)),
            );
        } else {
            self.remap(&mut image, "bufferView", &f, Self::view)?;
        }
        collect_extensions(&image, &mut self.out.extensions_used);
        self.out.images.push(image);
        let o = self.out.images.len() - 1;
        self.maps.images.insert(i, o);
        Ok(o)
    }

    /// The source's required extensions that the copied parts use, and quantized attributes
    /// (which no `extensions` object marks) where the source declares them.
    fn carry_root_extensions(&mut self) {
        let list = |key: &str| -> Vec<String> {
            self.raw.json[key]
                .as_array()
                .map(|a| {
                    a.iter()
                        .filter_map(|s| s.as_str().map(str::to_string))
                        .collect()
                })
                .unwrap_or_default()
        };
        let (used, required) = (list("extensionsUsed"), list("extensionsRequired"));
        let quantized = "KHR_mesh_quantization";
        if used.iter().any(|e| e == quantized) && !self.maps.meshes.is_empty() {
            self.out.extensions_used.insert(quantized.to_string());
        }
        for e in required {
            if self.out.extensions_used.contains(&e) {
                self.out.extensions_required.insert(e);
            }
        }
    }
}

/// The MIME type image bytes announce by their signature.
fn sniff(bytes: &[u8]) -> Option<&'static str> {
    if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
        Some("image/png")
    } else if bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        Some("image/jpeg")
    } else if bytes.len() >= 12 && &bytes[..4] == b"RIFF" && &bytes[8..12] == b"WEBP" {
        Some("image/webp")
    } else if bytes.starts_with(b"\xABKTX 20\xBB") {
        Some("image/ktx2")
    } else {
        None
    }
}
