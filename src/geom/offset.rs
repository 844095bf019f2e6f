//! Where a ray leaving a surface may start: off the surface by a bound on the floating-point
//! error of the hit point, so it cannot hit the surface it leaves, and no further, so it
//! still meets whatever lies just beyond (a leaf 5 cm behind another). This is pbrt-v4's
//! rule (Pharr, Jakob and Humphreys, *Physically Based Rendering*, 4th ed., section 6.8):
//! carry a conservative error bound with each computed point, offset the origin along the
//! normal by the bound's projection onto it, and round away from the surface.
//!
//! Offsets proportional to distance (1e-4 x distance) skip occluders: at 1.5 km that is 15 cm,
//! which lifts a shadow ray clean through the leaves in front of the one it leaves.

use glam::Vec3;

/// pbrt's `gamma(n)`: a bound on the relative error of `n` successive f32 operations, each
/// rounded to nearest (unit roundoff 2^-24).
pub fn gamma(n: u32) -> f32 {
    let e = n as f32 * (f32::EPSILON * 0.5);
    e / (1.0 - e)
}

/// The point at barycentric weights `w` of the triangle `p`, and a componentwise bound on its
/// rounding error: `gamma(7) * sum |w_i p_i|` (pbrt-v4 equation 6.30; barycentric
/// interpolation is far more accurate than `o + t d` far from the origin).
pub fn barycentric_point(p: [Vec3; 3], w: [f32; 3]) -> (Vec3, Vec3) {
    let point = p[0] * w[0] + p[1] * w[1] + p[2] * w[2];
    let error = ((p[0] * w[0]).abs() + (p[1] * w[1]).abs() + (p[2] * w[2]).abs()) * gamma(7);
    (point, error)
}

/// The origin for a ray leaving `p` (error bound `error`, geometric normal `n`) in direction
/// `w`: `p` moved to the side of the surface `w` points into, by `|n| . error` along `n`, each
/// coordinate rounded one more float away from the surface.
pub fn offset_origin(p: Vec3, error: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let d = n.abs().dot(error);
    let offset = if n.dot(w) < 0.0 { -n * d } else { n * d };
    let mut o = p + offset;
    for i in 0..3 {
        if offset[i] > 0.0 {
            o[i] = o[i].next_up();
        } else if offset[i] < 0.0 {
            o[i] = o[i].next_down();
        }
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{Ray, intersect_triangle};

    /// Shadow rays leaving random points of long thin triangles far from the origin, in
    /// random directions into the lit side, never hit the triangle they leave; and the offset
    /// is tiny next to the old 1e-4 x distance rule.
    #[test]
    fn offset_rays_never_hit_their_own_triangle_and_stay_close() {
        let mut worst = 0.0f32;
        for k in 0..20_000u64 {
            let u = |j: u64| crate::rng::unit(crate::rng::hash3(k, j, 0x0ff5e7)) as f32;
            let far = 10f32.powf(u(0) * 3.5); // 1 m .. 3 km from the origin
            let centre = Vec3::new(u(1) - 0.5, u(2) * 0.3, u(3) - 0.5).normalize() * far;
            let edge =
                |j: u64| Vec3::new(u(j) - 0.5, u(j + 1) - 0.5, u(j + 2) - 0.5) * (0.01 + u(j + 3));
            let p = [centre, centre + edge(4), centre + edge(8)];
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            if n.length() < 1e-6 {
                continue;
            }
            let n = n.normalize();
            let (a, b) = (u(12), u(13));
            let w = if a + b > 1.0 {
                [a + b - 1.0, 1.0 - a, 1.0 - b]
            } else {
                [1.0 - a - b, a, b]
            };
            let (point, error) = barycentric_point(p, w);
            let side = if u(14) < 0.5 { n } else { -n };
            let dir = (side + Vec3::new(u(15) - 0.5, u(16) - 0.5, u(17) - 0.5))
                .try_normalize()
                .filter(|d| d.dot(side) > 1e-3);
            let Some(dir) = dir else { continue };
            let origin = offset_origin(point, error, n, dir);
            let ray = Ray { origin, dir };
            assert!(
                intersect_triangle(&ray, p, 0.0, f32::INFINITY).is_none(),
                "case {k}: a ray leaving {point} at {far} m hits its own triangle"
            );
            worst = worst.max((origin - point).length() / far);
        }
        assert!(worst < 1e-5, "offset {worst} x distance");
    }
}
