//! glTF 2.0 import: a `.gltf` or `.glb` file becomes a plain triangle [`Mesh`] in the model's
//! own space (metres, +Y up, origin at the tree's base), with materials and decoded textures.
//!
//! This is the only module that sees glTF types. It reads the JSON with `gltf-json`'s serde
//! types and does its own validation, so that every problem is reported with the file and the
//! JSON path of the offending field, and so that the quirks real assets carry (a scene listing a
//! node that is also another node's child, unused extensions, external buffers) are tolerated
//! while unsafe input (cycles, out-of-range reads, network URIs) is refused.

mod accessor;
mod animation;
mod document;
mod image;
mod raw;
mod scene;
#[cfg(test)]
mod tests;

use std::fmt;
use std::path::{Path, PathBuf};

use glam::{Mat3, Vec2, Vec3, Vec4};

use crate::limits::Limits;
use crate::provenance::Source;

pub use self::animation::{CameraAnimation, load_camera_animation};
pub use self::image::{Texture, WrapMode};
pub use self::raw::{MeshNode, RawGltf};

/// A triangle soup with per-vertex attributes, ready for scan conversion.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Vertex positions in the model's space, metres.
    pub positions: Vec<Vec3>,
    /// Texture coordinates of the set the vertex's material samples (zero when it has none).
    pub uvs: Vec<Vec2>,
    /// `COLOR_0`, linear RGBA (white where the primitive has none).
    pub colors: Vec<Vec4>,
    /// Triangles, counter-clockwise seen from the front in the model's space.
    pub triangles: Vec<Triangle>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Triangle {
    pub vertices: [u32; 3],
    pub material: u32,
}

/// The part of a glTF material that a volume needs: its colour and its coverage.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// `baseColorFactor`, linear RGBA.
    pub base_color: Vec4,
    /// Index into [`Mesh::textures`] of the `baseColorTexture`.
    pub base_color_texture: Option<u32>,
    /// `KHR_texture_transform` of the base colour texture, as a 2D affine matrix.
    pub uv_transform: Option<Mat3>,
    pub alpha_mode: AlphaMode,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    Opaque,
    /// Covered where alpha >= cutoff (glTF `MASK`).
    Mask {
        cutoff: f32,
    },
    /// Alpha is fractional coverage (glTF `BLEND`).
    Blend,
}

impl Material {
    pub fn is_alpha_tested(&self) -> bool {
        !matches!(self.alpha_mode, AlphaMode::Opaque)
    }
}

impl Default for Material {
    /// The glTF default material: white, opaque.
    fn default() -> Self {
        Material {
            name: String::new(),
            base_color: Vec4::ONE,
            base_color_texture: None,
            uv_transform: None,
            alpha_mode: AlphaMode::Opaque,
        }
    }
}

#[cfg(test)]
impl Mesh {
    /// A mesh of `triangles` over `positions`, all of one `material`, untextured and white:
    /// the small meshes tests build by hand.
    pub fn plain(positions: Vec<Vec3>, triangles: &[[u32; 3]], material: Material) -> Mesh {
        let n = positions.len();
        Mesh {
            positions,
            uvs: vec![Vec2::ZERO; n],
            colors: vec![Vec4::ONE; n],
            triangles: triangles
                .iter()
                .map(|&vertices| Triangle {
                    vertices,
                    material: 0,
                })
                .collect(),
            materials: vec![material],
            textures: vec![],
        }
    }
}

impl Mesh {
    /// The axis-aligned bounds of the vertices that triangles use.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for tri in &self.triangles {
            for &v in &tri.vertices {
                let p = self.positions[v as usize];
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        (!self.triangles.is_empty()).then_some((lo, hi))
    }

    /// The three corners of every triangle, in order: what acceleration structures are built on.
    pub fn corners(&self) -> Vec<[Vec3; 3]> {
        self.triangles
            .iter()
            .map(|t| t.vertices.map(|v| self.positions[v as usize]))
            .collect()
    }

    /// Linear RGBA base colour of `triangle` at barycentric weights `w` (material factor x
    /// texture x `COLOR_0`).
    pub fn base_color(&self, triangle: &Triangle, w: [f32; 3]) -> Vec4 {
        let [a, b, c] = triangle.vertices.map(|v| v as usize);
        let material = &self.materials[triangle.material as usize];
        let mut color = material.base_color
            * (self.colors[a] * w[0] + self.colors[b] * w[1] + self.colors[c] * w[2]);
        if let Some(texture) = material.base_color_texture {
            let mut uv = self.uvs[a] * w[0] + self.uvs[b] * w[1] + self.uvs[c] * w[2];
            if let Some(m) = material.uv_transform {
                uv = m.transform_point2(uv);
            }
            color *= self.textures[texture as usize].sample(uv);
        }
        color
    }
}

