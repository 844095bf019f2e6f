//! The conventional method the paper compares against, and at many samples per pixel the
//! ground truth: the same instances drawn from their original polygon models.
//!
//! Two levels of bounding volume hierarchy: the scene's tree over the instances' boxes (the
//! one the volume renderer walks), and one per model over its triangles, in model space. A ray
//! is carried into each instance's frame (the direction divided by the scale, so distances
//! along it are the renderer's), so 20,000 trees cost no more memory than their few models.
//! Surfaces shade with the same equation (3) as the textures, on the geometric normal, lit by
//! the sun through every mesh and the terrain; alpha-masked leaves let light and view through.

use glam::Vec3;

use super::instances::TreeTransform;
use super::lod::Draw;
use super::scene::{Scene, TreeMesh};
use super::shading::{Radiance, shade, shade_ground, sun_radiance};
use crate::geom::{Ray, TriangleHit, barycentric_point, offset_origin};
use crate::mesh_tracer::covers;
use crate::rng;

/// A hit on a tree: which instance, which triangle of its model, and where.
pub(super) struct TreeHit {
    pub(super) instance: u32,
    pub(super) triangle: u32,
    pub(super) hit: TriangleHit,
}

/// Whether triangle `t` of instance `i`'s model is there at `w`: its alpha, and for foliage
/// the leaf fraction (the same leaves stay on a tree for every ray).
fn present(scene: &Scene, i: u32, tree: &TreeMesh, t: u32, w: [f32; 3], key: u64) -> bool {
    if tree.foliage[t as usize] {
        let fraction = scene.looks[scene.instances.get(i).look as usize].foliage;
        if fraction < 1.0
            && rng::unit(rng::hash3(
                u64::from(i),
                u64::from(t),
                rng::purpose::MESH_LEAF,
            )) >= f64::from(fraction)
        {
            return false;
        }
    }
    covers(&tree.mesh, t, w, key)
}

fn tree_of<'a>(scene: &'a Scene, inst: &TreeTransform) -> &'a TreeMesh {
    &scene.meshes[scene.looks[inst.look as usize].texel]
}

/// The nearest surface along `ray` before `t_max` of the trees `draw` draws as models, and
/// whether the ray may enter the box of a tree it draws as a texture before that surface:
/// it does if one was met, or may where no surface was found before the model horizon
/// ([`Draw::model_horizon`]), beyond which the search does not look.
pub(super) fn nearest_drawn(
    scene: &Scene,
    ray: &Ray,
    t_max: f32,
    key: u64,
    draw: &Draw,
) -> (Option<TreeHit>, bool) {
    let mut texture = f32::INFINITY;
    // Past the horizon every tree is a texture: the search stops there (in a far view, at
    // once), and the texture walk is left to find whatever lies beyond.
    let horizon = draw.model_horizon(scene);
    let hit = scene
        .instances
        .nearest(ray, t_max.min(horizon), |i, local, t_max| {
            if draw.texel(scene, i) {
                if let Some((enter, _)) = scene.instances.local_interval(i, local, t_max) {
                    texture = texture.min(enter);
                }
                return None;
            }
            hit_instance(scene, i, local, t_max, key).map(|h| (h.hit.t, h))
        });
    let hit = hit.map(|(_, h)| h);
    let end = hit.as_ref().map_or(t_max, |h| h.hit.t);
    let beyond = hit.is_none() && horizon < t_max;
    (hit, texture < end || beyond)
}

/// The nearest surface of instance `i`'s model along `local` (the ray in its model space)
/// before `t_max`; `key` draws its alpha-blended triangles.
fn hit_instance(scene: &Scene, i: u32, local: &Ray, t_max: f32, key: u64) -> Option<TreeHit> {
    let tree = tree_of(scene, scene.instances.get(i));
    let (triangle, hit) = tree.triangles.nearest(local, 0.0, t_max, |t, h| {
        present(scene, i, tree, t, h.w, key)
    })?;
    Some(TreeHit {
        instance: i,
        triangle,
        hit,
    })
}

/// Whether the sun is hidden from `origin` by the terrain or any tree.
fn sun_hidden(scene: &Scene, origin: Vec3, key: u64) -> bool {
    let ray = Ray {
        origin,
        dir: scene.sun.direction,
    };
    if let Some(g) = &scene.ground
        && g.occluded(&ray, f32::INFINITY)
    {
        return true;
    }
    scene
        .sun_beam
        .any(&scene.instances, &ray, f32::INFINITY, |i, local, t_max| {
            blocks(scene, i, local, t_max, key)
        })
}

