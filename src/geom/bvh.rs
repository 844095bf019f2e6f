//! A bounding volume hierarchy over any primitives that have boxes. Built as a binary tree by
//! the binned surface-area heuristic, then collapsed into a tree of four-wide nodes that keep
//! their children's boxes side by side (axis by axis), so one ray meets four boxes in one pass
//! of straight-line arithmetic the compiler turns into vector instructions, and never
//! re-derives a box from a pointer. Traversal visits children nearest first and drops those
//! that start beyond the nearest hit found so far. Primitives are tested by a closure, so the
//! same tree serves triangles, instance boxes and terrain.

use glam::Vec3;

use super::{Aabb, Ray};

const BINS: usize = 12;
/// The most primitives a leaf holds.
pub const LEAF_SIZE: usize = 4;
const WIDTH: usize = 4;
/// Below this depth of the binary build, splits are by surface area; deeper, by the median,
/// which halves the count each time: the tree's depth stays below 48 + 32 whatever the input
/// (and its build time n log n).
const SAH_DEPTH: u32 = 48;
/// Waiting children a traversal keeps on the stack before spilling to the heap.
const STACK: usize = 12;

/// A node of the binary build.
#[derive(Clone, Copy, Debug)]
struct Binary {
    bounds: Aabb,
    /// Leaf: first index into `order`; inner: index of the left child (right = left + 1).
    start: u32,
    /// Leaf: number of primitives; inner: 0.
    count: u32,
}

/// Four children: their boxes axis by axis (`lo[axis][k]`), and what each is. A slot with
/// `count == 0` is the inner node `start`; `count > 0` the primitives `order[start..][..count]`;
/// an unused slot has an empty box (+inf..-inf), which no ray enters, and `start == EMPTY`.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Wide {
    lo: [[f32; WIDTH]; 3],
    hi: [[f32; WIDTH]; 3],
    start: [u32; WIDTH],
    count: [u32; WIDTH],
}

const EMPTY: u32 = u32::MAX;

impl Wide {
    const UNUSED: Wide = Wide {
        lo: [[f32::INFINITY; WIDTH]; 3],
        hi: [[f32::NEG_INFINITY; WIDTH]; 3],
        start: [EMPTY; WIDTH],
        count: [0; WIDTH],
    };

    fn set(&mut self, k: usize, b: Aabb, start: u32, count: u32) {
        for a in 0..3 {
            self.lo[a][k] = b.lo[a];
            self.hi[a][k] = b.hi[a];
        }
        self.start[k] = start;
        self.count[k] = count;
    }

    /// The slots in use.
    #[cfg(test)]
    fn used(&self) -> impl Iterator<Item = usize> + '_ {
        (0..WIDTH).filter(|&k| self.start[k] != EMPTY)
    }
}

/// What a child slot holds: an inner node, or primitive indices.
pub enum NodeContent<'a> {
    Inner(u32),
    Leaf(&'a [u32]),
}

/// A ray prepared for slab tests: per axis, which of a box's two planes it meets first.
pub struct SlabRay {
    origin: [f32; 3],
    inv: [f32; 3],
    negative: [bool; 3],
}

impl SlabRay {
    pub fn new(ray: &Ray) -> SlabRay {
        let inv = ray.dir.recip();
        SlabRay {
            origin: ray.origin.to_array(),
            inv: inv.to_array(),
            negative: [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0],
        }
    }

