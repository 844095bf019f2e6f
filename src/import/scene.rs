//! Flattens the default scene: walks the node tree from the scene's roots, applies each node's
//! transform (matrix or TRS) to its mesh's triangle primitives, and collects materials.

use std::collections::HashMap;
use std::path::Path;

use glam::{DMat4, DQuat, DVec3, Mat3, Vec2, Vec3, Vec4};
use gltf_json as json;
use json::mesh::{Mode, Semantic};
use json::validation::Checked;

use super::accessor;
use super::document::Document;
use super::image::load_texture;
use super::{AlphaMode, ImportError, Material, Mesh, SceneCamera, SceneSun, Triangle};

/// Deeper hierarchies than this are refused as malformed (real assets nest a handful of levels).
pub(super) const MAX_DEPTH: usize = 256;

struct Builder {
    mesh: Mesh,
    cameras: Vec<SceneCamera>,
    /// The names (the camera's and its node's) of the orthographic cameras, which a render
    /// cannot use but a user may ask for.
    orthographic: Vec<String>,
    suns: Vec<SceneSun>,
    /// glTF material index (None = default material) -> index in `mesh.materials`.
    materials: HashMap<Option<usize>, u32>,
    /// glTF texture index -> index in `mesh.textures`.
    textures: HashMap<usize, u32>,
}

/// The default scene, flattened: its triangles, perspective cameras, orthographic cameras'
/// names and directional lights.
pub(super) struct Flattened {
    pub mesh: Mesh,
    pub cameras: Vec<SceneCamera>,
    pub orthographic: Vec<String>,
    pub suns: Vec<SceneSun>,
}

pub(super) fn flatten(doc: &mut Document) -> Result<Flattened, ImportError> {
    let roots = scene_roots(doc)?;
    let mut builder = Builder {
        mesh: Mesh::default(),
        cameras: Vec::new(),
        orthographic: Vec::new(),
        suns: Vec::new(),
        materials: HashMap::new(),
        textures: HashMap::new(),
    };
    let mut on_path = vec![false; doc.root.nodes.len()];
    for (i, node) in roots.into_iter().enumerate() {
        visit(
            doc,
            &mut builder,
            node,
            DMat4::IDENTITY,
            &mut on_path,
            0,
            &format!("scene.nodes[{i}]"),
        )?;
    }
    Ok(Flattened {
        mesh: builder.mesh,
        cameras: builder.cameras,
        orthographic: builder.orthographic,
        suns: builder.suns,
    })
}

/// The root nodes of the default scene: `scene`, else the first scene, else (a file with no
/// scenes) every node that is nobody's child; each once, in order.
///
/// A node with two parents is refused here, for every walk of the hierarchy: glTF's nodes
/// form disjoint trees, and a hierarchy that shares children (each of 60 nodes listing the
/// next twice) has 2^60 paths from its root, which a walk would follow until memory or
/// patience ran out. With one parent each and no cycle (the walks refuse those), a node is
/// reached once per root above it, at most 257 times.
pub(super) fn scene_roots(doc: &Document) -> Result<Vec<usize>, ImportError> {
    let root = &doc.root;
    let mut parent: Vec<Option<usize>> = vec![None; root.nodes.len()];
    for (p, node) in root.nodes.iter().enumerate() {
        for child in node.children.iter().flatten() {
            let c = child.value();
            match parent.get_mut(c) {
                Some(Some(first)) => {
                    let why = if *first == p {
                        format!("lists node {c} twice")
                    } else {
                        format!("node {c} is already a child of nodes[{first}]")
                    };
                    return Err(ImportError::invalid(
                        &doc.path,
                        format!("nodes[{p}].children"),
                        format!("{why}: a glTF node has at most one parent"),
                    ));
                }
                Some(slot) => *slot = Some(p),
                // A missing child is refused by the walk that meets it, naming its place.
                None => {}
            }
        }
    }
    if let (Some(scene), true) = (root.scene, root.scenes.is_empty()) {
        return Err(ImportError::invalid(
            &doc.path,
            "scene",
            format!(
                "scene {} does not exist (the file has no scenes array)",
                scene.value()
            ),
        ));
    }
    if root.scenes.is_empty() {
        return Ok((0..root.nodes.len())
            .filter(|&i| parent[i].is_none())
            .collect());
    }
    let scene = root.scene.map_or(0, |s| s.value());
    let Some(scene) = root.scenes.get(scene) else {
        return Err(ImportError::invalid(
            &doc.path,
            "scene",
            format!(
                "scene {scene} does not exist ({} scenes)",
                root.scenes.len()
            ),
        ));
    };
    // A root listed twice would be drawn twice over itself. (One that does not exist is
    // kept, for the walk to refuse by its place.)
    let mut listed = vec![false; root.nodes.len()];
    Ok(scene
        .nodes
        .iter()
        .map(|n| n.value())
        .filter(|&n| {
            listed
                .get_mut(n)
                .is_none_or(|seen| !std::mem::replace(seen, true))
        })
        .collect())
}

