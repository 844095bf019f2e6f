//! Shading both methods share: the result of a ray, and the paper's equation (3) for trees
//! and the terrain's Lambertian answer to the same light.

use glam::Vec3;

use super::scene::Scene;

/// The result of one ray: premultiplied radiance, what the sky sees through, and the
/// arbitrary output values at the ray's "surface": the first point where the opacity of what
/// it crossed (trees and terrain, not the sky) reaches half of that opacity's final value. So
/// every ray that meets anything has a finite surface, however faint (a compositor's depth of
/// field or fog needs one wherever alpha is above 0), and a ray through a dense crown has it
/// where the crown's opacity reaches a half.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Radiance {
    pub rgb: Vec3,
    /// Transmittance to the sky (0 where the terrain is hit).
    pub transmittance: f32,
    /// Distance along the ray to the surface; infinite where the ray met nothing.
    pub distance: f32,
    pub normal: Vec3,
    pub albedo: Vec3,
    /// Opacity of the trees alone.
    pub canopy: f32,
    /// The part of `canopy` drawn from polygon models (the rest is the textures').
    pub mesh_canopy: f32,
    /// The part of `canopy` drawn from trees in the hybrid method's transition band (drawn
    /// either way by chance), however they were drawn.
    pub band_canopy: f32,
    /// Species index + 1 of the densest tree at the surface, 0 for terrain or sky.
    pub species: f32,
    /// Work done: volume samples along the ray (steps that read a texture: a step where every
    /// texture's trilinear stencil is empty reads nothing and is not one), and shadow rays
    /// cast from it.
    pub samples: u32,
    pub shadow_rays: u32,
}

/// I_0: the sun's irradiance / pi, the radiance of a white Lambertian surface facing it.
pub fn sun_radiance(scene: &Scene) -> f32 {
    scene.sun.irradiance / std::f32::consts::PI
}

/// The terrain's answer to the light: Lambertian, lit by `light` and the ambient term.
pub fn shade_ground(scene: &Scene, albedo: Vec3, normal: Vec3, light: f32) -> Vec3 {
    let s = &scene.shading;
    albedo * (light * s.kd * normal.dot(scene.sun.direction).max(0.0) + s.ambient * s.kd)
}

/// Equation (3): albedo (I (kd cos theta + ks cos^n alpha) + Ia kd). Without a normal (no
/// density gradient) the cosine is replaced by its mean over the hemisphere facing the
/// light, 1/2, and there is no highlight.
pub fn shade(scene: &Scene, albedo: Vec3, normal: Option<Vec3>, light: f32, to_eye: Vec3) -> Vec3 {
    let direct = match normal {
        Some(n) => direct(scene, n, to_eye),
        None => 0.5 * scene.shading.kd,
    };
    lit(scene, albedo, light, direct)
}

/// [`shade`] for a cloud of leaves: its direct term the mean over the leaf `normals` drawn
/// for the sample (`render::leaves`).
pub fn shade_leaves(
    scene: &Scene,
    albedo: Vec3,
    normals: &[Vec3],
    light: f32,
    to_eye: Vec3,
) -> Vec3 {
    let sum: f32 = normals.iter().map(|&n| direct(scene, n, to_eye)).sum();
    lit(scene, albedo, light, sum / normals.len() as f32)
}

/// Equation (3) from its direct term: albedo (I direct + Ia kd).
fn lit(scene: &Scene, albedo: Vec3, light: f32, direct: f32) -> Vec3 {
    let s = &scene.shading;
    albedo * (light * direct + s.ambient * s.kd)
}

/// The direct term of equation (3) for a unit normal `n`: kd cos theta + ks cos^n alpha.
fn direct(scene: &Scene, n: Vec3, to_eye: Vec3) -> f32 {
    let s = &scene.shading;
    let l = scene.sun.direction;
    let cos = n.dot(l).max(0.0);
    let reflected = 2.0 * n.dot(l) * n - l;
    let highlight = if cos > 0.0 {
        reflected.dot(to_eye).max(0.0).powf(s.shininess)
    } else {
        0.0
    };
    s.kd * cos + s.ks * highlight
}