    /// Where the ray enters each of `node`'s four boxes within [t_min, t_max], and a bit per
    /// box it meets. The same arithmetic as [`Aabb::intersect`], which drops the NaN of
    /// 0 x infinity for a ray on a slab's plane.
    #[inline(always)]
    fn enter(&self, node: &Wide, t_min: f32, t_max: f32) -> ([f32; WIDTH], u32) {
        let mut enter = [t_min; WIDTH];
        let mut exit = [t_max; WIDTH];
        for a in 0..3 {
            let (near, far) = if self.negative[a] {
                (&node.hi[a], &node.lo[a])
            } else {
                (&node.lo[a], &node.hi[a])
            };
            for k in 0..WIDTH {
                // Written as comparisons, which are one vector instruction each; f32::max and
                // min are several, to give NaN meaning. A NaN here (0 x infinity) fails the
                // comparison and is dropped, as f32::max/min drop it.
                let (t0, t1) = (
                    (near[k] - self.origin[a]) * self.inv[a],
                    (far[k] - self.origin[a]) * self.inv[a],
                );
                enter[k] = if t0 > enter[k] { t0 } else { enter[k] };
                exit[k] = if t1 < exit[k] { t1 } else { exit[k] };
            }
        }
        let mut met = 0;
        for k in 0..WIDTH {
            met |= u32::from(enter[k] <= exit[k]) << k;
        }
        (enter, met)
    }
}

#[derive(Clone, Debug)]
pub struct Bvh {
    /// The root is node 0; an empty tree has one node with every slot unused.
    nodes: Vec<Wide>,
    /// Primitive indices, leaves' ranges point into it.
    order: Vec<u32>,
    bounds: Aabb,
}

impl Bvh {
    /// Panics with more than [`MAX_PRIMITIVES`] boxes (the limits on trees and triangles keep
    /// inputs far below it).
    pub fn build(boxes: &[Aabb]) -> Bvh {
        assert!(
            boxes.len() <= MAX_PRIMITIVES,
            "a hierarchy holds at most {MAX_PRIMITIVES} primitives"
        );
        let (binary, order) = build_binary(boxes);
        let mut nodes = vec![Wide::UNUSED];
        if !order.is_empty() {
            collapse(&binary, &mut nodes);
        }
        Bvh {
            nodes,
            order,
            bounds: binary[0].bounds,
        }
    }

    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Primitive indices in the order the leaves hold them.
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// The children of inner node `n` (0 is the root) that `slab`'s ray enters within
    /// [0, t_max], for callers that walk the tree themselves: where the ray enters each, and
    /// what it holds.
    pub fn entered(
        &self,
        n: u32,
        slab: &SlabRay,
        t_max: f32,
    ) -> impl Iterator<Item = (f32, NodeContent<'_>)> {
        let node = &self.nodes[n as usize];
        let (enter, met) = slab.enter(node, 0.0, t_max);
        (0..WIDTH)
            .filter(move |k| met & (1 << k) != 0)
            .map(move |k| {
                let content = if node.count[k] == 0 {
                    NodeContent::Inner(node.start[k])
                } else {
                    let s = node.start[k] as usize;
                    NodeContent::Leaf(&self.order[s..s + node.count[k] as usize])
                };
                (enter[k], content)
            })
    }

    /// Walks the nodes `ray` crosses within (t_min, t_max), nearest first, calling `test` on
    /// each primitive with the current t_max. `test` returns a smaller t_max when it finds a
    /// hit; returning one <= t_min stops the walk (an any-hit query). Returns the final t_max.
    pub fn traverse(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        mut test: impl FnMut(u32, f32) -> Option<f32>,
    ) -> f32 {
        walk(&self.nodes, ray, t_min, t_max, |start, count, mut t_max| {
            let mut hit = None;
            for &p in &self.order[start as usize..(start + count) as usize] {
                if let Some(t) = test(p, t_max) {
                    t_max = t_max.min(t);
                    hit = Some(t_max);
                    if t_max <= t_min {
                        break;
                    }
                }
            }
            hit
        })
    }

    /// The same tree with its leaves numbered 0, 1, 2..., for a caller that keeps each leaf's
    /// primitives together in an array of its own: a ray then reaches a leaf's data in one
    /// fetch, not through [`Bvh::order`]. Returns each leaf's primitives, by number.
    pub fn into_numbered_leaves(self) -> (NumberedLeaves, Vec<Vec<u32>>) {
        let Bvh {
            mut nodes,
            order,
            bounds,
        } = self;
        let mut leaves = Vec::new();
        for node in &mut nodes {
            for k in 0..WIDTH {
                if node.start[k] != EMPTY && node.count[k] > 0 {
                    let (s, c) = (node.start[k] as usize, node.count[k] as usize);
                    node.start[k] = leaves.len() as u32;
                    leaves.push(order[s..s + c].to_vec());
                }
            }
        }
        (NumberedLeaves { nodes, bounds }, leaves)
    }
}