/// Refuses a node transform the glTF spec forbids and no tool means: a `matrix` that is not
/// affine (its last row must be 0, 0, 0, 1: a projective matrix has no translation, rotation
/// and scale) and a `rotation` that is no rotation (zero or not finite, so it cannot be
/// normalised). A rotation merely off unit length, as exporters round it, is normalised.
pub(super) fn check_transform(
    path: &Path,
    index: usize,
    node: &json::Node,
) -> Result<(), ImportError> {
    if let Some(m) = node.matrix {
        // Column-major: the last row is elements 3, 7, 11 and 15.
        let row = [m[3], m[7], m[11], m[15]];
        let affine = row[..3].iter().all(|v| v.abs() <= 1e-6) && (row[3] - 1.0).abs() <= 1e-6;
        if !affine {
            return Err(ImportError::invalid(
                path,
                format!("nodes[{index}].matrix"),
                format!(
                    "its last row is {row:?}, not [0, 0, 0, 1]: a node matrix must be an affine \
                     transform (translation, rotation and scale)"
                ),
            ));
        }
    }
    if let Some(r) = node.rotation {
        let q = DQuat::from_array(r.0.map(f64::from));
        if !(q.is_finite() && q.length_squared() > 1e-12) {
            return Err(ImportError::invalid(
                path,
                format!("nodes[{index}].rotation"),
                format!(
                    "{:?} is no rotation: it does not normalise to a unit quaternion [x, y, z, w]",
                    r.0
                ),
            ));
        }
    }
    Ok(())
}

pub(super) fn local_transform(node: &json::Node) -> DMat4 {
    if let Some(m) = node.matrix {
        return DMat4::from_cols_array(&m.map(f64::from));
    }
    let (translation, rotation, scale) = trs(node);
    DMat4::from_scale_rotation_translation(scale, rotation, translation)
}

/// A node's translation, rotation (normalised; [`check_transform`] refuses one that cannot
/// be, and here it becomes the identity) and scale, each its default where absent.
pub(super) fn trs(node: &json::Node) -> (DVec3, DQuat, DVec3) {
    let t = node
        .translation
        .map_or(DVec3::ZERO, |t| DVec3::from(t.map(f64::from)));
    let s = node
        .scale
        .map_or(DVec3::ONE, |s| DVec3::from(s.map(f64::from)));
    let r = node.rotation.map_or(DQuat::IDENTITY, |r| {
        let q = DQuat::from_array(r.0.map(f64::from));
        if q.length_squared() > 0.0 && q.is_finite() {
            q.normalize()
        } else {
            DQuat::IDENTITY
        }
    });
    (t, r, s)
}

fn visit(
    doc: &mut Document,
    b: &mut Builder,
    index: usize,
    parent: DMat4,
    on_path: &mut Vec<bool>,
    depth: usize,
    field: &str,
) -> Result<(), ImportError> {
    let path = doc.path.clone();
    if index >= doc.root.nodes.len() {
        return Err(ImportError::invalid(
            &path,
            field,
            format!("node {index} does not exist"),
        ));
    }
    if on_path[index] || depth > MAX_DEPTH {
        return Err(ImportError::invalid(
            &path,
            format!("nodes[{index}].children"),
            "the node hierarchy is cyclic or deeper than 256 levels",
        ));
    }
    let node = &doc.root.nodes[index];
    check_transform(&path, index, node)?;
    let world = parent * local_transform(node);
    if !world.is_finite() {
        return Err(ImportError::invalid(
            &path,
            format!("nodes[{index}]"),
            "transform is not finite",
        ));
    }
    let mesh = node.mesh.map(|m| m.value());
    let children: Vec<usize> = node.children.iter().flatten().map(|c| c.value()).collect();
    let skinned = node.skin.is_some();
    collect_views(doc, b, index, world)?;
    if skinned {
        doc.warn(format!(
            "{}: nodes[{index}] is skinned; baked in its bind pose",
            path.display()
        ));
    }
    if let Some(mesh) = mesh {
        let Some(primitives) = doc.root.meshes.get(mesh).map(|m| m.primitives.len()) else {
            return Err(ImportError::invalid(
                &path,
                format!("nodes[{index}].mesh"),
                format!("mesh {mesh} does not exist"),
            ));
        };
        for p in 0..primitives {
            add_primitive(doc, b, mesh, p, world)?;
        }
    }
    on_path[index] = true;
    for (i, child) in children.into_iter().enumerate() {
        visit(
            doc,
            b,
            child,
            world,
            on_path,
            depth + 1,
            &format!("nodes[{index}].children[{i}]"),
        )?;
    }
    on_path[index] = false;
    Ok(())
}

