//! A glTF file as data to copy rather than to draw: its JSON as read, its buffers and images'
//! bytes, and where its default scene puts each mesh. `texel export` copies a tree model's
//! meshes, materials and textures into another file from this, index by index, so nothing is
//! re-encoded and nothing the importer does not model (normal maps, extensions) is lost.
//!
//! The scene is walked exactly as [`super::load`] flattens it: the same roots, the same
//! transforms, the same refusals (missing nodes or meshes, cycles, transforms that are not
//! finite), so a mesh placed from [`MeshNode::world`] lands where the baked mesh lies.

use std::path::{Path, PathBuf};

use glam::DMat4;

use super::ImportError;
use super::document::{self, Document};
use super::scene::{local_transform, scene_roots};
use crate::limits::Limits;
use crate::provenance::Source;

/// Deeper hierarchies than this are refused, as the importer refuses them.
const MAX_DEPTH: usize = 256;

/// A mesh where the default scene draws it.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshNode {
    /// Index of the node in the file.
    pub node: usize,
    pub mesh: usize,
    /// Model space from the mesh's space: every transform from the scene's root down to and
    /// including the node's own.
    pub world: DMat4,
}

/// A glTF file opened for copying.
pub struct RawGltf {
    doc: Document,
    /// The JSON, as in the file (of a `.glb`, its JSON chunk).
    pub json: serde_json::Value,
    /// Each mesh the default scene draws, in the order the importer meets them (a node the
    /// scene reaches twice is listed twice).
    pub mesh_nodes: Vec<MeshNode>,
}

impl RawGltf {
    /// Reads a `.gltf` or `.glb` file (not yet its external buffers and images) and walks its
    /// default scene.
    pub fn open(path: &Path, limits: &Limits) -> Result<RawGltf, ImportError> {
        let bytes = document::read_gltf(path)?;
        let json_bytes = if bytes.starts_with(b"glTF") {
            document::split_glb(path, &bytes)?.0.to_vec()
        } else {
            bytes.clone()
        };
        let mut doc = Document::parse(path, bytes)?;
        doc.limits = *limits;
        let text = json_bytes
            .strip_prefix(b"\xEF\xBB\xBF")
            .unwrap_or(&json_bytes);
        let json: serde_json::Value = serde_json::from_slice(text)
            .map_err(|e| ImportError::invalid(path, "", format!("not valid JSON: {e}")))?;
        let mesh_nodes = mesh_nodes(&doc)?;
        Ok(RawGltf {
            doc,
            json,
            mesh_nodes,
        })
    }

    pub fn path(&self) -> &Path {
        &self.doc.path
    }

    /// The bytes of `buffers[index]` (the `.glb` binary chunk, a data URI or a file beside
    /// the model), read on first use; `field` names the reference in errors.
    pub fn buffer(&mut self, index: usize, field: &str) -> Result<&[u8], ImportError> {
        self.doc.buffer(index, field)
    }

    /// The bytes an image's `uri` names (a data URI or a file beside the model).
    pub fn uri(&mut self, uri: &str, field: &str) -> Result<Vec<u8>, ImportError> {
        self.doc.resolve_uri(uri, field, crate::input::MAX_GLTF)
    }

    /// Every file read so far: the glTF first.
    pub fn sources(&self) -> &[Source<PathBuf>] {
        &self.doc.sources
    }

    /// Things skipped or ignored that a user may want to know about.
    pub fn warnings(&self) -> &[String] {
        &self.doc.warnings
    }

    pub fn warn(&mut self, message: String) {
        self.doc.warn(message);
    }
}

/// The meshes of the default scene and their transforms, walked as `scene::flatten` walks.
fn mesh_nodes(doc: &Document) -> Result<Vec<MeshNode>, ImportError> {
    let mut out = Vec::new();
    let mut on_path = vec![false; doc.root.nodes.len()];
    for (i, node) in scene_roots(doc)?.into_iter().enumerate() {
        visit(
            doc,
            node,
            DMat4::IDENTITY,
            &mut on_path,
            0,
            &format!("scene.nodes[{i}]"),
            &mut out,
        )?;
    }
    Ok(out)
}

fn visit(
    doc: &Document,
    index: usize,
    parent: DMat4,
    on_path: &mut [bool],
    depth: usize,
    field: &str,
    out: &mut Vec<MeshNode>,
) -> Result<(), ImportError> {
    let path = &doc.path;
    let Some(node) = doc.root.nodes.get(index) else {
        return Err(ImportError::invalid(
            path,
            field,
            format!("node {index} does not exist"),
        ));
    };
    if on_path[index] || depth > MAX_DEPTH {
        return Err(ImportError::invalid(
            path,
            format!("nodes[{index}].children"),
            "the node hierarchy is cyclic or deeper than 256 levels",
        ));
    }
    let world = parent * local_transform(node);
    if !world.is_finite() {
        return Err(ImportError::invalid(
            path,
            format!("nodes[{index}]"),
            "transform is not finite",
        ));
    }
    if let Some(mesh) = node.mesh.map(|m| m.value()) {
        if mesh >= doc.root.meshes.len() {
            return Err(ImportError::invalid(
                path,
                format!("nodes[{index}].mesh"),
                format!("mesh {mesh} does not exist"),
            ));
        }
        out.push(MeshNode {
            node: index,
            mesh,
            world,
        });
    }
    on_path[index] = true;
    for (i, child) in node.children.iter().flatten().enumerate() {
        visit(
            doc,
            child.value(),
            world,
            on_path,
            depth + 1,
            &format!("nodes[{index}].children[{i}]"),
            out,
        )?;
    }
    on_path[index] = false;
    Ok(())
}
