//! Ray-triangle intersection (Moller-Trumbore), double-sided.

use glam::Vec3;

use super::Ray;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    pub t: f32,
    /// Barycentric weights of the three corners.
    pub w: [f32; 3],
}

pub fn intersect_triangle(ray: &Ray, p: [Vec3; 3], t_min: f32, t_max: f32) -> Option<TriangleHit> {
    let e1 = p[1] - p[0];
    let e2 = p[2] - p[0];
    let pv = ray.dir.cross(e2);
    let det = e1.dot(pv);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let tv = ray.origin - p[0];
    let u = tv.dot(pv) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let qv = tv.cross(e1);
    let v = ray.dir.dot(qv) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(qv) * inv;
    (t > t_min && t < t_max).then_some(TriangleHit {
        t,
        w: [1.0 - u - v, u, v],
    })
}
