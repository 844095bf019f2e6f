use glam::{DMat4, DQuat, DVec3, Mat4, Quat, Vec3};

use super::*;
use crate::render::Placed;
use crate::rng::Stream;

/// What a viewer does with an instanced node under identity parents: the instance's
/// translation, rotation and scale (as written, in f32) applied to a mesh-space point.
fn viewer_point(t: DVec3, r: DQuat, s: DVec3, p: Vec3) -> Vec3 {
    Mat4::from_scale_rotation_translation(s.as_vec3(), r.normalize().as_quat(), t.as_vec3())
        .transform_point3(p)
}

/// Each tree's instance transform, composed with the transform a model's hierarchy gives a
/// mesh (rotated, scaled non-uniformly, moved, even mirrored), puts every point of the mesh
/// where the renderer's own transform of the tree puts the model-space point.
#[test]
fn instances_put_a_meshs_points_where_the_renderer_draws_them() {
    let mut s = Stream::new(15, 0);
    let mut u = || s.unit();
    let meshes = [
        DMat4::IDENTITY,
        DMat4::from_scale_rotation_translation(
            DVec3::new(0.5, 2.0, 1.5),
            DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 0.7),
            DVec3::new(0.2, -0.05, 1.0),
        ),
        DMat4::from_scale_rotation_translation(
            DVec3::new(-1.0, 1.0, 1.0),
            DQuat::from_rotation_x(-std::f64::consts::FRAC_PI_2),
            DVec3::new(0.0, 3.0, 0.0),
        ),
    ];
    for k in 0..200 {
        let placed = Placed {
            look: 0,
            position: DVec3::new(u() * 2000.0 - 1000.0, u() * 800.0, u() * 2000.0 - 1000.0),
            rotation: (u() * std::f64::consts::TAU) as f32,
            scale: (0.2 + u() * 5.0) as f32,
        };
        let tree = placed.transform(0, DVec3::ZERO);
        let mesh = meshes[k % meshes.len()];
        let (t, r, sc) = decompose(&(tree.world_from_model() * mesh)).expect("a TRS");
        for _ in 0..8 {
            let p = Vec3::new(u() as f32 - 0.5, u() as f32 * 4.0, u() as f32 - 0.5);
            let model = mesh.transform_point3(p.as_dvec3()).as_vec3();
            let (renderer, _) = tree.point_to_world(model, Vec3::ZERO);
            let exported = viewer_point(t, r, sc, p);
            let size = renderer.abs().max_element().max(1.0);
            assert!(
                (exported - renderer).abs().max_element() <= 2e-6 * size,
                "tree {k}: exported {exported}, rendered {renderer}"
            );
        }
    }
}

/// The tree's own transform is a turn about +Y, counter-clockwise seen from above: +X turns
/// towards -Z.
#[test]
fn a_quarter_turn_takes_x_to_minus_z() {
    let placed = Placed {
        look: 0,
        position: DVec3::new(10.0, 2.0, -3.0),
        rotation: std::f32::consts::FRAC_PI_2,
        scale: 2.0,
    };
    let m = placed.transform(0, DVec3::ZERO).world_from_model();
    let p = m.transform_point3(DVec3::X);
    assert!((p - DVec3::new(10.0, 2.0, -5.0)).length() < 1e-6, "{p}");
    let (_, r, s) = decompose(&m).unwrap();
    assert!((s - DVec3::splat(2.0)).length() < 1e-6);
    let q = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2).as_dquat();
    assert!(r.dot(q).abs() > 1.0 - 1e-6, "{r}");
}

/// A transform with shear is no TRS, and is refused rather than written wrong.
#[test]
fn a_sheared_transform_is_not_a_trs() {
    let parent = DMat4::from_scale(DVec3::new(1.0, 3.0, 1.0));
    let child = DMat4::from_rotation_z(0.5);
    assert!(decompose(&(parent * child)).is_none());
    assert!(decompose(&(child * parent)).is_some());
}
