//! The glTF container: `.glb` chunks or `.gltf` JSON, the extension policy, and the buffers and
//! images the JSON points at (embedded, data URIs or files beside the model), each read once.

use std::path::{Path, PathBuf};

use base64::Engine as _;
use gltf_json as json;

use super::ImportError;
use crate::input::{self, InputError, MAX_GLTF};
use crate::limits::Limits;
use crate::provenance::{Source, sha256};

/// Extensions that change geometry or data layout and that we cannot decode.
const COMPRESSION_EXTENSIONS: &[&str] = &[
    "KHR_draco_mesh_compression",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
];

/// Required extensions we honour or may safely ignore for a volume bake: texture transforms and
/// quantized attributes are decoded; material extensions only change shading we do not model.
const TOLERATED_REQUIRED: &[&str] = &[
    "KHR_texture_transform",
    "KHR_mesh_quantization",
    "KHR_materials_unlit",
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_materials_clearcoat",
    "KHR_materials_sheen",
    "KHR_materials_iridescence",
    "KHR_materials_anisotropy",
    "KHR_materials_dispersion",
    "KHR_materials_variants",
    "KHR_lights_punctual",
];

/// Bytes a buffer file may have beyond its declared `byteLength` (padding).
const BUFFER_SLACK: u64 = 1 << 16;

/// Largest JSON chunk we parse; real tree assets are kilobytes.
const MAX_JSON_BYTES: usize = 256 << 20;

pub(super) struct Document {
    pub path: PathBuf,
    pub root: json::Root,
    /// The `.glb` binary chunk, which `buffers[0]` refers to when it has no URI.
    glb_bin: Option<Vec<u8>>,
    buffers: Vec<Option<Vec<u8>>>,
    pub sources: Vec<Source<PathBuf>>,
    pub warnings: Vec<String>,
    pub limits: Limits,
    /// Values of accessors without a bufferView (zeros, with sparse substitutions) decoded so
    /// far: memory no byte of the input stands for, bounded by [`MAX_UNBACKED_VALUES`].
    pub unbacked_values: u64,
    /// Pixels of images decoded so far, bounded in all by `--max-pixels`.
    pub pixels_decoded: u64,
    /// Images decoded so far, by index.
    pub images: std::collections::HashMap<usize, super::image::Decoded>,
}

/// Accessor values a file may ask for without the bytes to hold them (accessors without a
/// bufferView read as zeros): 16.8 million, 128 MiB decoded. Tree models use none, or a few
/// for sparse edits; a 1.3 KB file of such accessors shared by several primitives took 5.7 GB.
pub const MAX_UNBACKED_VALUES: u64 = 1 << 24;

fn from_input(e: InputError) -> ImportError {
    match e {
        InputError::Io { path, source } => ImportError::Io { file: path, source },
        InputError::TooLarge { path, limit, what } => ImportError::unsupported(
            &path,
            "",
            format!("larger than the {limit} bytes a {what} may have"),
        ),
    }
}

/// A glTF file, read no further than its first bytes when they say it is not glTF (a binary
/// `glTF` header, or JSON's `{` after any byte-order mark and white space), and no further than
/// its declared length when it is a `.glb`.
pub(super) fn read_gltf(path: &Path) -> Result<Vec<u8>, ImportError> {
    let bytes = input::read_framed(path, 12, |head| {
        if head.starts_with(b"glTF") && head.len() >= 12 {
            let length = u32::from_le_bytes([head[8], head[9], head[10], head[11]]);
            return Some(u64::from(length).min(MAX_GLTF));
        }
        let text = head.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(head);
        let first = text.iter().find(|b| !b.is_ascii_whitespace());
        matches!(first, None | Some(b'{')).then_some(MAX_GLTF)
    })
    .map_err(from_input)?;
    if bytes.len() as u64 > MAX_GLTF {
        return Err(from_input(InputError::TooLarge {
            path: path.to_path_buf(),
            limit: MAX_GLTF,
            what: "glTF file",
        }));
    }
    Ok(bytes)
}

impl Document {
    pub fn open(path: &Path, limits: &Limits) -> Result<Document, ImportError> {
        let bytes = read_gltf(path)?;
        let mut doc = Document::parse(path, bytes)?;
        doc.limits = *limits;
        Ok(doc)
    }

