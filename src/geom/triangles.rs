//! A triangle soup with its BVH: nearest-hit and any-hit queries, with a filter deciding per
//! hit whether the surface is there (alpha masks).
//!
//! Each leaf of the hierarchy (at most four triangles) is kept as one packet, corner and
//! edges axis by axis, so a ray meets a leaf's triangles in one pass of the same arithmetic
//! as [`intersect_triangle`], lane by lane: the hits, and so the images, are the same bits.

use glam::Vec3;

use super::bvh::{LEAF_SIZE, NumberedLeaves};
use super::{Aabb, Bvh, Ray, TriangleHit};

const LANES: usize = LEAF_SIZE;

/// Up to four triangles: the first corner and the two edges from it, axis by axis; unused
/// lanes have zero edges, which no ray hits (a zero determinant).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
struct Packet {
    p0: [[f32; LANES]; 3],
    e1: [[f32; LANES]; 3],
    e2: [[f32; LANES]; 3],
    /// The triangles' indices in the caller's list.
    id: [u32; LANES],
}

type Lanes = [f32; LANES];

fn cross(a: [Lanes; 3], b: [Lanes; 3]) -> [Lanes; 3] {
    let c = |i: usize, j: usize| -> Lanes {
        std::array::from_fn(|k| a[i][k] * b[j][k] - a[j][k] * b[i][k])
    };
    [c(1, 2), c(2, 0), c(0, 1)]
}

fn dot(a: [Lanes; 3], b: [Lanes; 3]) -> Lanes {
    std::array::from_fn(|k| a[0][k] * b[0][k] + a[1][k] * b[1][k] + a[2][k] * b[2][k])
}

impl Packet {
    /// Each lane's hit of `ray` within (t_min, t_max): (t, u, v) per lane, exactly as
    /// [`intersect_triangle`] computes them, and a bit per lane that is a hit. The tests are
    /// combined without short cuts, so they stay lane-parallel arithmetic.
    #[inline(always)]
    fn intersect(&self, ray: &Ray, t_min: f32, t_max: f32) -> ([Lanes; 3], u32) {
        let splat = |v: Vec3| -> [Lanes; 3] { [[v.x; LANES], [v.y; LANES], [v.z; LANES]] };
        let dir = splat(ray.dir);
        let pv = cross(dir, self.e2);
        let det = dot(self.e1, pv);
        let tv: [Lanes; 3] =
            std::array::from_fn(|a| std::array::from_fn(|k| ray.origin[a] - self.p0[a][k]));
        let inv: Lanes = std::array::from_fn(|k| 1.0 / det[k]);
        let u: Lanes = {
            let d = dot(tv, pv);
            std::array::from_fn(|k| d[k] * inv[k])
        };
        let qv = cross(tv, self.e1);
        let v: Lanes = {
            let d = dot(dir, qv);
            std::array::from_fn(|k| d[k] * inv[k])
        };
        let t: Lanes = {
            let d = dot(self.e2, qv);
            std::array::from_fn(|k| d[k] * inv[k])
        };
        let mut hits = 0;
        for k in 0..LANES {
            let ok = (det[k] != 0.0)
                & det[k].is_finite()
                & (u[k] >= 0.0)
                & (u[k] <= 1.0)
                & (v[k] >= 0.0)
                & (u[k] + v[k] <= 1.0)
                & (t[k] > t_min)
                & (t[k] < t_max);
            hits |= u32::from(ok) << k;
        }
        ([t, u, v], hits)
    }
}

#[derive(Clone, Debug)]
pub struct TriangleBvh {
    /// One per leaf of the hierarchy, by the leaf's number.
    packets: Vec<Packet>,
    tree: NumberedLeaves,
    triangles: usize,
}

impl TriangleBvh {
    pub fn new(corners: Vec<[Vec3; 3]>) -> TriangleBvh {
        let boxes: Vec<Aabb> = corners.iter().map(|c| Aabb::of_points(c)).collect();
        let (tree, leaves) = Bvh::build(&boxes).into_numbered_leaves();
        let packets = leaves
            .iter()
            .map(|ids| {
                let mut p = Packet::default();
                for (lane, &id) in ids.iter().enumerate() {
                    let [a, b, c] = corners[id as usize];
                    let (e1, e2) = (b - a, c - a);
                    for axis in 0..3 {
                        p.p0[axis][lane] = a[axis];
                        p.e1[axis][lane] = e1[axis];
                        p.e2[axis][lane] = e2[axis];
                    }
                    p.id[lane] = id;
                }
                p
            })
            .collect();
        TriangleBvh {
            packets,
            tree,
            triangles: corners.len(),
        }
    }

