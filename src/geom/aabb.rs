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
    /// is 1 / ray.dir (infinite components are fine: IEEE arithmetic gives the right slabs,
    /// and `min`/`max` drop the NaN of 0 x infinity for a ray on a slab's plane).
    pub fn intersect(
        &self,
        ray: &Ray,
        inv_dir: Vec3,
        t_min: f32,
        t_max: f32,
    ) -> Option<(f32, f32)> {
        let t0 = (self.lo - ray.origin) * inv_dir;
        let t1 = (self.hi - ray.origin) * inv_dir;
        let near = t0.min(t1);
        let far = t0.max(t1);
        let enter = near.x.max(near.y).max(near.z).max(t_min);
        let exit = far.x.min(far.y).min(far.z).min(t_max);
        (enter <= exit).then_some((enter, exit))
    }
}
