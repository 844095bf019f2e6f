//! Ray queries against an imported mesh, honouring alpha-tested materials: the ground truth a
//! texture is measured against.

use crate::geom::{Ray, TriangleBvh, TriangleHit};
use crate::import::{AlphaMode, Mesh};
use crate::rng;

/// Whether the surface of triangle `t` of `mesh` is there at barycentric `w` (alpha mask or,
/// for blended materials, alpha as a coverage probability keyed by `key`).
pub fn covers(mesh: &Mesh, t: u32, w: [f32; 3], key: u64) -> bool {
    let tri = &mesh.triangles[t as usize];
    let alpha_mode = mesh.materials[tri.material as usize].alpha_mode;
    if alpha_mode == AlphaMode::Opaque {
        return true;
    }
    let alpha = mesh.base_color(tri, w).w;
    match alpha_mode {
        AlphaMode::Mask { cutoff } => alpha >= cutoff,
        _ => alpha as f64 > rng::unit(rng::hash3(key, t as u64, rng::purpose::MESH_BLEND)),
    }
}

pub struct MeshTracer<'a> {
    mesh: &'a Mesh,
    triangles: TriangleBvh,
}

impl<'a> MeshTracer<'a> {
    pub fn new(mesh: &'a Mesh) -> Self {
        let corners = mesh.corners();
        MeshTracer {
            mesh,
            triangles: TriangleBvh::new(corners),
        }
    }

    /// The nearest covered surface along `ray` within (t_min, t_max): triangle and hit.
    pub fn nearest(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        key: u64,
    ) -> Option<(u32, TriangleHit)> {
        self.triangles
            .nearest(ray, t_min, t_max, |t, h| covers(self.mesh, t, h.w, key))
    }

    /// Whether any covered surface lies along `ray` within (t_min, t_max).
    pub fn occluded(&self, ray: &Ray, t_min: f32, t_max: f32, key: u64) -> bool {
        self.triangles
            .occluded(ray, t_min, t_max, |t, h| covers(self.mesh, t, h.w, key))
    }
}