/// The camera node `index` holds, if any; one its index does not name is refused.
pub(super) fn camera_of(
    doc: &Document,
    index: usize,
) -> Result<Option<&json::Camera>, ImportError> {
    let Some(camera) = doc.root.nodes[index].camera.map(|c| c.value()) else {
        return Ok(None);
    };
    doc.root.cameras.get(camera).map(Some).ok_or_else(|| {
        ImportError::invalid(
            &doc.path,
            format!("nodes[{index}].camera"),
            format!(
                "camera {camera} does not exist ({} cameras)",
                doc.root.cameras.len()
            ),
        )
    })
}

/// The camera and directional light of node `index`, if it has them, placed by its `world`
/// transform: the views a render may be asked to use. A light index that names no light is
/// refused; an orthographic camera is only listed by name (a render draws perspective ones).
fn collect_views(
    doc: &mut Document,
    b: &mut Builder,
    index: usize,
    world: DMat4,
) -> Result<(), ImportError> {
    let node = &doc.root.nodes[index];
    let axis = |v: DVec3| crate::geom::direction(world.transform_vector3(v));
    if let Some(c) = camera_of(doc, index)? {
        if let Some(p) = &c.perspective {
            b.cameras.push(SceneCamera {
                name: c
                    .name
                    .clone()
                    .or_else(|| node.name.clone())
                    .unwrap_or_else(|| format!("camera {}", b.cameras.len())),
                node: node.name.clone(),
                eye: world.transform_point3(DVec3::ZERO),
                forward: axis(DVec3::NEG_Z),
                up: axis(DVec3::Y),
                yfov: p.yfov as f64,
            });
        } else {
            b.orthographic
                .extend(c.name.iter().chain(node.name.iter()).cloned());
        }
    }
    let Some(light) = node
        .extensions
        .as_ref()
        .and_then(|e| e.khr_lights_punctual.as_ref())
        .map(|l| l.light.value())
    else {
        return Ok(());
    };
    let lights = doc
        .root
        .extensions
        .as_ref()
        .and_then(|e| e.khr_lights_punctual.as_ref())
        .map_or(&[][..], |ls| &ls.lights[..]);
    let Some(l) = lights.get(light) else {
        return Err(ImportError::invalid(
            &doc.path,
            format!("nodes[{index}].extensions.KHR_lights_punctual.light"),
            format!(
                "light {light} does not exist (the file's KHR_lights_punctual.lights has {})",
                lights.len()
            ),
        ));
    };
    if l.type_ == Checked::Valid(json::extensions::scene::khr_lights_punctual::Type::Directional) {
        // A light's direction is its node's -Z; a transform that scales it to nothing (a zero
        // scale, as exporters hide objects, or one f32 rounds to zero) leaves the sun no
        // direction to come from: such a light is no sun (a bake never reads lights).
        let towards = axis(DVec3::Z);
        if !(towards.is_finite() && towards.length_squared() > 0.5) {
            let warning = format!(
                "{}: nodes[{index}]: its directional light is not a sun: the node's transform scales it to nothing (or beyond f64)",
                doc.path.display()
            );
            doc.warn(warning);
            return Ok(());
        }
        b.suns.push(SceneSun {
            name: l
                .name
                .clone()
                .or_else(|| node.name.clone())
                .unwrap_or_else(|| format!("light {}", b.suns.len())),
            towards,
            intensity: l.intensity as f64,
            color: l.color,
        });
    }
    Ok(())
}

