//! The mesh method against answers known in closed form, and against the texel method where
//! the two must agree.

use glam::{DVec3, Vec3, Vec4};

use super::mesh;
use super::scene::TreeMesh;
use super::scene::{Lighting, Look, Scene, Sun};
use super::tests::{HEAD_ON, PLAIN, ground, look, placed, uniform_texel};
use super::{Camera, Method, RenderSettings, render};
use crate::bake::{self, BakeSettings};
use crate::import::{AlphaMode, Material, Mesh};

/// A mesh of quads (corners counter-clockwise seen from the side they face), one material.
pub(crate) fn quads(quads: &[[Vec3; 4]], material: Material) -> Mesh {
    let positions = quads.iter().flatten().copied().collect();
    let triangles: Vec<[u32; 3]> = (0..quads.len() as u32)
        .flat_map(|q| [[0, 1, 2], [0, 2, 3]].map(|t| t.map(|v| 4 * q + v)))
        .collect();
    Mesh::plain(positions, &triangles, material)
}

pub(crate) fn material(name: &str, albedo: f32, alpha: f32, alpha_mode: AlphaMode) -> Material {
    Material {
        name: name.into(),
        base_color: Vec4::new(albedo, albedo, albedo, alpha),
        alpha_mode,
        ..Material::default()
    }
}

/// The six outward faces of the box `lo`..`hi`.
pub(crate) fn cuboid(lo: Vec3, hi: Vec3) -> Vec<[Vec3; 4]> {
    let c =
        |x: usize, y: usize, z: usize| Vec3::new([lo.x, hi.x][x], [lo.y, hi.y][y], [lo.z, hi.z][z]);
    vec![
        [c(0, 0, 1), c(1, 0, 1), c(1, 1, 1), c(0, 1, 1)], // +z
        [c(1, 0, 0), c(0, 0, 0), c(0, 1, 0), c(1, 1, 0)], // -z
        [c(1, 0, 1), c(1, 0, 0), c(1, 1, 0), c(1, 1, 1)], // +x
        [c(0, 0, 0), c(0, 0, 1), c(0, 1, 1), c(0, 1, 0)], // -x
        [c(0, 1, 1), c(1, 1, 1), c(1, 1, 0), c(0, 1, 0)], // +y
        [c(0, 0, 0), c(1, 0, 0), c(1, 0, 1), c(0, 0, 1)], // -y
    ]
}

/// One tree, drawn from `model` (whose texel is an empty box `lo`..`lo + 0.25 dims`).
fn scene_of(
    model: Mesh,
    foliage: bool,
    look: Look,
    (box_lo, dims): (DVec3, [usize; 3]),
    eye: DVec3,
    ground: Option<Mesh>,
    sun: Sun,
) -> Scene {
    let texel = uniform_texel(dims, 0.25, box_lo, 0.0, [0.5; 3]);
    let flags = vec![foliage; model.triangles.len()];
    Scene::new(
        eye,
        vec![texel],
        vec![look],
        &[placed(DVec3::ZERO)],
        ground,
        Lighting {
            sun,
            shading: PLAIN,
            sky: None,
        },
    )
    .with_meshes(vec![TreeMesh::new(model, flags)])
}

/// A square 4 m x 4 m in the plane z = 0, facing +z.
pub(super) const SQUARE: [Vec3; 4] = [
    Vec3::new(-2.0, -2.0, 0.0),
    Vec3::new(2.0, -2.0, 0.0),
    Vec3::new(2.0, 2.0, 0.0),
    Vec3::new(-2.0, 2.0, 0.0),
];