/// Whether instance `i`'s polygon model stops the ray `local` (in its model space) before
/// `t_max`; `key` draws its alpha-blended triangles.
pub(super) fn blocks(scene: &Scene, i: u32, local: &Ray, t_max: f32, key: u64) -> bool {
    let tree = tree_of(scene, scene.instances.get(i));
    tree.triangles.occluded(local, 0.0, t_max, |t, h| {
        present(scene, i, tree, t, h.w, key)
    })
}

/// What a view ray in direction `dir` sees where it hits a tree's model: the normal facing
/// it, the albedo, the species index + 1, and where a ray towards the sun may leave.
pub(super) struct TreeSurface {
    pub(super) normal: Vec3,
    pub(super) albedo: Vec3,
    pub(super) species: f32,
    pub(super) leave: Vec3,
}

pub(super) fn tree_surface(scene: &Scene, h: &TreeHit, dir: Vec3) -> TreeSurface {
    let inst = scene.instances.get(h.instance);
    let tree = tree_of(scene, inst);
    let look = &scene.looks[inst.look as usize];
    let normal = facing(
        inst.dir_to_world(tree.normal(h.triangle))
            .normalize_or(Vec3::Y),
        dir,
    );
    let albedo = if tree.foliage[h.triangle as usize] {
        look.foliage_albedo
    } else {
        let tri = &tree.mesh.triangles[h.triangle as usize];
        tree.mesh.base_color(tri, h.hit.w).truncate()
    };
    let (p, error) = barycentric_point(tree.corners(h.triangle), h.hit.w);
    let (p, error) = inst.point_to_world(p, error);
    TreeSurface {
        normal,
        albedo,
        species: inst.look as f32 + 1.0,
        leave: offset_origin(p, error, normal, scene.sun.direction),
    }
}

/// `n` turned to face the eye looking along `dir`: surfaces are two-sided.
fn facing(n: Vec3, dir: Vec3) -> Vec3 {
    if n.dot(dir) > 0.0 { -n } else { n }
}

/// Radiance along the ray from the eye in direction `dir`, from the polygon models.
pub fn radiance(scene: &Scene, dir: Vec3, key: u64) -> Radiance {
    let ray = Ray {
        origin: Vec3::ZERO,
        dir,
    };
    let ground_hit = scene
        .ground
        .as_ref()
        .and_then(|g| g.nearest(&ray, f32::INFINITY));
    let t_max = ground_hit.map_or(f32::INFINITY, |(_, h)| h.t);
    let mut out = Radiance {
        distance: f32::INFINITY,
        ..Radiance::default()
    };
    let shadow_key = rng::mix64(key ^ rng::purpose::MESH_SHADOW);
    // The surface seen, and where a ray leaving it towards the sun may start.
    let sun = scene.sun.direction;
    let (normal, albedo, t, species, leave) =
        if let (Some(h), _) = nearest_drawn(scene, &ray, t_max, key, &Draw::Mesh) {
            let s = tree_surface(scene, &h, dir);
            super::matte::add(h.instance, 1.0);
            out.canopy = 1.0;
            out.mesh_canopy = 1.0;
            (s.normal, s.albedo, h.hit.t, s.species, s.leave)
        } else if let (Some(g), Some((tri, hit))) = (&scene.ground, ground_hit) {
            let triangle = &g.mesh.triangles[tri as usize];
            let albedo = g.mesh.base_color(triangle, hit.w).truncate();
            let n = g.normal(tri, dir);
            super::matte::add(super::matte::TERRAIN, 1.0);
            (n, albedo, hit.t, 0.0, g.leave(tri, &hit, n, sun))
        } else {
            out.transmittance = 1.0;
            if let Some(sky) = scene.sky {
                super::matte::add(super::matte::SKY, 1.0);
                out.rgb = sky;
                out.transmittance = 0.0;
            }
            return out;
        };
    let lit = if normal.dot(sun) > 0.0 {
        out.shadow_rays = u32::from(scene.shadows);
        if scene.shadows && sun_hidden(scene, leave, shadow_key) {
            0.0
        } else {
            sun_radiance(scene)
        }
    } else {
        0.0
    };
    out.rgb = if species > 0.0 {
        shade(scene, albedo, Some(normal), lit, -dir)
    } else {
        shade_ground(scene, albedo, normal, lit)
    };
    out.distance = t;
    out.normal = normal;
    out.albedo = albedo;
    out.species = species;
    out.samples = 1;
    out
}