/// A hierarchy whose leaves are numbered (see [`Bvh::into_numbered_leaves`]).
#[derive(Clone, Debug)]
pub struct NumberedLeaves {
    nodes: Vec<Wide>,
    bounds: Aabb,
}

impl NumberedLeaves {
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// [`Bvh::traverse`] a leaf at a time: `test(leaf, count, t_max)` tests the leaf's
    /// `count` primitives together, for callers that keep a leaf's data as one packet.
    pub fn traverse(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        test: impl FnMut(u32, u32, f32) -> Option<f32>,
    ) -> f32 {
        walk(&self.nodes, ray, t_min, t_max, test)
    }
}

/// Walks `nodes` (the root first) along `ray` within (t_min, t_max), nearest child first,
/// calling `test(start, count, t_max)` on each leaf reached before the nearest hit so far.
fn walk(
    nodes: &[Wide],
    ray: &Ray,
    t_min: f32,
    mut t_max: f32,
    mut test: impl FnMut(u32, u32, f32) -> Option<f32>,
) -> f32 {
    let slab = SlabRay::new(ray);
    let mut waiting = Waiting::new();
    let (mut start, mut count) = (0u32, 0u32);
    loop {
        if count == 0 {
            let node = &nodes[start as usize];
            let (enter, mut met) = slab.enter(node, t_min, t_max);
            // The common cases (none met, one met) first, free of branches that depend on
            // each child (and of a bit count, which baseline x86-64 has no instruction for).
            if met == 0 {
                // Nothing here: on to the waiting children.
            } else if met & (met - 1) == 0 {
                let k = met.trailing_zeros() as usize;
                (start, count) = (node.start[k], node.count[k]);
                continue;
            } else {
                // The children met, nearest first: an insertion sort of at most four,
                // stable, so equally near children keep their slots' order.
                let mut hits = [(0f32, 0usize); WIDTH];
                let mut n = 0;
                while met != 0 {
                    let k = met.trailing_zeros() as usize;
                    met &= met - 1;
                    let e = enter[k];
                    let mut j = n;
                    while j > 0 && hits[j - 1].0 > e {
                        hits[j] = hits[j - 1];
                        j -= 1;
                    }
                    hits[j] = (e, k);
                    n += 1;
                }
                for &(e, k) in hits[1..n].iter().rev() {
                    waiting.push((pack(node.start[k], node.count[k]), e));
                }
                let k = hits[0].1;
                (start, count) = (node.start[k], node.count[k]);
                continue;
            }
        } else if let Some(t) = test(start, count, t_max) {
            t_max = t_max.min(t);
            if t_max <= t_min {
                return t_max;
            }
        }
        // The nearest waiting child the ray still reaches before its nearest hit.
        loop {
            let Some((slot, e)) = waiting.pop() else {
                return t_max;
            };
            if e <= t_max {
                (start, count) = unpack(slot);
                break;
            }
        }
    }
}

/// A child slot as one word, for the traversal's stack: its `start` shifted past three bits
/// that hold its `count` (0 to [`LEAF_SIZE`]).
type Packed = u32;

/// Primitives (and nodes) a tree may have: their indices fit a [`Packed`] beside a count.
/// `--max-triangles` and `--max-trees` cannot go above it.
pub const MAX_PRIMITIVES: usize = (1 << 29) - 1;

fn pack(start: u32, count: u32) -> Packed {
    start << 3 | count
}

fn unpack(p: Packed) -> (u32, u32) {
    (p >> 3, p & 7)
}

/// Children waiting in a traversal, with where the ray enters them: (slot, enter). A small
/// array on the stack (no allocation, little to initialise: it is set up once per walk, and a
/// ray walks a model's tree for every tree it passes); the rare deeper entries (three per
/// level) spill to the heap.
struct Waiting {
    near: [(Packed, f32); STACK],
    len: usize,
    spill: Vec<(Packed, f32)>,
}