#[test]
fn a_lit_quad_gives_the_lambert_radiance_and_foliage_takes_the_season() {
    let wood = material("bark", 0.6, 1.0, AlphaMode::Opaque);
    let box_lo = DVec3::new(-2.0, -2.0, -1.0);
    let eye = DVec3::new(0.3, 0.2, 10.0);
    let at = |sun: Sun, foliage: bool, look: Look| {
        let s = scene_of(
            quads(&[SQUARE], wood.clone()),
            foliage,
            look,
            (box_lo, [16, 16, 8]),
            eye,
            None,
            sun,
        );
        mesh::radiance(&s, Vec3::NEG_Z, 1)
    };
    let r = at(HEAD_ON, false, look());
    assert!(
        (r.rgb - Vec3::splat(0.6)).abs().max_element() < 1e-5,
        "{r:?}"
    );
    assert_eq!(r.transmittance, 0.0);
    assert!((r.distance - 10.0).abs() < 1e-4);
    let oblique = Sun {
        direction: Vec3::new(0.0, 60f32.to_radians().sin(), 60f32.to_radians().cos()),
        ..HEAD_ON
    };
    let r = at(oblique, false, look());
    assert!((r.rgb.x - 0.3).abs() < 1e-5, "{r:?}");
    // Seen from behind, the quad is two-sided but the sun is on the other side: dark.
    let s = scene_of(
        quads(&[SQUARE], wood.clone()),
        false,
        look(),
        (box_lo, [16, 16, 8]),
        DVec3::new(0.3, 0.2, -10.0),
        None,
        HEAD_ON,
    );
    assert_eq!(mesh::radiance(&s, Vec3::Z, 1).rgb, Vec3::ZERO);
    // Foliage takes the day's colour; without leaves it is not there.
    let green = Look {
        foliage_albedo: Vec3::new(0.1, 0.5, 0.1),
        ..look()
    };
    let r = at(HEAD_ON, true, green);
    assert!((r.rgb - green.foliage_albedo).abs().max_element() < 1e-5);
    let bare = Look {
        foliage: 0.0,
        ..green
    };
    let r = at(HEAD_ON, true, bare);
    assert_eq!((r.rgb, r.transmittance), (Vec3::ZERO, 1.0));
}

#[test]
fn a_quad_shadows_the_ground_unless_its_alpha_masks_it_out() {
    let above = SQUARE.map(|p| Vec3::new(p.x, 10.0, p.y));
    // Facing up: counter-clockwise seen from +y.
    let above = [above[0], above[3], above[2], above[1]];
    let run = |alpha: f32| {
        let s = scene_of(
            quads(
                &[above],
                material("bark", 0.6, alpha, AlphaMode::Mask { cutoff: 0.5 }),
            ),
            false,
            look(),
            (DVec3::new(-2.0, 9.0, -2.0), [16, 8, 16]),
            DVec3::new(0.0, 5.0, 0.0),
            Some(ground(0.0, 50.0, 0.4)),
            Sun::from_angles(0.0, 90.0, std::f32::consts::PI),
        );
        let under = mesh::radiance(&s, Vec3::NEG_Y, 1).rgb.x;
        let beside = mesh::radiance(&s, Vec3::new(0.8, -0.6, 0.0).normalize(), 1)
            .rgb
            .x;
        let up = mesh::radiance(&s, Vec3::Y, 1);
        (under, beside, up)
    };
    let (under, beside, up) = run(1.0);
    assert_eq!(under, 0.0, "in the quad's shadow");
    assert!((beside - 0.4).abs() < 1e-5, "{beside}");
    assert!(up.transmittance == 0.0 && (up.distance - 5.0).abs() < 1e-4);
    // Alpha below the cutoff: neither the eye nor the sun sees the quad.
    let (under, beside, up) = run(0.2);
    assert!((under - 0.4).abs() < 1e-5 && (beside - 0.4).abs() < 1e-5);
    assert_eq!(up.transmittance, 1.0);
}

