//! A triangle soup with its BVH: nearest-hit and any-hit queries, with a filter deciding per
//! hit whether the surface is there (alpha masks).

use glam::Vec3;

use super::{Aabb, Bvh, Ray, TriangleHit, intersect_triangle};

pub struct TriangleBvh {
    corners: Vec<[Vec3; 3]>,
    bvh: Bvh,
}

impl TriangleBvh {
    pub fn new(corners: Vec<[Vec3; 3]>) -> TriangleBvh {
        let boxes: Vec<Aabb> = corners.iter().map(|c| Aabb::of_points(c)).collect();
        TriangleBvh {
            bvh: Bvh::build(&boxes),
            corners,
        }
    }

    pub fn bounds(&self) -> Aabb {
        self.bvh.bounds()
    }

    pub fn len(&self) -> usize {
        self.corners.len()
    }

    pub fn is_empty(&self) -> bool {
        self.corners.is_empty()
    }

    /// The nearest hit within (t_min, t_max) that `keep` accepts.
    pub fn nearest(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        mut keep: impl FnMut(u32, &TriangleHit) -> bool,
    ) -> Option<(u32, TriangleHit)> {
        let mut best = None;
        self.bvh.traverse(ray, t_min, t_max, |t, tmax| {
            let hit = intersect_triangle(ray, self.corners[t as usize], t_min, tmax)?;
            if !keep(t, &hit) {
                return None;
            }
            best = Some((t, hit));
            Some(hit.t)
        });
        best
    }

    /// Whether any hit within (t_min, t_max) is accepted by `keep`.
    pub fn occluded(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        mut keep: impl FnMut(u32, &TriangleHit) -> bool,
    ) -> bool {
        let mut hit = false;
        self.bvh.traverse(ray, t_min, t_max, |t, tmax| {
            let h = intersect_triangle(ray, self.corners[t as usize], t_min, tmax)?;
            if !keep(t, &h) {
                return None;
            }
            hit = true;
            Some(t_min)
        });
        hit
    }
}