fn add_primitive(
    doc: &mut Document,
    b: &mut Builder,
    mesh: usize,
    prim: usize,
    world: DMat4,
) -> Result<(), ImportError> {
    let path = doc.path.clone();
    let field = format!("meshes[{mesh}].primitives[{prim}]");
    let primitive = doc.root.meshes[mesh].primitives[prim].clone();
    let mode = match primitive.mode {
        Checked::Valid(mode) => mode,
        Checked::Invalid => {
            return Err(ImportError::invalid(
                &path,
                format!("{field}.mode"),
                "invalid",
            ));
        }
    };
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        doc.warn(format!(
            "{}: {field} skipped: {mode:?} are not surfaces",
            path.display()
        ));
        return Ok(());
    }
    let Some(position_accessor) = attribute(&primitive, Semantic::Positions) else {
        doc.warn(format!(
            "{}: {field} skipped: it has no POSITION",
            path.display()
        ));
        return Ok(());
    };
    let pfield = format!("{field}.attributes.POSITION");
    let positions = accessor::read(doc, position_accessor, &pfield)?;
    if positions.components != 3 {
        return Err(ImportError::invalid(&path, &pfield, "is not a VEC3"));
    }
    if let Some(bad) = positions.data.iter().position(|v| !v.is_finite()) {
        return Err(ImportError::invalid(
            &path,
            &pfield,
            format!(
                "accessor {position_accessor} element {} is not finite ({})",
                bad / 3,
                positions.data[bad]
            ),
        ));
    }
    let n = positions.count();

    let material = material_index(doc, b, primitive.material.map(|m| m.value()), &field)?;
    let tex_coord = texture_coordinate_set(doc, primitive.material.map(|m| m.value()));
    let uvs = texture_coordinates(doc, &primitive, tex_coord, n, &field)?;
    let colors = vertex_colors(doc, &primitive, n, &field)?;

    let indices = vertex_indices(doc, &primitive, n, &field)?;
    if mode == Mode::Triangles && !indices.len().is_multiple_of(3) {
        // glTF's validator warns of this, no more: the leftover vertices make no triangle.
        let at = if primitive.indices.is_some() {
            format!("{field}.indices")
        } else {
            format!("{field}.attributes.POSITION")
        };
        doc.warn(format!(
            "{}: {at}: {} vertices is no whole number of triangles; the last {} make none",
            doc.path.display(),
            indices.len(),
            indices.len() % 3
        ));
    }
    let corners = triangulate(mode, &indices);
    // Instancing multiplies what a small file holds: check the scene's size before growing it.
    let limits = doc.limits;
    let what = "the triangles of the scene with every node instanced";
    limits
        .check_triangles((b.mesh.triangles.len() + corners.len()) as u64, what)
        .and_then(|_| {
            limits.check_triangles(
                ((b.mesh.positions.len() + n) / 3) as u64,
                "a third of the scene's vertices with every node instanced",
            )
        })
        .map_err(|e| ImportError::invalid(&path, &field, e))?;

    append(b, world, &positions.data, uvs, colors, &corners, material)
        .map_err(|message| ImportError::invalid(&path, &pfield, message))
}

/// The accessor of `primitive`'s attribute `semantic`, if it has one.
fn attribute(primitive: &json::mesh::Primitive, semantic: Semantic) -> Option<usize> {
    primitive
        .attributes
        .get(&Checked::Valid(semantic))
        .map(|a| a.value())
}

/// The `n` texture coordinates of the set `tex_coord` the material samples (zero where it
/// samples none, or the primitive lacks them: a warning then).
fn texture_coordinates(
    doc: &mut Document,
    primitive: &json::mesh::Primitive,
    tex_coord: Option<u32>,
    n: usize,
    field: &str,
) -> Result<Vec<Vec2>, ImportError> {
    let path = doc.path.clone();
    Ok(
        match tex_coord
            .and_then(|set| attribute(primitive, Semantic::TexCoords(set)).map(|a| (set, a)))
        {
            Some((set, a)) => {
                let f = format!("{field}.attributes.TEXCOORD_{set}");
                let v = accessor::read(doc, a, &f)?;
                if v.components != 2 || v.count() != n {
                    return Err(ImportError::invalid(
                        &path,
                        &f,
                        format!("must be {n} VEC2 elements"),
                    ));
                }
                (0..n)
                    .map(|i| Vec2::new(v.element(i)[0] as f32, v.element(i)[1] as f32))
                    .collect()
            }
            None => {
                if let Some(set) = tex_coord {
                    doc.warn(format!(
                    "{}: {field} has a textured material but no TEXCOORD_{set}; texture sampled at (0,0)",
                    path.display()
                ));
                }
                vec![Vec2::ZERO; n]
            }
        },
    )
}