impl Waiting {
    fn new() -> Waiting {
        Waiting {
            near: [(0, 0.0); STACK],
            len: 0,
            spill: Vec::new(),
        }
    }

    fn push(&mut self, entry: (Packed, f32)) {
        if self.len < STACK {
            self.near[self.len] = entry;
            self.len += 1;
        } else {
            self.spill.push(entry);
        }
    }

    fn pop(&mut self) -> Option<(Packed, f32)> {
        if let Some(entry) = self.spill.pop() {
            return Some(entry);
        }
        self.len = self.len.checked_sub(1)?;
        Some(self.near[self.len])
    }
}

/// The binary SAH tree over `boxes` (node 0 the root, each inner node's two children side by
/// side) and the primitive order its leaves index.
fn build_binary(boxes: &[Aabb]) -> (Vec<Binary>, Vec<u32>) {
    let mut order: Vec<u32> = (0..boxes.len() as u32).collect();
    let centres: Vec<Vec3> = boxes.iter().map(Aabb::centre).collect();
    let bounds = boxes.iter().fold(Aabb::EMPTY, |b, x| b.union(*x));
    let nodes = subtree(boxes, &centres, &mut order, 0, bounds, 0);
    (nodes, order)
}

/// Primitives below which a subtree is built on the calling thread: the two halves of a larger
/// one are built side by side.
const PARALLEL_BUILD: usize = 4096;

/// The binary tree over `part`, the primitives at `offset..` of the whole order, whose bounds
/// are `bounds`, at `depth`: its nodes, its root first, inner nodes' children indexing the
/// returned nodes. Each split depends only on the primitives it splits, so the tree (and the
/// order) is the same whichever thread builds which half, and whatever the thread count.
fn subtree(
    boxes: &[Aabb],
    centres: &[Vec3],
    part: &mut [u32],
    offset: usize,
    bounds: Aabb,
    depth: u32,
) -> Vec<Binary> {
    let count = part.len();
    if count <= LEAF_SIZE {
        return vec![Binary {
            bounds,
            start: offset as u32,
            count: count as u32,
        }];
    }
    // Where no plane beats a leaf (centres that coincide) the median still splits: every
    // leaf holds at most LEAF_SIZE primitives, which callers' packets rely on.
    let sah = if depth < SAH_DEPTH {
        split(boxes, centres, part)
    } else {
        None
    };
    let mid = sah.unwrap_or_else(|| median(centres, part));
    let (low, high) = part.split_at_mut(mid);
    let bounds_of = |p: &[u32]| {
        p.iter()
            .fold(Aabb::EMPTY, |b, &i| b.union(boxes[i as usize]))
    };
    let (low_bounds, high_bounds) = (bounds_of(low), bounds_of(high));
    let mut build_low = || subtree(boxes, centres, low, offset, low_bounds, depth + 1);
    let mut build_high = || subtree(boxes, centres, high, offset + mid, high_bounds, depth + 1);
    let (low, high) = if count >= PARALLEL_BUILD {
        rayon::join(build_low, build_high)
    } else {
        (build_low(), build_high())
    };
    // Laid out as the root, its two children, then the rest of each child's subtree: a node
    // at index j > 0 of the low subtree moves to j + 2, of the high one to j + low.len() + 1.
    let mut nodes = Vec::with_capacity(1 + low.len() + high.len());
    nodes.push(Binary {
        bounds,
        start: 1,
        count: 0,
    });
    let place = |mut node: Binary, shift: u32| {
        if node.count == 0 {
            node.start += shift;
        }
        node
    };
    let (low_shift, high_shift) = (2, low.len() as u32 + 1);
    nodes.push(place(low[0], low_shift));
    nodes.push(place(high[0], high_shift));
    nodes.extend(low[1..].iter().map(|&n| place(n, low_shift)));
    nodes.extend(high[1..].iter().map(|&n| place(n, high_shift)));
    nodes
}

