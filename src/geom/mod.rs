//! Geometry shared by every stage: rays, boxes, triangles and the bounding volume hierarchy.

mod aabb;
mod bvh;
mod triangle;
mod triangles;

pub use aabb::Aabb;
pub use bvh::{Bvh, NodeContent};
pub use triangle::{TriangleHit, intersect_triangle};
pub use triangles::TriangleBvh;

use glam::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}
