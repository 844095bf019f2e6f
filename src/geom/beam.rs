//! Items as rays along one direction see them. Each item's extent is projected on the plane
//! across the direction `w` and binned in a grid there. A ray along `w` keeps its place across
//! `w`, so it stays in one cell: the items it may meet are that cell's whose extents reach past
//! the ray's origin along `w`, found without descending a hierarchy. Within a cell they are
//! sorted by how far along `w` they reach, so those wholly behind the origin are passed over
//! by a binary search. Built once a frame for the sun's direction, it serves every shadow ray.

use glam::Vec3;

use super::Ray;

/// An item's extent: across `w` (`u0, u1, v0, v1`) and along it (`d0, d1`).
pub type Extent = [f32; 6];

#[derive(Clone, Debug)]
pub struct Beam {
    w: Vec3,
    across: [Vec3; 2],
    /// The grid's lower corner across `w`, its cell size, and its cells along each axis.
    lo: [f32; 2],
    cell: f32,
    dims: [usize; 2],
    /// Per cell, its entries `starts[c]..starts[c + 1]` of `entries`.
    starts: Vec<u32>,
    /// Per entry: the item and its extent.
    entries: Vec<(u32, Extent)>,
    /// Per entry, how far along `w` its extent reaches (`d1`): the key of the binary search,
    /// apart so that its probes read 4 bytes an entry, not 28.
    reach: Vec<f32>,
}

/// Most cells of a beam's grid (memory: 4 bytes each, and an entry per cell an item covers).
const CELLS: usize = 1 << 22;

