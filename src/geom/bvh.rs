//! A bounding volume hierarchy over any primitives that have boxes: binned surface-area
//! heuristic build, stack traversal nearest child first. Primitives are tested by a closure,
//! so the same tree serves triangles, instance boxes and terrain.

use glam::Vec3;

use super::{Aabb, Ray};

const BINS: usize = 12;
const LEAF_SIZE: usize = 4;

#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: Aabb,
    /// Leaf: first index into `order`; inner: index of the left child (right = left + 1).
    start: u32,
    /// Leaf: number of primitives; inner: 0.
    count: u32,
}

/// What a node holds: two child nodes, or primitive indices.
pub enum NodeContent<'a> {
    Inner(u32, u32),
    Leaf(&'a [u32]),
}

#[derive(Clone, Debug)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Primitive indices, leaves' ranges point into it.
    order: Vec<u32>,
}

impl Bvh {
    pub fn build(boxes: &[Aabb]) -> Bvh {
        let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
        let centres: Vec<Vec3> = boxes.iter().map(Aabb::centre).collect();
        let root = Node {
            bounds: boxes.iter().fold(Aabb::EMPTY, |b, x| b.union(*x)),
            start: 0,
            count: boxes.len() as u32,
        };
        let mut nodes = vec![root];
        let mut todo = vec![0usize];
        while let Some(n) = todo.pop() {
            let Node { start, count, .. } = nodes[n];
            if count as usize <= LEAF_SIZE {
                continue;
            }
            let range = start as usize..(start + count) as usize;
            let Some(mid) = split(boxes, &centres, &mut order[range.clone()]) else {
                continue;
            };
            let mid = range.start + mid;
            let bounds_of = |r: std::ops::Range<usize>| {
                order[r]
                    .iter()
                    .fold(Aabb::EMPTY, |b, &i| b.union(boxes[i as usize]))
            };
            let left = nodes.len();
            nodes.push(Node {
                bounds: bounds_of(range.start..mid),
                start: range.start as u32,
                count: (mid - range.start) as u32,
            });
            nodes.push(Node {
                bounds: bounds_of(mid..range.end),
                start: mid as u32,
                count: (range.end - mid) as u32,
            });
            nodes[n].start = left as u32;
            nodes[n].count = 0;
            todo.push(left);
            todo.push(left + 1);
        }
        Bvh { nodes, order }
    }

    pub fn bounds(&self) -> Aabb {
        self.nodes[0].bounds
    }

    /// Node `i` (0 is the root) for callers that walk the tree themselves: its box and either
    /// its two children or its primitives. `None` for an empty tree.
    pub fn node(&self, i: u32) -> Option<(Aabb, NodeContent<'_>)> {
        if self.order.is_empty() {
            return None;
        }
        let n = self.nodes.get(i as usize)?;
        let content = if n.count > 0 {
            NodeContent::Leaf(&self.order[n.start as usize..(n.start + n.count) as usize])
        } else {
            NodeContent::Inner(n.start, n.start + 1)
        };
        Some((n.bounds, content))
    }

