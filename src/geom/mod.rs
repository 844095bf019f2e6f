//! Geometry shared by every stage: rays, boxes, triangles, the bounding volume hierarchy, and
//! beams (items binned across one direction, for the sun's rays).

mod aabb;
mod beam;
mod bvh;
mod offset;
mod triangle;
mod triangles;

pub use aabb::Aabb;
pub use beam::Beam;
pub use bvh::{Bvh, MAX_PRIMITIVES, NodeContent, SlabRay};
pub use offset::{barycentric_point, gamma, offset_origin};
pub use triangle::{TriangleHit, intersect_triangle};
pub use triangles::TriangleBvh;

use glam::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}

/// The unit direction of `v`, or zero where it has none (zero or not finite). A vector whose
/// squared length would overflow or underflow f64 (components beyond 1e154, or all below
/// 1e-154) is scaled first, so a far target still gives a direction; others are not, so that
/// their directions keep their bits.
pub fn direction(v: glam::DVec3) -> glam::DVec3 {
    let largest = v.abs().max_element();
    let v = if largest > 1e150 || (largest > 0.0 && largest < 1e-150) {
        v / largest
    } else {
        v
    };
    v.normalize_or_zero()
}

/// The eight corners of the box `lo..hi`: corner `k` takes `hi` on axis `a` where bit `a` of
/// `k` is set (x fastest).
pub fn box_corners<T: Copy>(lo: [T; 3], hi: [T; 3]) -> [[T; 3]; 8] {
    std::array::from_fn(|k| std::array::from_fn(|a| if k >> a & 1 == 1 { hi[a] } else { lo[a] }))
}

/// `n` unit directions spread evenly over the sphere (a Fibonacci lattice), the same for every
/// caller.
pub fn sphere_lattice(n: usize) -> impl Iterator<Item = Vec3> {
    (0..n).map(move |i| {
        let y = 1.0 - (2.0 * i as f32 + 1.0) / n as f32;
        let r = (1.0 - y * y).max(0.0).sqrt();
        let phi = i as f32 * 2.399_963; // the golden angle, radians
        Vec3::new(r * phi.cos(), y, r * phi.sin())
    })
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    /// A direction too long or too short to square still has a direction; an ordinary one keeps
    /// its bits.
    #[test]
    fn directions_of_vectors_beyond_f64s_square_are_found() {
        let far = super::direction(DVec3::new(1e200, 0.0, -1e200));
        let expected = DVec3::new(1.0, 0.0, -1.0).normalize();
        assert!((far - expected).length() < 1e-15, "{far}");
        let v = DVec3::new(3.0, 4.0, 12.0);
        assert_eq!(super::direction(v), v.normalize());
        assert_eq!(super::direction(DVec3::ZERO), DVec3::ZERO);
        assert_eq!(super::direction(DVec3::new(1e-170, 0.0, 0.0)), DVec3::X);
        assert_eq!(
            super::direction(DVec3::new(f64::INFINITY, 0.0, 0.0)),
            DVec3::ZERO
        );
    }
}