#[test]
fn an_opaque_box_baked_fine_renders_like_its_mesh() {
    let (lo, hi) = (Vec3::new(-1.0, 0.5, -1.0), Vec3::new(1.0, 2.5, 1.0));
    let model = quads(
        &cuboid(lo, hi),
        material("bark", 0.5, 1.0, AlphaMode::Opaque),
    );
    let texel = bake::bake(
        &model,
        &BakeSettings {
            resolution: 64,
            fine: 256,
            ..BakeSettings::default()
        },
    )
    .unwrap();
    let sun = Sun::from_angles(200.0, 40.0, std::f32::consts::PI);
    let scene = Scene::new(
        DVec3::new(4.0, 5.0, 6.0),
        vec![texel],
        vec![look()],
        &[placed(DVec3::ZERO)],
        Some(ground(0.0, 20.0, 0.3)),
        Lighting {
            sun,
            shading: super::Shading::default(),
            sky: None,
        },
    )
    .with_meshes(vec![TreeMesh::new(
        model.clone(),
        vec![false; model.triangles.len()],
    )]);
    let camera = Camera::look_at(scene.origin, DVec3::new(0.0, 1.5, 0.0), 30.0, 48, 48).unwrap();
    let image = |method| {
        render(
            &scene,
            &camera,
            &RenderSettings {
                method,
                spp: 16,
                ..RenderSettings::default()
            },
            &|_| {},
        )
    };
    let (texel, mesh) = (image(Method::Texel), image(Method::Mesh));
    let rms = |c: usize| {
        let e: f64 = texel
            .rgba
            .iter()
            .zip(&mesh.rgba)
            .map(|(a, b)| f64::from(a[c] - b[c]).powi(2))
            .sum();
        (e / texel.rgba.len() as f64).sqrt()
    };
    let mean = mesh.rgba.iter().map(|p| f64::from(p[1])).sum::<f64>() / mesh.rgba.len() as f64;
    println!(
        "texel vs mesh: rms R {:.4} G {:.4} A {:.4}; mean G {mean:.4}",
        rms(0),
        rms(1),
        rms(3)
    );
    assert!(rms(1) < 0.1 * mean, "{} vs mean {mean}", rms(1));
}

/// A leaf 5 cm in front of another, lit through it and seen from 1.5 km: the shadow ray from
/// the back leaf starts off its surface by the hit point's error bound (under a millimetre),
/// not by a fraction of the distance (15 cm, which would start it beyond the front leaf), so
/// the back leaf is exactly in shadow under the front one and exactly lit beside it.
#[test]
fn a_leaf_5_cm_behind_an_alpha_masked_leaf_is_in_its_shadow_from_afar() {
    let leaf = material("leaf", 0.6, 1.0, AlphaMode::Mask { cutoff: 0.5 });
    let front = [
        Vec3::new(0.0, -2.0, 0.05),
        Vec3::new(2.0, -2.0, 0.05),
        Vec3::new(2.0, 2.0, 0.05),
        Vec3::new(0.0, 2.0, 0.05),
    ];
    for distance in [10.0, 300.0, 1500.0] {
        // Seen from 30 degrees above the leaves' plane, from the side the front leaf leaves
        // open: the view ray passes under its edge to the back leaf.
        let side = DVec3::new(-(30f64.to_radians().cos()), 0.0, 30f64.to_radians().sin());
        let eye = side * distance;
        let s = scene_of(
            quads(&[SQUARE, front], leaf.clone()),
            true,
            look(),
            (DVec3::new(-2.0, -2.0, -1.0), [16, 16, 8]),
            eye,
            None,
            HEAD_ON,
        );
        let at = |x: f64| {
            let dir = (DVec3::new(x, 0.3, 0.0) - eye).normalize().as_vec3();
            mesh::radiance(&s, dir, 7)
        };
        let shadowed = at(0.02);
        let lit = at(-0.5);
        assert!(
            (shadowed.distance as f64 - (DVec3::new(0.02, 0.3, 0.0) - eye).length()).abs() < 0.01,
            "at {distance} m the view ray must reach the back leaf: {shadowed:?}"
        );
        assert_eq!(shadowed.rgb, Vec3::ZERO, "at {distance} m: {shadowed:?}");
        assert!(
            (lit.rgb - lit.albedo).abs().max_element() < 1e-4 && lit.albedo.x > 0.1,
            "at {distance} m: {lit:?}"
        );
        // Without shadows the back leaf is lit under the front one too.
        let mut s = s;
        s.shadows = false;
        let r = mesh::radiance(
            &s,
            (DVec3::new(0.02, 0.3, 0.0) - eye).normalize().as_vec3(),
            7,
        );
        assert_eq!((r.rgb, r.shadow_rays), (lit.rgb, 0), "at {distance} m");
    }
}
