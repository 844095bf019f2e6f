//! `texel export`: a placed forest for other tools. A glTF 2.0 (binary, or text with its
//! buffer inline) that places each species' source model once per tree with
//! `EXT_mesh_gpu_instancing`, and tables of the trees (CSV, JSON).
//!
//! The models are the ones the mesh render method draws (the species' main texel's first
//! recorded source, checked against its SHA-256), placed by the renderer's own transform
//! ([`TreeTransform::world_from_model`]): model space is the source's default scene flattened
//! as the importer flattens it (the bake applies no offset or normalisation of its own), then
//! scaled, turned about +Y and moved to the tree's base.
//!
//! How instances compose with the model's node hierarchy: the extension draws a mesh at
//! `NodeWorld * Instance * vertex`, and one node cannot carry a different hierarchy per
//! instance. So each mesh the model's scene draws becomes its own instanced node under
//! identity parents, and its instances carry the whole transform,
//! `tree_from_model * model_from_mesh`, as translation, rotation and scale. That product is a
//! TRS exactly when the mesh's own transform is (the tree's scale is uniform and commutes with
//! any rotation); a model whose hierarchy shears a mesh is refused.

mod copy;
mod glb;
mod load;
mod table;

use glam::{DMat4, DQuat, DVec3};
use serde_json::{Value, json};

pub use self::load::{ExportError, Inputs, load};
pub use self::table::{csv, json_table};

use self::copy::{CopiedMesh, copy_model};
use self::glb::Gltf;
use crate::formats::instances::Forest;
use crate::import::ImportError;
use crate::number::shortest;
use crate::render::Placed;
use crate::render::camera::EYE_LIMIT;

/// The extension that places a mesh many times.
pub const INSTANCING: &str = "EXT_mesh_gpu_instancing";

/// World from model of tree `i` of `forest`, as the renderer places it.
pub fn tree_from_model(forest: &Forest, i: usize) -> DMat4 {
    Placed::of(&forest.instances[i])
        .transform(0, DVec3::ZERO)
        .world_from_model()
}

/// `m` as translation, rotation and scale, if it is one (no shear).
pub fn decompose(m: &DMat4) -> Option<(DVec3, DQuat, DVec3)> {
    let (s, r, t) = m.to_scale_rotation_translation();
    let back = DMat4::from_scale_rotation_translation(s, r, t);
    let size = m.to_cols_array().iter().fold(1.0f64, |a, v| a.max(v.abs()));
    let error = (back - *m)
        .to_cols_array()
        .iter()
        .fold(0.0f64, |a, v| a.max(v.abs()));
    (error <= 1e-9 * size && r.is_finite()).then_some((t, r, s))
}

/// A node's TRS properties, each left out where it is the default.
fn trs_properties(node: &mut Value, (t, r, s): (DVec3, DQuat, DVec3)) {
    if t != DVec3::ZERO {
        node["translation"] = json!(t.as_vec3().to_array());
    }
    if r != DQuat::IDENTITY {
        node["rotation"] = json!(r.as_quat().to_array());
    }
    if s != DVec3::ONE {
        node["scale"] = json!(s.as_vec3().to_array());
    }
}

/// The translation, rotation and scale of a mesh's place in its model; refused where it is
/// not one.
fn check_trs(
    model: &crate::import::RawGltf,
    m: &CopiedMesh,
) -> Result<(DVec3, DQuat, DVec3), ImportError> {
    decompose(&m.placed.world).ok_or_else(|| {
        ImportError::unsupported(
            model.path(),
            format!("nodes[{}]", m.placed.node),
            "the node hierarchy shears this mesh (a non-uniform scale above a rotation): \
             its instances cannot be written as translation, rotation and scale",
        )
    })
}

/// How the glTF is packed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Container {
    /// Binary glTF (`.glb`): the JSON and one binary chunk.
    Glb,
    /// A `.gltf` JSON text, its one buffer inline as a base64 data URI (a third larger).
    Text,
}

impl Container {
    /// What a file name asks for: `.gltf` (any case) the text, anything else the binary.
    pub fn for_path(path: &std::path::Path) -> Container {
        match path.extension() {
            Some(e) if e.eq_ignore_ascii_case("gltf") => Container::Text,
            _ => Container::Glb,
        }
    }
}