impl Beam {
    /// The beam along the unit direction `w` of items given by their points (an item's extent
    /// is its points'; items with a point that is not finite are left out).
    pub fn new<'a>(w: Vec3, items: impl Iterator<Item = (u32, &'a [Vec3])>) -> Beam {
        let (a, b) = w.any_orthonormal_pair();
        let extents: Vec<(u32, Extent)> = items
            .filter_map(|(index, points)| {
                let mut e = [
                    f32::INFINITY,
                    f32::NEG_INFINITY,
                    f32::INFINITY,
                    f32::NEG_INFINITY,
                    f32::INFINITY,
                    f32::NEG_INFINITY,
                ];
                for p in points {
                    for (k, axis) in [a, b, w].into_iter().enumerate() {
                        let x = p.dot(axis);
                        e[2 * k] = e[2 * k].min(x);
                        e[2 * k + 1] = e[2 * k + 1].max(x);
                    }
                }
                e.iter().all(|x| x.is_finite()).then_some((index, e))
            })
            .collect();
        let mut beam = Beam {
            w,
            across: [a, b],
            lo: [0.0; 2],
            cell: 1.0,
            dims: [0, 0],
            starts: vec![0],
            entries: Vec::new(),
            reach: Vec::new(),
        };
        if extents.is_empty() {
            return beam;
        }
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        let mut size = 0.0f64;
        for (_, e) in &extents {
            for k in 0..2 {
                lo[k] = lo[k].min(e[2 * k]);
                hi[k] = hi[k].max(e[2 * k + 1]);
            }
            size += f64::from((e[1] - e[0]).max(e[3] - e[2]));
        }
        // Cells about one item across, as many as memory allows.
        let span = [hi[0] - lo[0], hi[1] - lo[1]];
        let mut cell = ((size / extents.len() as f64) as f32).max(1e-3);
        while (span[0] / cell).ceil() * (span[1] / cell).ceil() > CELLS as f32 {
            cell *= 2.0;
        }
        let dims = span.map(|s| ((s / cell).ceil() as usize).max(1));
        let range = |x0: f32, x1: f32, k: usize| {
            let c = |x: f32| (((x - lo[k]) / cell).floor().max(0.0) as usize).min(dims[k] - 1);
            c(x0)..=c(x1)
        };
        let mut counts = vec![0u32; dims[0] * dims[1] + 1];
        for (_, e) in &extents {
            for y in range(e[2], e[3], 1) {
                for x in range(e[0], e[1], 0) {
                    counts[x + dims[0] * y] += 1;
                }
            }
        }
        let mut starts = vec![0u32; counts.len()];
        for c in 1..counts.len() {
            starts[c] = starts[c - 1] + counts[c - 1];
        }
        let mut fill = starts.clone();
        let mut entries = vec![(0u32, [0.0f32; 6]); starts[dims[0] * dims[1]] as usize];
        for &(index, e) in &extents {
            for y in range(e[2], e[3], 1) {
                for x in range(e[0], e[1], 0) {
                    let c = x + dims[0] * y;
                    entries[fill[c] as usize] = (index, e);
                    fill[c] += 1;
                }
            }
        }
        for c in 0..dims[0] * dims[1] {
            entries[starts[c] as usize..starts[c + 1] as usize]
                .sort_unstable_by(|p, q| p.1[5].total_cmp(&q.1[5]));
        }
        beam.lo = lo;
        beam.cell = cell;
        beam.dims = dims;
        beam.starts = starts;
        beam.reach = entries.iter().map(|e| e.1[5]).collect();
        beam.entries = entries;
        beam
    }

    /// Whether `ray` runs along the beam (only such rays may use it).
    pub fn carries(&self, ray: &Ray) -> bool {
        ray.dir == self.w
    }

    /// Calls `f(i, t_max)` for every item whose extent the ray (along the beam, see
    /// [`Beam::carries`]) may meet before `t_max`, in no particular order; `f` returns `Some(t)`
    /// to shorten the ray to `t` (`Some(0.0)` ends the visit), `None` to go on.
    pub fn visit(&self, ray: &Ray, t_max: f32, mut f: impl FnMut(u32, f32) -> Option<f32>) {
        if self.entries.is_empty() {
            return;
        }
        let (u, v, d) = (
            ray.origin.dot(self.across[0]),
            ray.origin.dot(self.across[1]),
            ray.origin.dot(self.w),
        );
        let at = |x: f32, k: usize| {
            let c = ((x - self.lo[k]) / self.cell).floor();
            (c >= 0.0 && c < self.dims[k] as f32).then_some(c as usize)
        };
        let (Some(x), Some(y)) = (at(u, 0), at(v, 1)) else {
            return;
        };
        let c = x + self.dims[0] * y;
        let range = self.starts[c] as usize..self.starts[c + 1] as usize;
        let cell = &self.entries[range.clone()];
        // Items that end before the origin along `w` cannot be met.
        let first = self.reach[range].partition_point(|&r| r < d);
        let mut t_max = t_max;
        for &(i, e) in &cell[first..] {
            if u < e[0] || u > e[1] || v < e[2] || v > e[3] || e[4] - d > t_max {
                continue;
            }
            if let Some(t) = f(i, t_max) {
                if t <= 0.0 {
                    return;
                }
                t_max = t_max.min(t);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::{TriangleBvh, intersect_triangle};
    use crate::rng::Stream;

    /// Rays along a beam meet exactly the triangles the hierarchy says they meet (any hit),
    /// over a rough terrain of small triangles seen at a low sun, from points above, below and
    /// beside it.
    #[test]
    fn a_beam_finds_the_hits_the_hierarchy_finds() {
        let mut s = Stream::new(8, 0);
        let mut u = || s.unit() as f32;
        let n = 40;
        let h: Vec<f32> = (0..(n + 1) * (n + 1)).map(|_| u() * 6.0).collect();
        let p = |i: usize, j: usize| Vec3::new(i as f32 * 2.0, h[i + (n + 1) * j], j as f32 * 2.0);
        let mut corners = Vec::new();
        for j in 0..n {
            for i in 0..n {
                corners.push([p(i, j), p(i + 1, j), p(i, j + 1)]);
                corners.push([p(i + 1, j), p(i + 1, j + 1), p(i, j + 1)]);
            }
        }
        let w = Vec3::new(0.5, 0.25, -0.6).normalize();
        let beam = Beam::new(
            w,
            corners.iter().enumerate().map(|(i, c)| (i as u32, &c[..])),
        );
        let bvh = TriangleBvh::new(corners.clone());
        let mut hits = 0;
        for _ in 0..4000 {
            let ray = Ray {
                origin: Vec3::new(u() * 90.0 - 5.0, u() * 12.0 - 3.0, u() * 90.0 - 5.0),
                dir: w,
            };
            assert!(beam.carries(&ray));
            let t_max = if u() < 0.5 { f32::INFINITY } else { u() * 30.0 };
            let by_tree = bvh.occluded(&ray, 0.0, t_max, |_, _| true);
            let mut by_beam = false;
            beam.visit(&ray, t_max, |t, t_max| {
                by_beam = intersect_triangle(&ray, corners[t as usize], 0.0, t_max).is_some();
                by_beam.then_some(0.0)
            });
            assert_eq!(by_tree, by_beam, "from {} to {t_max}", ray.origin);
            hits += usize::from(by_beam);
        }
        assert!(hits > 500 && hits < 3500, "{hits} of 4000 rays hit");
    }
}