    pub fn bounds(&self) -> Aabb {
        self.tree.bounds()
    }

    pub fn len(&self) -> usize {
        self.triangles
    }

    pub fn is_empty(&self) -> bool {
        self.triangles == 0
    }

    /// Calls `keep` on the hits of leaf number `leaf` nearest first, until it accepts one:
    /// that hit.
    fn first_kept(
        &self,
        ray: &Ray,
        leaf: u32,
        t_min: f32,
        t_max: f32,
        keep: &mut impl FnMut(u32, &TriangleHit) -> bool,
    ) -> Option<(u32, TriangleHit)> {
        let packet = &self.packets[leaf as usize];
        let ([t, u, v], mut hits) = packet.intersect(ray, t_min, t_max);
        while hits != 0 {
            // The nearest hit left (the first lane of equals, as a scan in lane order finds).
            let mut lane = hits.trailing_zeros() as usize;
            let mut rest = hits & (hits - 1);
            while rest != 0 {
                let k = rest.trailing_zeros() as usize;
                if t[k] < t[lane] {
                    lane = k;
                }
                rest &= rest - 1;
            }
            let hit = TriangleHit {
                t: t[lane],
                w: [1.0 - u[lane] - v[lane], u[lane], v[lane]],
            };
            if keep(packet.id[lane], &hit) {
                return Some((packet.id[lane], hit));
            }
            hits &= !(1 << lane);
        }
        None
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
        self.tree.traverse(ray, t_min, t_max, |leaf, _, t_max| {
            let found = self.first_kept(ray, leaf, t_min, t_max, &mut keep)?;
            best = Some(found);
            Some(found.1.t)
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
        self.tree.traverse(ray, t_min, t_max, |leaf, _, t_max| {
            self.first_kept(ray, leaf, t_min, t_max, &mut keep)?;
            hit = true;
            Some(t_min)
        });
        hit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::intersect_triangle;
    use crate::rng::Stream;

    /// The packets give the scalar test's nearest hit, bit for bit, and a filter that drops
    /// every other triangle sees the same hits.
    #[test]
    fn packets_hit_as_the_scalar_test_does() {
        let mut s = Stream::new(9, 0);
        let mut r = || s.range(-10.0, 10.0) as f32;
        let tris: Vec<[Vec3; 3]> = (0..700)
            .map(|_| {
                let c = Vec3::new(r(), r(), r());
                [
                    c,
                    c + Vec3::new(r(), r(), r()) * 0.2,
                    c + Vec3::new(r(), r(), r()) * 0.2,
                ]
            })
            .collect();
        // Ten triangles on one spot: centres that coincide still make leaves of at most four.
        let mut tris = tris;
        tris.extend((0..10).map(|k| [Vec3::ZERO, Vec3::X, Vec3::Y + Vec3::Z * k as f32 * 0.01]));
        let bvh = TriangleBvh::new(tris.clone());
        for _ in 0..3000 {
            let ray = Ray {
                origin: Vec3::new(r(), r(), r()),
                dir: Vec3::new(r(), r(), r()).normalize(),
            };
            for odd_only in [false, true] {
                let keep = |t: u32| !odd_only || t % 2 == 1;
                let brute = tris
                    .iter()
                    .enumerate()
                    .filter(|(t, _)| keep(*t as u32))
                    .filter_map(|(t, c)| {
                        intersect_triangle(&ray, *c, 0.0, f32::INFINITY).map(|h| (t as u32, h))
                    })
                    .min_by(|a, b| a.1.t.total_cmp(&b.1.t));
                let fast = bvh.nearest(&ray, 0.0, f32::INFINITY, |t, _| keep(t));
                assert_eq!(brute, fast);
                let any = bvh.occluded(&ray, 0.0, f32::INFINITY, |t, _| keep(t));
                assert_eq!(any, brute.is_some());
            }
        }
    }
}