    /// A document from the bytes of the file at `path` (which names it in errors and anchors
    /// its relative URIs), within the default limits.
    pub fn parse(path: &Path, bytes: Vec<u8>) -> Result<Document, ImportError> {
        let source = Source {
            path: path.to_path_buf(),
            sha256: sha256(&bytes),
            bytes: bytes.len() as u64,
        };
        let (json_bytes, glb_bin) = if bytes.starts_with(b"glTF") {
            split_glb(path, &bytes)?
        } else {
            let text = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(&bytes);
            if text.iter().find(|b| !b.is_ascii_whitespace()) != Some(&b'{') {
                return Err(ImportError::invalid(
                    path,
                    "",
                    "not a glTF file: it starts with neither the binary glTF header nor JSON",
                ));
            }
            (bytes.as_slice(), None)
        };
        if json_bytes.len() > MAX_JSON_BYTES {
            return Err(ImportError::unsupported(
                path,
                "",
                "JSON larger than 256 MiB",
            ));
        }
        check_extensions(path, json_bytes)?;
        let root = parse_root(path, json_bytes)?;
        if !root.asset.version.starts_with("2.") {
            return Err(ImportError::unsupported(
                path,
                "asset.version",
                format!("glTF version {} (only 2.x is read)", root.asset.version),
            ));
        }
        let glb_bin = glb_bin.map(<[u8]>::to_vec);
        let buffers = vec![None; root.buffers.len()];
        let mut warnings = Vec::new();
        if root
            .extensions_used
            .iter()
            .any(|e| e == "EXT_mesh_gpu_instancing")
        {
            warnings.push(format!(
                "{}: EXT_mesh_gpu_instancing is ignored (each node is baked once)",
                path.display()
            ));
        }
        Ok(Document {
            path: path.to_path_buf(),
            root,
            glb_bin,
            buffers,
            sources: vec![source],
            warnings,
            limits: Limits::default(),
            unbacked_values: 0,
            pixels_decoded: 0,
            images: Default::default(),
        })
    }

    pub fn warn(&mut self, message: String) {
        if !self.warnings.contains(&message) {
            self.warnings.push(message);
        }
    }

    /// The bytes of `buffers[index]`, loaded on first use.
    pub fn buffer(&mut self, index: usize, field: &str) -> Result<&[u8], ImportError> {
        let Some(spec) = self.root.buffers.get(index) else {
            return Err(ImportError::invalid(
                &self.path,
                field,
                format!(
                    "buffer {index} does not exist ({} buffers)",
                    self.root.buffers.len()
                ),
            ));
        };
        if self.buffers[index].is_none() {
            let (uri, declared) = (spec.uri.clone(), spec.byte_length.0);
            let where_ = format!("buffers[{index}]");
            // What the buffers read so far hold, and this one would add: a file that names
            // `/dev/zero` or a FIFO with a huge byteLength must not be read without end.
            let held: u64 = self.buffers.iter().flatten().map(|b| b.len() as u64).sum();
            if declared.saturating_add(held) > MAX_GLTF {
                return Err(ImportError::unsupported(
                    &self.path,
                    format!("{where_}.byteLength"),
                    format!(
                        "declares {declared} bytes; with the {held} bytes of the buffers before it, \
                         more than the {MAX_GLTF} bytes a glTF's buffers may hold in all"
                    ),
                ));
            }
            let data = match &uri {
                None => match (index, &self.glb_bin) {
                    (0, Some(_)) => self.glb_bin.take().unwrap_or_default(),
                    _ => {
                        return Err(ImportError::invalid(
                            &self.path,
                            &where_,
                            "has no uri and is not the GLB binary chunk",
                        ));
                    }
                },
                // A buffer file may be padded a little past its byteLength, no more.
                Some(uri) => {
                    self.resolve_uri(uri, &where_, declared.saturating_add(BUFFER_SLACK))?
                }
            };
            if (data.len() as u64) < declared {
                return Err(ImportError::invalid(
                    &self.path,
                    format!("{where_}.byteLength"),
                    format!(
                        "declares {declared} bytes but only {} are present",
                        data.len()
                    ),
                ));
            }
            self.buffers[index] = Some(data);
        }
        Ok(self.buffers[index].as_deref().unwrap_or_default())
    }

    /// Reads a data URI or a file relative to the glTF. Network and absolute URIs are refused:
    /// a build step must not read outside what its inputs name.
    pub fn resolve_uri(
        &mut self,
        uri: &str,
        field: &str,
        limit: u64,
    ) -> Result<Vec<u8>, ImportError> {
        if let Some(rest) = uri.strip_prefix("data:") {
            let Some((_, payload)) = rest.split_once(";base64,") else {
                return Err(ImportError::unsupported(
                    &self.path,
                    field,
                    "data URI is not base64-encoded",
                ));
            };
            return base64::engine::general_purpose::STANDARD
                .decode(payload.trim())
                .map_err(|e| {
                    ImportError::invalid(&self.path, field, format!("bad base64 data URI: {e}"))
                });
        }
        if uri.contains("://") || uri.starts_with('/') || uri.starts_with('\\') || uri.contains(':')
        {
            return Err(ImportError::unsupported(
                &self.path,
                field,
                format!(
                    "URI {uri:?} is not a relative path (network and absolute URIs are refused)"
                ),
            ));
        }
        let decoded = percent_encoding::percent_decode_str(uri)
            .decode_utf8()
            .map_err(|_| ImportError::invalid(&self.path, field, "URI is not valid UTF-8"))?;
        let file = self
            .path
            .parent()
            .unwrap_or(Path::new(""))
            .join(decoded.as_ref());
        let bytes = input::read_bounded(&file, limit, "file").map_err(|e| match e {
            InputError::Io { source, .. } => ImportError::invalid(
                &self.path,
                field,
                format!("cannot read {}: {source}", file.display()),
            ),
            InputError::TooLarge { limit, .. } => ImportError::invalid(
                &self.path,
                field,
                format!(
                    "{} holds more than the {limit} bytes it may",
                    file.display()
                ),
            ),
        })?;
        if !self.sources.iter().any(|s| s.path == file) {
            self.sources.push(Source {
                path: file,
                sha256: sha256(&bytes),
                bytes: bytes.len() as u64,
            });
        }
        Ok(bytes)
    }
}