/// Fills the wide tree from the binary one: each wide node takes a binary node's two children
/// and keeps opening the inner child with the largest surface area until it has four.
fn collapse(binary: &[Binary], wide: &mut Vec<Wide>) {
    let root = binary[0];
    let mut todo = vec![(0usize, 0usize)];
    if root.count > 0 {
        wide[0].set(0, root.bounds, root.start, root.count);
        return;
    }
    while let Some((b, w)) = todo.pop() {
        let first = binary[b].start as usize;
        let mut kids = vec![first, first + 1];
        while kids.len() < WIDTH {
            let widest = kids
                .iter()
                .enumerate()
                .filter(|&(_, &k)| binary[k].count == 0)
                .max_by(|a, b| {
                    let area = |k: usize| binary[k].bounds.surface_area();
                    area(*a.1).total_cmp(&area(*b.1))
                })
                .map(|(pos, _)| pos);
            let Some(pos) = widest else { break };
            let k = kids.remove(pos);
            let first = binary[k].start as usize;
            kids.extend([first, first + 1]);
        }
        for (slot, &k) in kids.iter().enumerate() {
            let node = binary[k];
            if node.count > 0 {
                wide[w].set(slot, node.bounds, node.start, node.count);
            } else {
                let child = wide.len();
                wide.push(Wide::UNUSED);
                wide[w].set(slot, node.bounds, child as u32, 0);
                todo.push((k, child));
            }
        }
    }
}

