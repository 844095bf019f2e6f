//! Axis-aligned boxes and the slab test.

use glam::Vec3;

use super::Ray;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub lo: Vec3,
    pub hi: Vec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        lo: Vec3::splat(f32::INFINITY),
        hi: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn of_points(points: &[Vec3]) -> Aabb {
        points.iter().fold(Aabb::EMPTY, |b, &p| b.grow(p))
    }

    pub fn grow(self, p: Vec3) -> Aabb {
        Aabb {
            lo: self.lo.min(p),
            hi: self.hi.max(p),
        }
    }

    pub fn union(self, o: Aabb) -> Aabb {
        Aabb {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
        }
    }

    pub fn centre(&self) -> Vec3 {
        (self.lo + self.hi) * 0.5
    }

    pub fn surface_area(&self) -> f32 {
        let d = (self.hi - self.lo).max(Vec3::ZERO);
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }

    /// Parametric interval where `ray` is inside the box, clipped to [t_min, t_max]; `inv_dir`
    /// is 1 / ray.dir (infinite components are fine: IEEE arithmetic gives the right slabs).
    /// Each slab's planes are taken in the order the ray meets them, and clipped by
    /// comparisons, which are one instruction each where `f32::max`/`min` are several: a NaN
    /// (0 x infinity, a ray on a slab's plane and parallel to it) fails the comparison and
    /// leaves that slab unclipped, as the hierarchy's slab test does.
    #[inline]
    pub fn intersect(
        &self,
        ray: &Ray,
        inv_dir: Vec3,
        t_min: f32,
        t_max: f32,
    ) -> Option<(f32, f32)> {
        let (mut enter, mut exit) = (t_min, t_max);
        for a in 0..3 {
            let (near, far) = if inv_dir[a] < 0.0 {
                (self.hi[a], self.lo[a])
            } else {
                (self.lo[a], self.hi[a])
            };
            let t0 = (near - ray.origin[a]) * inv_dir[a];
            let t1 = (far - ray.origin[a]) * inv_dir[a];
            enter = if t0 > enter { t0 } else { enter };
            exit = if t1 < exit { t1 } else { exit };
        }
        (enter <= exit).then_some((enter, exit))
    }
}