/// Splits a binary glTF into its JSON chunk and optional BIN chunk.
pub(super) fn split_glb<'a>(
    path: &Path,
    bytes: &'a [u8],
) -> Result<(&'a [u8], Option<&'a [u8]>), ImportError> {
    let u32_at = |at: usize| -> Option<u32> {
        bytes
            .get(at..at + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let bad = |message: &str| ImportError::invalid(path, "GLB", message);
    let version = u32_at(4).ok_or_else(|| bad("truncated header"))?;
    if version != 2 {
        return Err(ImportError::unsupported(
            path,
            "GLB",
            format!("container version {version} (only 2 is read)"),
        ));
    }
    let length = u32_at(8).ok_or_else(|| bad("truncated header"))? as usize;
    if length > bytes.len() {
        return Err(bad(&format!(
            "header says {length} bytes but the file has {} (truncated?)",
            bytes.len()
        )));
    }
    let bytes = &bytes[..length];
    let mut at = 12;
    let mut json_chunk = None;
    let mut bin_chunk = None;
    while at + 8 <= bytes.len() {
        let chunk_len = u32_at(at).ok_or_else(|| bad("truncated chunk header"))? as usize;
        let kind = u32_at(at + 4).ok_or_else(|| bad("truncated chunk header"))?;
        let data = bytes
            .get(at + 8..at + 8 + chunk_len)
            .ok_or_else(|| bad("chunk runs past the end of the file"))?;
        match kind {
            0x4E4F_534A if json_chunk.is_none() => json_chunk = Some(data),
            0x004E_4942 if bin_chunk.is_none() => bin_chunk = Some(data),
            _ => {}
        }
        at += 8 + chunk_len;
    }
    let json_chunk = json_chunk.ok_or_else(|| bad("no JSON chunk"))?;
    Ok((json_chunk, bin_chunk))
}

/// The typed glTF root, with every problem named by its JSON path.
fn parse_root(path: &Path, json_bytes: &[u8]) -> Result<json::Root, ImportError> {
    let not_json =
        |e: serde_json::Error| ImportError::invalid(path, "", format!("not valid JSON: {e}"));
    let mut value: serde_json::Value = serde_json::from_slice(json_bytes).map_err(not_json)?;
    // glTF 2.0 makes `scene.nodes` optional (an empty scene); gltf-json requires it.
    if let Some(scenes) = value.get_mut("scenes").and_then(|s| s.as_array_mut()) {
        for scene in scenes.iter_mut().filter_map(|s| s.as_object_mut()) {
            scene
                .entry("nodes")
                .or_insert_with(|| serde_json::Value::Array(Vec::new()));
        }
    }
    serde_path_to_error::deserialize(value).map_err(|e| {
        let field = e.path().to_string();
        let field = if field == "." { String::new() } else { field };
        ImportError::invalid(
            path,
            field,
            format!("not valid glTF 2.0: {}", e.into_inner()),
        )
    })
}

/// What to do about a compression extension we cannot decode.
fn decompression_advice(extension: &str) -> &'static str {
    if extension.contains("draco") {
        "re-export the model without Draco compression (Blender: untick Compression), or \
         decompress it with `gltf-transform copy`"
    } else {
        "re-run gltfpack without -c/-cc, or decompress the model with `gltf-transform copy`"
    }
}

/// Refuses compressed geometry and other required extensions we cannot honour, before the JSON
/// is parsed into typed structures (whose errors would be far less clear).
fn check_extensions(path: &Path, json_bytes: &[u8]) -> Result<(), ImportError> {
    #[derive(serde::Deserialize, Default)]
    #[serde(default, rename_all = "camelCase")]
    struct Extensions {
        extensions_used: Vec<String>,
        extensions_required: Vec<String>,
    }
    let ext: Extensions = serde_json::from_slice(json_bytes)
        .map_err(|e| ImportError::invalid(path, "", format!("not valid glTF JSON: {e}")))?;
    for name in &ext.extensions_required {
        if COMPRESSION_EXTENSIONS.contains(&name.as_str()) {
            return Err(ImportError::unsupported(
                path,
                "extensionsRequired",
                format!(
                    "mesh compression {name} is not supported; {}",
                    decompression_advice(name)
                ),
            ));
        }
        if !TOLERATED_REQUIRED.contains(&name.as_str()) {
            return Err(ImportError::unsupported(
                path,
                "extensionsRequired",
                format!("required extension {name} is not supported"),
            ));
        }
    }
    Ok(())
}