    /// Walks the nodes `ray` crosses within (t_min, t_max), nearest first, calling `test` on
    /// each primitive with the current t_max. `test` returns a smaller t_max when it finds a
    /// hit; returning one <= t_min stops the walk (an any-hit query). Returns the final t_max.
    pub fn traverse(
        &self,
        ray: &Ray,
        t_min: f32,
        mut t_max: f32,
        mut test: impl FnMut(u32, f32) -> Option<f32>,
    ) -> f32 {
        if self.order.is_empty() {
            return t_max;
        }
        let inv = ray.dir.recip();
        let mut stack = [0u32; 64];
        let mut top = 0;
        let mut node = 0usize;
        if self.nodes[0]
            .bounds
            .intersect(ray, inv, t_min, t_max)
            .is_none()
        {
            return t_max;
        }
        loop {
            let n = self.nodes[node];
            if n.count > 0 {
                for &p in &self.order[n.start as usize..(n.start + n.count) as usize] {
                    if let Some(t) = test(p, t_max) {
                        t_max = t_max.min(t);
                        if t_max <= t_min {
                            return t_max;
                        }
                    }
                }
            } else {
                let (l, r) = (n.start as usize, n.start as usize + 1);
                let hl = self.nodes[l].bounds.intersect(ray, inv, t_min, t_max);
                let hr = self.nodes[r].bounds.intersect(ray, inv, t_min, t_max);
                match (hl, hr) {
                    (Some(a), Some(b)) => {
                        let (near, far) = if a.0 <= b.0 { (l, r) } else { (r, l) };
                        if top < stack.len() {
                            stack[top] = far as u32;
                            top += 1;
                        }
                        node = near;
                        continue;
                    }
                    (Some(_), None) => {
                        node = l;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = r;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            if top == 0 {
                return t_max;
            }
            top -= 1;
            node = stack[top] as usize;
        }
    }
}

/// Partitions `order` by the cheapest binned SAH plane; `None` when no split beats a leaf
/// (all centres coincide).
fn split(boxes: &[Aabb], centres: &[Vec3], order: &mut [u32]) -> Option<usize> {
    let cb = order
        .iter()
        .fold(Aabb::EMPTY, |b, &i| b.grow(centres[i as usize]));
    let extent = cb.hi - cb.lo;
    let mut best: Option<(f32, usize, usize)> = None; // cost, axis, bin
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let bin_of = |i: u32| {
            (((centres[i as usize][axis] - cb.lo[axis]) / extent[axis] * BINS as f32) as usize)
                .min(BINS - 1)
        };
        let mut bins = [(Aabb::EMPTY, 0u32); BINS];
        for &i in order.iter() {
            let b = &mut bins[bin_of(i)];
            b.0 = b.0.union(boxes[i as usize]);
            b.1 += 1;
        }
        let mut right = [(0.0f32, 0u32); BINS];
        let (mut acc, mut n) = (Aabb::EMPTY, 0);
        for k in (1..BINS).rev() {
            acc = acc.union(bins[k].0);
            n += bins[k].1;
            right[k] = (acc.surface_area(), n);
        }
        let (mut acc, mut n) = (Aabb::EMPTY, 0);
        for k in 0..BINS - 1 {
            acc = acc.union(bins[k].0);
            n += bins[k].1;
            let (ra, rn) = right[k + 1];
            if n == 0 || rn == 0 {
                continue;
            }
            let cost = acc.surface_area() * n as f32 + ra * rn as f32;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, k));
            }
        }
    }
    let (_, axis, k) = best?;
    let threshold = |i: u32| {
        (((centres[i as usize][axis] - cb.lo[axis]) / extent[axis] * BINS as f32) as usize)
            .min(BINS - 1)
            <= k
    };
    // Stable partition keeps the build deterministic and independent of unstable sort order.
    let (left, right): (Vec<u32>, Vec<u32>) = order.iter().partition(|&&i| threshold(i));
    let mid = left.len();
    order[..mid].copy_from_slice(&left);
    order[mid..].copy_from_slice(&right);
    Some(mid)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::intersect_triangle;
    use crate::rng::Stream;

    #[test]
    fn nearest_hit_matches_brute_force() {
        let mut s = Stream::new(5, 0);
        let mut r = || s.range(-10.0, 10.0) as f32;
        let tris: Vec<[Vec3; 3]> = (0..500)
            .map(|_| {
                let c = Vec3::new(r(), r(), r());
                [
                    c,
                    c + Vec3::new(r(), r(), r()) * 0.1,
                    c + Vec3::new(r(), r(), r()) * 0.1,
                ]
            })
            .collect();
        let boxes: Vec<Aabb> = tris.iter().map(|t| Aabb::of_points(t)).collect();
        let bvh = Bvh::build(&boxes);
        for _ in 0..2000 {
            let ray = Ray {
                origin: Vec3::new(r(), r(), r()),
                dir: Vec3::new(r(), r(), r()).normalize(),
            };
            let brute = tris
                .iter()
                .filter_map(|t| intersect_triangle(&ray, *t, 0.0, f32::INFINITY))
                .map(|h| h.t)
                .fold(f32::INFINITY, f32::min);
            let fast = bvh.traverse(&ray, 0.0, f32::INFINITY, |i, tmax| {
                intersect_triangle(&ray, tris[i as usize], 0.0, tmax).map(|h| h.t)
            });
            assert_eq!(brute, fast);
        }
    }
}
