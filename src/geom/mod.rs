//! Geometry shared by every stage: rays, boxes, triangles and the bounding volume hierarchy.

mod aabb;
mod bvh;
mod offset;
mod triangle;
mod triangles;

pub use aabb::Aabb;
pub use bvh::{Bvh, NodeContent};
pub use offset::{barycentric_point, gamma, offset_origin};
pub use triangle::{TriangleHit, intersect_triangle};
pub use triangles::TriangleBvh;

use glam::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}

/// The eight corners of the box `lo..hi`: corner `k` takes `hi` on axis `a` where bit `a` of
/// `k` is set (x fastest).
pub fn box_corners<T: Copy>(lo: [T; 3], hi: [T; 3]) -> [[T; 3]; 8] {
    std::array::from_fn(|k| std::array::from_fn(|a| if k >> a & 1 == 1 { hi[a] } else { lo[a] }))
}