/// The `n` vertex colours of `COLOR_0` as linear RGBA (white where there is none).
fn vertex_colors(
    doc: &mut Document,
    primitive: &json::mesh::Primitive,
    n: usize,
    field: &str,
) -> Result<Vec<Vec4>, ImportError> {
    let path = doc.path.clone();
    Ok(match attribute(primitive, Semantic::Colors(0)) {
        Some(a) => {
            let f = format!("{field}.attributes.COLOR_0");
            let v = accessor::read(doc, a, &f)?;
            if !(v.components == 3 || v.components == 4) || v.count() != n {
                return Err(ImportError::invalid(
                    &path,
                    &f,
                    format!("must be {n} VEC3 or VEC4 elements"),
                ));
            }
            let colors: Vec<Vec4> = (0..n)
                .map(|i| {
                    let e = v.element(i);
                    let alpha = if v.components == 4 { e[3] } else { 1.0 };
                    Vec4::new(e[0] as f32, e[1] as f32, e[2] as f32, alpha as f32)
                })
                .collect();
            // A NaN colour would bake to a NaN albedo, and a NaN alpha would cut every leaf.
            if let Some(i) = colors.iter().position(|c| !c.is_finite()) {
                return Err(ImportError::invalid(
                    &path,
                    &f,
                    format!("accessor {a} element {i} is not finite ({})", colors[i]),
                ));
            }
            colors
        }
        None => vec![Vec4::ONE; n],
    })
}

/// The primitive's vertex indices (all `n` in order where it has none), each checked.
fn vertex_indices(
    doc: &mut Document,
    primitive: &json::mesh::Primitive,
    n: usize,
    field: &str,
) -> Result<Vec<u32>, ImportError> {
    let path = doc.path.clone();
    Ok(match primitive.indices {
        Some(i) => {
            let f = format!("{field}.indices");
            let indices = accessor::read_indices(doc, i.value(), &f)?;
            if let Some(&bad) = indices.iter().find(|&&v| v as usize >= n) {
                return Err(ImportError::invalid(
                    &path,
                    &f,
                    format!("index {bad} is out of range for {n} vertices"),
                ));
            }
            indices
        }
        None => (0..n as u32).collect(),
    })
}

/// Appends a primitive's vertices (transformed by `world`) and triangles to the mesh; a
/// mirroring transform swaps each triangle's winding so fronts stay fronts.
fn append(
    b: &mut Builder,
    world: DMat4,
    positions: &[f64],
    uvs: Vec<Vec2>,
    colors: Vec<Vec4>,
    corners: &[[u32; 3]],
    material: u32,
) -> Result<(), &'static str> {
    let base = b.mesh.positions.len() as u32;
    let mirrored = world.determinant() < 0.0;
    for p in positions.chunks_exact(3) {
        let q = world
            .transform_point3(DVec3::new(p[0], p[1], p[2]))
            .as_vec3();
        if !q.is_finite() {
            return Err("a transformed position overflows");
        }
        b.mesh.positions.push(q);
    }
    b.mesh.uvs.extend(uvs);
    b.mesh.colors.extend(colors);
    for &[i, j, k] in corners {
        if i == j || j == k || i == k {
            continue;
        }
        // A mirroring transform turns counter-clockwise into clockwise; swap to keep fronts.
        let vertices = if mirrored {
            [base + i, base + k, base + j]
        } else {
            [base + i, base + j, base + k]
        };
        b.mesh.triangles.push(Triangle { vertices, material });
    }
    Ok(())
}

/// Triangle corner indices for a triangle list, strip or fan (glTF 2.0 section 3.7.2.1).
fn triangulate(mode: Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::TriangleStrip => (0..idx.len().saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i], idx[i + 1], idx[i + 2]]
                } else {
                    [idx[i], idx[i + 2], idx[i + 1]]
                }
            })
            .collect(),
        Mode::TriangleFan => (1..idx.len().saturating_sub(1))
            .map(|i| [idx[i], idx[i + 1], idx[0]])
            .collect(),
        _ => idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
    }
}