/// A perspective camera of the scene, in the model's space.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneCamera {
    /// The camera's name, else its node's, else "camera N".
    pub name: String,
    /// The name of the node that places it, where it has one (`--camera` takes either).
    pub node: Option<String>,
    pub eye: glam::DVec3,
    /// Unit viewing direction (the node's -Z) and up (its +Y).
    pub forward: glam::DVec3,
    pub up: glam::DVec3,
    /// Vertical field of view, radians.
    pub yfov: f64,
}

/// A directional light of the scene (`KHR_lights_punctual`).
#[derive(Clone, Debug, PartialEq)]
pub struct SceneSun {
    pub name: String,
    /// Unit vector towards the light (the node's +Z).
    pub towards: glam::DVec3,
    /// Illuminance, lux.
    pub intensity: f64,
    pub color: [f32; 3],
}

/// A model as imported, with the files it was read from.
#[derive(Clone, Debug)]
pub struct Model {
    pub mesh: Mesh,
    pub cameras: Vec<SceneCamera>,
    /// The names of the orthographic cameras (their own and their nodes'): not drawable, but
    /// named in the error when `--camera` asks for one.
    pub orthographic: Vec<String>,
    pub suns: Vec<SceneSun>,
    /// Every file read: the glTF first, then external buffers and images, in the order read.
    pub sources: Vec<Source<PathBuf>>,
    /// Things skipped or ignored that a user may want to know about.
    pub warnings: Vec<String>,
}

/// Why a glTF file could not be imported. Every variant names the file; `field` is the JSON path
/// of what was wrong where there is one.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    #[error("{file}: cannot read")]
    Io {
        file: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{file}: {}{message}", field_prefix(field))]
    Invalid {
        file: PathBuf,
        field: String,
        message: String,
    },
    #[error("{file}: {}{message}", field_prefix(field))]
    Unsupported {
        file: PathBuf,
        field: String,
        message: String,
    },
}

pub(crate) fn field_prefix(field: &str) -> String {
    if field.is_empty() {
        String::new()
    } else {
        format!("{field}: ")
    }
}

impl ImportError {
    pub(crate) fn invalid(
        file: &Path,
        field: impl fmt::Display,
        message: impl fmt::Display,
    ) -> Self {
        ImportError::Invalid {
            file: file.to_path_buf(),
            field: field.to_string(),
            message: message.to_string(),
        }
    }

    pub(crate) fn unsupported(
        file: &Path,
        field: impl fmt::Display,
        message: impl fmt::Display,
    ) -> Self {
        ImportError::Unsupported {
            file: file.to_path_buf(),
            field: field.to_string(),
            message: message.to_string(),
        }
    }
}

/// Reads a `.gltf` (with its external or embedded buffers and images) or a `.glb` file and
/// flattens the default scene into one mesh in the model's space. The scene may hold no
/// triangles at all (a file of cameras and lights); see [`load_surface`].
pub fn load(path: &Path) -> Result<Model, ImportError> {
    load_with(path, &Limits::default())
}

/// [`load`] within `limits` (triangles once every node is instanced).
pub fn load_with(path: &Path, limits: &Limits) -> Result<Model, ImportError> {
    let doc = document::Document::open(path, limits)?;
    model_of(doc)
}

/// [`load_with`] from the bytes of a `.gltf` or `.glb` file; `path` names it in errors and
/// anchors the relative URIs of its external buffers and images.
pub fn load_bytes(path: &Path, bytes: Vec<u8>, limits: &Limits) -> Result<Model, ImportError> {
    let mut doc = document::Document::parse(path, bytes)?;
    doc.limits = *limits;
    model_of(doc)
}

fn model_of(mut doc: document::Document) -> Result<Model, ImportError> {
    let scene::Flattened {
        mesh,
        cameras,
        orthographic,
        suns,
    } = scene::flatten(&mut doc)?;
    Ok(Model {
        mesh,
        cameras,
        orthographic,
        suns,
        sources: doc.sources,
        warnings: doc.warnings,
    })
}

/// [`load`] for a file that must hold a surface; `purpose` completes "there is nothing ...",
/// e.g. "to bake".
pub fn load_surface(path: &Path, purpose: &str, limits: &Limits) -> Result<Model, ImportError> {
    let model = load_with(path, limits)?;
    if model.mesh.triangles.is_empty() {
        return Err(ImportError::invalid(
            path,
            "",
            format!(
                "the default scene holds no triangles (it is empty, or has only cameras, \
                 lights, points or lines): there is nothing {purpose}"
            ),
        ));
    }
    Ok(model)
}