/// Splits `order` at its middle along the widest axis of its centres (ties by index, so the
/// build stays deterministic).
fn median(centres: &[Vec3], order: &mut [u32]) -> usize {
    let cb = order
        .iter()
        .fold(Aabb::EMPTY, |b, &i| b.grow(centres[i as usize]));
    let axis = (cb.hi - cb.lo).max_position();
    order.sort_by(|&a, &b| {
        centres[a as usize][axis]
            .total_cmp(&centres[b as usize][axis])
            .then(a.cmp(&b))
    });
    order.len() / 2
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

    fn random_triangles(seed: u64, n: usize, size: f32) -> Vec<[Vec3; 3]> {
        let mut s = Stream::new(seed, 0);
        let mut r = || s.range(-10.0, 10.0) as f32;
        (0..n)
            .map(|_| {
                let c = Vec3::new(r(), r(), r());
                [
                    c,
                    c + Vec3::new(r(), r(), r()) * size,
                    c + Vec3::new(r(), r(), r()) * size,
                ]
            })
            .collect()
    }

    /// `n` rays from points and in directions spread over the triangles' cube.
    fn random_rays(seed: u64, n: usize) -> Vec<Ray> {
        let mut s = Stream::new(seed, 0);
        let mut r = || s.range(-10.0, 10.0) as f32;
        (0..n)
            .map(|_| Ray {
                origin: Vec3::new(r(), r(), r()),
                dir: Vec3::new(r(), r(), r()).normalize(),
            })
            .collect()
    }

    fn brute(tris: &[[Vec3; 3]], ray: &Ray) -> f32 {
        tris.iter()
            .filter_map(|t| intersect_triangle(ray, *t, 0.0, f32::INFINITY))
            .map(|h| h.t)
            .fold(f32::INFINITY, f32::min)
    }

    fn nearest(bvh: &Bvh, tris: &[[Vec3; 3]], ray: &Ray) -> f32 {
        bvh.traverse(ray, 0.0, f32::INFINITY, |i, tmax| {
            intersect_triangle(ray, tris[i as usize], 0.0, tmax).map(|h| h.t)
        })
    }

    #[test]
    fn nearest_hit_matches_brute_force() {
        let tris = random_triangles(5, 500, 0.1);
        let boxes: Vec<Aabb> = tris.iter().map(|t| Aabb::of_points(t)).collect();
        let bvh = Bvh::build(&boxes);
        for ray in random_rays(6, 2000) {
            assert_eq!(brute(&tris, &ray), nearest(&bvh, &tris, &ray));
        }
    }

    /// Rays along the axes (infinite reciprocals), from on a box's plane, and an empty tree,
    /// a tree of one primitive and one of a few.
    #[test]
    fn axis_rays_and_small_trees_match_brute_force() {
        for n in [0, 1, 3, 5, 17, 300] {
            let tris = random_triangles(n as u64, n, 0.5);
            let boxes: Vec<Aabb> = tris.iter().map(|t| Aabb::of_points(t)).collect();
            let bvh = Bvh::build(&boxes);
            for (k, t) in tris.iter().enumerate().take(50) {
                for axis in 0..3 {
                    for sign in [-1.0f32, 1.0] {
                        let mut dir = Vec3::ZERO;
                        dir[axis] = sign;
                        let c = (t[0] + t[1] + t[2]) / 3.0;
                        let ray = Ray {
                            origin: c - dir * 20.0,
                            dir,
                        };
                        assert_eq!(brute(&tris, &ray), nearest(&bvh, &tris, &ray), "{n} {k}");
                        // Starting exactly on the plane of a corner's box.
                        let ray = Ray {
                            origin: Vec3::new(t[0].x, c.y, c.z) - dir * 20.0,
                            dir,
                        };
                        assert_eq!(brute(&tris, &ray), nearest(&bvh, &tris, &ray));
                    }
                }
            }
        }
    }

    /// Numbered leaves: the same hits as brute force, and every primitive in one leaf.
    #[test]
    fn numbered_leaves_match_brute_force() {
        let tris = random_triangles(11, 400, 0.3);
        let boxes: Vec<Aabb> = tris.iter().map(|t| Aabb::of_points(t)).collect();
        let (numbered, leaves) = Bvh::build(&boxes).into_numbered_leaves();
        let mut all: Vec<u32> = leaves.iter().flatten().copied().collect();
        all.sort();
        assert_eq!(all, (0..tris.len() as u32).collect::<Vec<_>>());
        for ray in random_rays(12, 2000) {
            let expected = brute(&tris, &ray);
            let by_leaf = numbered.traverse(&ray, 0.0, f32::INFINITY, |leaf, count, t_max| {
                assert_eq!(count as usize, leaves[leaf as usize].len());
                leaves[leaf as usize]
                    .iter()
                    .filter_map(|&i| intersect_triangle(&ray, tris[i as usize], 0.0, t_max))
                    .map(|h| h.t)
                    .reduce(f32::min)
            });
            assert_eq!(expected, by_leaf);
        }
    }

    /// Past the array, waiting children spill to the heap and still come back last in,
    /// first out, each once.
    #[test]
    fn waiting_children_come_back_in_order_past_the_array() {
        let mut w = Waiting::new();
        let n = 3 * STACK as u32;
        for i in 0..n {
            w.push((pack(i, 1), i as f32));
        }
        for i in (0..n).rev() {
            assert_eq!(w.pop(), Some((pack(i, 1), i as f32)));
            assert_eq!(unpack(pack(i, 4)), (i, 4));
        }
        assert_eq!(w.pop(), None);
    }

    /// Primitives spaced so the surface-area splits cut one off at a time: the tree's depth
    /// is bounded by the median rule, so traversal finds every hit.
    #[test]
    fn a_degenerate_distribution_keeps_a_bounded_depth() {
        let tris: Vec<[Vec3; 3]> = (0..4000)
            .map(|i| {
                let x = 1.001f32.powi(i * 4);
                let c = Vec3::new(x, 0.0, 0.0);
                [c, c + Vec3::Y * 0.5, c + Vec3::Z * 0.5]
            })
            .collect();
        let boxes: Vec<Aabb> = tris.iter().map(|t| Aabb::of_points(t)).collect();
        let bvh = Bvh::build(&boxes);
        for t in tris.iter().step_by(37) {
            let ray = Ray {
                origin: t[0] + Vec3::new(0.0, 0.1, -5.0),
                dir: Vec3::Z,
            };
            assert_eq!(brute(&tris, &ray), nearest(&bvh, &tris, &ray));
        }
        let leaves: u32 = bvh
            .nodes
            .iter()
            .flat_map(|n| n.used().map(|k| n.count[k]))
            .sum();
        assert_eq!(
            leaves as usize,
            tris.len(),
            "every primitive in exactly one leaf"
        );
    }
}