fn texture_coordinate_set(doc: &Document, material: Option<usize>) -> Option<u32> {
    let info = doc
        .root
        .materials
        .get(material?)?
        .pbr_metallic_roughness
        .base_color_texture
        .as_ref()?;
    let over = info
        .extensions
        .as_ref()
        .and_then(|e| e.texture_transform.as_ref())
        .and_then(|t| t.tex_coord);
    Some(over.unwrap_or(info.tex_coord))
}

fn material_index(
    doc: &mut Document,
    b: &mut Builder,
    index: Option<usize>,
    field: &str,
) -> Result<u32, ImportError> {
    if let Some(&m) = b.materials.get(&index) {
        return Ok(m);
    }
    let material = match index {
        None => Material::default(),
        Some(i) => convert_material(doc, b, i, field)?,
    };
    let m = b.mesh.materials.len() as u32;
    b.mesh.materials.push(material);
    b.materials.insert(index, m);
    Ok(m)
}

fn convert_material(
    doc: &mut Document,
    b: &mut Builder,
    i: usize,
    field: &str,
) -> Result<Material, ImportError> {
    let path = doc.path.clone();
    let Some(m) = doc.root.materials.get(i).cloned() else {
        return Err(ImportError::invalid(
            &path,
            format!("{field}.material"),
            format!("material {i} does not exist"),
        ));
    };
    let here = format!("materials[{i}]");
    let pbr = &m.pbr_metallic_roughness;
    let base_color = Vec4::from_array(pbr.base_color_factor.0);
    if !base_color.is_finite() {
        return Err(ImportError::invalid(
            &path,
            format!("{here}.pbrMetallicRoughness.baseColorFactor"),
            "not finite",
        ));
    }
    let cutoff = m.alpha_cutoff.map_or(0.5, |c| c.0);
    if !(cutoff >= 0.0 && cutoff.is_finite()) {
        return Err(ImportError::invalid(
            &path,
            format!("{here}.alphaCutoff"),
            format!("{cutoff} is not a cutoff from 0 up (glTF's minimum is 0)"),
        ));
    }
    let alpha_mode = match m.alpha_mode {
        Checked::Valid(json::material::AlphaMode::Mask) => AlphaMode::Mask { cutoff },
        Checked::Valid(json::material::AlphaMode::Blend) => AlphaMode::Blend,
        _ => AlphaMode::Opaque,
    };
    let (base_color_texture, uv_transform) = match &pbr.base_color_texture {
        None => (None, None),
        Some(info) => {
            let t = info.index.value();
            let index = match b.textures.get(&t) {
                Some(&k) => k,
                None => {
                    let texture = load_texture(
                        doc,
                        t,
                        &format!("{here}.pbrMetallicRoughness.baseColorTexture"),
                    )?;
                    let k = b.mesh.textures.len() as u32;
                    b.mesh.textures.push(texture);
                    b.textures.insert(t, k);
                    k
                }
            };
            let transform = info
                .extensions
                .as_ref()
                .and_then(|e| e.texture_transform.as_ref())
                .map(|t| {
                    // KHR_texture_transform: uv' = T * R * S * uv, rotation counter-clockwise in UV.
                    let (s, c) = t.rotation.0.sin_cos();
                    Mat3::from_translation(Vec2::from(t.offset.0))
                        * Mat3::from_cols(Vec3::new(c, -s, 0.0), Vec3::new(s, c, 0.0), Vec3::Z)
                        * Mat3::from_scale(Vec2::from(t.scale.0))
                });
            if let AlphaMode::Mask { cutoff } = alpha_mode
                && !b.mesh.textures[index as usize].has_alpha
                && base_color.w >= cutoff
            {
                doc.warn(format!(
                    "{}: {here} ({:?}): alphaMode MASK, but its baseColorTexture has no alpha \
                     channel, so the mask cuts nothing",
                    path.display(),
                    m.name.as_deref().unwrap_or_default()
                ));
            }
            (Some(index), transform)
        }
    };
    Ok(Material {
        name: m.name.clone().unwrap_or_default(),
        base_color,
        base_color_texture,
        uv_transform,
        alpha_mode,
    })
}