/// The glTF of the loaded forest, packed as `container` says: per species with trees, a node
/// whose children are its model's meshes, each instanced once per tree; the terrain beside
/// them where loaded. Warnings about what was left out are added to `warnings`.
pub fn gltf(
    inputs: &mut Inputs,
    container: Container,
    warnings: &mut Vec<String>,
) -> Result<Vec<u8>, ExportError> {
    let mut out = Gltf::default();
    let mut roots = Vec::new();
    let forest = &inputs.forest;
    // Trees lie within 21,000 km of the forest's origin (the format's centimetres in 32 bits),
    // so the origin says whether 32-bit floats, glTF's, can tell them apart.
    let o = forest.info.origin;
    if !forest.instances.is_empty() && o.iter().any(|v| v.abs() > EYE_LIMIT) {
        return Err(ExportError::Mismatch {
            file: inputs.dependencies.first().cloned().unwrap_or_default(),
            message: format!(
                "the forest's origin ({}, {}, {}) lies beyond {EYE_LIMIT:e} m, where glTF's \
                 32-bit floats cannot tell its trees apart",
                shortest(o[0]),
                shortest(o[1]),
                shortest(o[2])
            ),
        });
    }
    // Each model copied once, however many species draw it.
    let mut copied: Vec<Option<Vec<CopiedMesh>>> = inputs.models.iter().map(|_| None).collect();
    let mut trees: Vec<Vec<usize>> = vec![Vec::new(); forest.info.species.len()];
    for (i, t) in forest.instances.iter().enumerate() {
        trees[t.species as usize].push(i);
    }
    let mut species_nodes = Vec::new();
    for (s, record) in forest.info.species.iter().enumerate() {
        let (Some(m), false) = (inputs.species_model[s], trees[s].is_empty()) else {
            continue;
        };
        if copied[m].is_none() {
            let model = &mut inputs.models[m];
            let meshes = copy_model(model, &mut out).map_err(ExportError::from)?;
            for mesh in &meshes {
                check_trs(model, mesh)?;
            }
            copied[m] = Some(meshes);
        }
        let mut children = Vec::new();
        for (k, mesh) in copied[m].iter().flatten().enumerate() {
            let n = trees[s].len();
            let (mut t, mut r, mut sc) = (
                Vec::with_capacity(3 * n),
                Vec::with_capacity(4 * n),
                Vec::with_capacity(3 * n),
            );
            for &i in &trees[s] {
                let world = tree_from_model(forest, i) * mesh.placed.world;
                let (tt, rr, ss) = decompose(&world).ok_or_else(|| {
                    ExportError::from(ImportError::unsupported(
                        inputs.models[m].path(),
                        format!("nodes[{}]", mesh.placed.node),
                        "this mesh's transform cannot be written as translation, rotation \
                         and scale",
                    ))
                })?;
                t.extend(tt.as_vec3().to_array());
                r.extend(rr.normalize().as_quat().to_array());
                sc.extend(ss.as_vec3().to_array());
            }
            let attributes = json!({
                "TRANSLATION": out.floats(&t, 3),
                "ROTATION": out.floats(&r, 4),
                "SCALE": out.floats(&sc, 3),
            });
            let name = match &mesh.name {
                Some(n) => format!("{}/{n}", record.name),
                None => format!("{}/mesh {k}", record.name),
            };
            children.push(out.node(json!({
                "name": name,
                "mesh": mesh.mesh,
                "extensions": { INSTANCING: { "attributes": attributes } },
            })));
        }
        species_nodes.push(out.node(json!({ "name": record.name, "children": children })));
    }
    if !species_nodes.is_empty() {
        out.extensions_used.insert(INSTANCING.to_string());
        out.extensions_required.insert(INSTANCING.to_string());
        roots.push(out.node(json!({ "name": "trees", "children": species_nodes })));
    }
    if let Some(terrain) = inputs.terrain.as_mut() {
        let meshes = copy_model(terrain, &mut out).map_err(ExportError::from)?;
        let mut children = Vec::new();
        for mesh in &meshes {
            let trs = check_trs(terrain, mesh)?;
            let mut node = json!({ "mesh": mesh.mesh });
            if let Some(n) = &mesh.name {
                node["name"] = json!(n);
            }
            trs_properties(&mut node, trs);
            children.push(out.node(node));
        }
        roots.push(out.node(json!({ "name": "terrain", "children": children })));
    }
    for model in inputs.models.iter().chain(&inputs.terrain) {
        warnings.extend(model.warnings().iter().cloned());
    }
    let generator = concat!("texel-forest ", env!("CARGO_PKG_VERSION"));
    match container {
        Container::Glb => out
            .into_glb(generator, &roots)
            .ok_or_else(|| ExportError::TooLarge(inputs.forest.instances.len())),
        Container::Text => Ok(out.into_text(generator, &roots)),
    }
}

#[cfg(test)]
mod tests;
