//! The forest as the renderer queries it: every tree an instance of one model (a texture's
//! grid box, or the polygon model it was baked from), turned about +Y, scaled and placed, all
//! under one bounding volume hierarchy. Every query hands its caller each instance it meets
//! with the ray carried into that instance's model space, as pbrt's `TransformedPrimitive`
//! does, so no caller transforms rays itself:
//!
//! - [`Instances::visit`]: every instance the ray meets, in no particular order (shadow rays:
//!   optical depth is a sum; any-hit and nearest-hit queries);
//! - [`Instances::nearest`]: the closest hit;
//! - [`Instances::intervals`]: the instances' intervals along the ray, front to back, as the
//!   ray advances (view rays through overlapping volumes);
//! - [`Beam::visit`] and [`Beam::any`]: [`Instances::visit`], and whether there is a hit, for
//!   rays along one direction fixed for the frame (the sun's), from a grid across it instead
//!   of the hierarchy.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use glam::Vec3;

use crate::geom::{Aabb, Bvh, NodeContent, Ray, SlabRay, box_corners, gamma};

/// A placed tree in the renderer's frame.
#[derive(Clone, Copy, Debug)]
pub struct TreeTransform {
    /// Index into the scene's looks (species on the day).
    pub look: u16,
    /// Index into [`Instances`]' model boxes.
    pub model: u32,
    pub position: Vec3,
    pub cos: f32,
    pub sin: f32,
    pub scale: f32,
}

impl TreeTransform {
    /// Model-space point of a renderer-frame point.
    #[inline]
    pub fn to_model(&self, p: Vec3) -> Vec3 {
        let d = (p - self.position) / self.scale;
        // Inverse of a rotation by `angle` about +Y.
        Vec3::new(
            self.cos * d.x - self.sin * d.z,
            d.y,
            self.sin * d.x + self.cos * d.z,
        )
    }

    /// Model-space direction of a renderer-frame direction (length divided by the scale, so a
    /// distance along the local ray is the same `t` as along the world ray).
    #[inline]
    pub fn dir_to_model(&self, d: Vec3) -> Vec3 {
        let d = d / self.scale;
        Vec3::new(
            self.cos * d.x - self.sin * d.z,
            d.y,
            self.sin * d.x + self.cos * d.z,
        )
    }

    /// Renderer-frame direction of a model-space direction (rotation only).
    #[inline]
    pub fn dir_to_world(&self, d: Vec3) -> Vec3 {
        Vec3::new(
            self.cos * d.x + self.sin * d.z,
            d.y,
            -self.sin * d.x + self.cos * d.z,
        )
    }

    /// The renderer-frame point of model-space point `p` (error bound `error`), and a bound
    /// on its error that also covers the way back: a ray leaving the point is carried into
    /// this instance's model space again to meet its own surface, so both trips' rounding
    /// (a few operations each, on magnitudes up to the position's) count. See
    /// [`crate::geom::offset_origin`].
    pub fn point_to_world(&self, p: Vec3, error: Vec3) -> (Vec3, Vec3) {
        let world = self.position + self.dir_to_world(p * self.scale);
        let (c, s) = (self.cos.abs(), self.sin.abs());
        let turned = |v: Vec3| Vec3::new(c * v.x + s * v.z, v.y, s * v.x + c * v.z);
        let magnitude = self.position.abs() + turned(p.abs() * self.scale) + world.abs();
        let error = turned(error * self.scale) * (1.0 + gamma(5)) + magnitude * (2.0 * gamma(5));
        (world, error)
    }

    /// [`TreeTransform::point_to_world`] (without its error bound) as a matrix: the turn about
    /// +Y, the scale and the position, for files that place the model as the renderer does
    /// (`texel export`).
    pub fn world_from_model(&self) -> glam::DMat4 {
        let axis = |a: Vec3| (self.dir_to_world(a) * self.scale).as_dvec3().extend(0.0);
        glam::DMat4::from_cols(
            axis(Vec3::X),
            axis(Vec3::Y),
            axis(Vec3::Z),
            self.position.as_dvec3().extend(1.0),
        )
    }

    /// `ray` in the instance's model space, with the same parameter `t`.
    #[inline]
    pub fn local_ray(&self, ray: &Ray) -> Ray {
        Ray {
            origin: self.to_model(ray.origin),
            dir: self.dir_to_model(ray.dir),
        }
    }
}

/// Every instance, its model's box, and the hierarchy over their world boxes.
#[derive(Clone, Debug)]
pub struct Instances {
    list: Vec<TreeTransform>,
    /// Per model: its box in model space.
    model_boxes: Vec<Aabb>,
    /// Per model: its box's centre and its finest cell (m), which pick how the hybrid method
    /// draws an instance.
    model_lod: Vec<(Vec3, f32)>,
    /// Over all instances: the largest finest cell (m) and the largest distance from a box's
    /// centre to its corners (m), which bound how far from the eye the hybrid method can draw
    /// any tree as a model.
    largest: (f32, f32),
    /// The distance from the eye (the frame's origin) to the nearest instance's box.
    nearest: f32,
    /// The least angle any instance's finest cell subtends at the eye from its box's centre
    /// (the cell over the centre's distance): a footprint below it is finer than every tree's
    /// cells.
    finest_angle: f32,
    bvh: Bvh,
}

impl Instances {
    /// `list`'s instances of models whose model-space boxes are `model_boxes` and whose
    /// finest texture cells are `model_cells` (m).
    pub fn new(list: Vec<TreeTransform>, model_boxes: Vec<Aabb>, model_cells: &[f32]) -> Instances {
        let boxes: Vec<Aabb> = list
            .iter()
            .map(|i| Self::world_box(i, model_boxes[i.model as usize]))
            .collect();
        let model_lod = model_boxes
            .iter()
            .zip(model_cells)
            .map(|(b, &cell)| (b.centre(), cell))
            .collect::<Vec<_>>();
        let largest = list.iter().fold((0.0f32, 0.0f32), |(cell, radius), i| {
            let m = i.model as usize;
            let b = model_boxes[m];
            (
                cell.max(model_cells[m] * i.scale),
                radius.max((b.hi - b.lo).length() * 0.5 * i.scale),
            )
        });
        // Each box's point nearest the origin, the eye.
        let nearest = boxes
            .iter()
            .map(|b| Vec3::ZERO.max(b.lo).min(b.hi).length())
            .fold(f32::INFINITY, f32::min);
        let finest_angle = list
            .iter()
            .map(|i| {
                let (centre, cell) = model_lod[i.model as usize];
                let centre = i.position + i.dir_to_world(centre) * i.scale;
                cell * i.scale / centre.length()
            })
            .fold(f32::INFINITY, f32::min);
        Instances {
            nearest,
            finest_angle,
            bvh: Bvh::build(&boxes),
            list,
            model_boxes,
            model_lod,
            largest,
        }
    }

    /// The largest finest cell of any instance (m), and the largest distance from an
    /// instance's box centre to its corners (m).
    pub fn largest(&self) -> (f32, f32) {
        self.largest
    }

    /// The corners of instance `i`'s model box, placed in the world.
    fn world_corners(i: &TreeTransform, b: Aabb) -> [Vec3; 8] {
        box_corners(b.lo.to_array(), b.hi.to_array())
            .map(|m| i.position + i.dir_to_world(Vec3::from(m)) * i.scale)
    }

    fn world_box(i: &TreeTransform, b: Aabb) -> Aabb {
        Aabb::of_points(&Self::world_corners(i, b))
    }

    /// The distance from the eye (the frame's origin) to the nearest point of any instance's
    /// box; infinite where there are none.
    pub fn nearest_distance(&self) -> f32 {
        self.nearest
    }

    /// The least angle (radians) any instance's finest cell subtends at the eye, seen from
    /// the centre of its box ([`Instances::centre_and_cell`]).
    pub fn finest_angle(&self) -> f32 {
        self.finest_angle
    }

    #[inline]
    pub fn get(&self, i: u32) -> &TreeTransform {
        &self.list[i as usize]
    }

    pub fn len(&self) -> usize {
        self.list.len()
    }

    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// The finest texture cell of model `model`, in its own units.
    #[inline]
    pub fn finest_cell(&self, model: u32) -> f32 {
        self.model_lod[model as usize].1
    }

    /// The centre of instance `i`'s model box, placed in the world, and the size of its
    /// model's finest texture cell there (m).
    #[inline]
    pub fn centre_and_cell(&self, i: u32) -> (Vec3, f32) {
        let inst = self.get(i);
        let (centre, cell) = self.model_lod[inst.model as usize];
        (
            inst.position + inst.dir_to_world(centre) * inst.scale,
            cell * inst.scale,
        )
    }

    /// The part of `ray` inside instance `i`'s model box, before `t_max`.
    pub fn interval(&self, i: u32, ray: &Ray, t_max: f32) -> Option<(f32, f32)> {
        self.local_interval(i, &self.get(i).local_ray(ray), t_max)
    }

    /// [`Instances::interval`] of a ray already carried into instance `i`'s model space.
    pub fn local_interval(&self, i: u32, local: &Ray, t_max: f32) -> Option<(f32, f32)> {
        let model = self.get(i).model as usize;
        self.model_boxes[model].intersect(local, local.dir.recip(), 0.0, t_max)
    }

    /// Calls `f(i, local ray, t_max)` for every instance whose world box `ray` meets before
    /// `t_max`, in no particular order. `f` returns `Some(t)` to shorten the ray to `t` (a hit
    /// nearer than any so far; `Some(0.0)` ends the traversal), `None` to go on.
    pub fn visit(&self, ray: &Ray, t_max: f32, mut f: impl FnMut(u32, &Ray, f32) -> Option<f32>) {
        self.bvh.traverse(ray, 0.0, t_max, |i, t_max| {
            f(i, &self.get(i).local_ray(ray), t_max)
        });
    }

    /// The nearest hit along `ray` before `t_max`: `hit(i, local ray, t_max)` gives an
    /// instance's nearest hit before `t_max`, as its distance and what the caller keeps of it.
    pub fn nearest<H>(
        &self,
        ray: &Ray,
        t_max: f32,
        mut hit: impl FnMut(u32, &Ray, f32) -> Option<(f32, H)>,
    ) -> Option<(u32, H)> {
        let mut best = None;
        self.visit(ray, t_max, |i, local, t_max| {
            let (t, h) = hit(i, local, t_max)?;
            best = Some((i, h));
            Some(t)
        });
        best
    }

    /// The instances' intervals along `ray` before `t_max`, front to back, opened lazily as the
    /// ray advances.
    pub fn intervals(&self, ray: Ray, t_max: f32) -> Intervals<'_> {
        let inv = ray.dir.recip();
        let mut heap = BinaryHeap::new();
        if !self.is_empty()
            && let Some((enter, _)) = self.bvh.bounds().intersect(&ray, inv, 0.0, t_max)
        {
            heap.push(Reverse((order_key(enter), Item::Node(0))));
        }
        Intervals {
            instances: self,
            ray,
            slab: SlabRay::new(&ray),
            t_max,
            heap,
        }
    }
}

/// The instances as rays along one direction see them (the sun's: every shadow ray of a
/// frame): a [`crate::geom::Beam`] of their world boxes.
#[derive(Clone, Debug)]
pub struct Beam(crate::geom::Beam);

impl Beam {
    /// The beam of `instances` along the unit direction `w`.
    pub fn new(instances: &Instances, w: Vec3) -> Beam {
        let corners: Vec<[Vec3; 8]> = instances
            .list
            .iter()
            .map(|i| Instances::world_corners(i, instances.model_boxes[i.model as usize]))
            .collect();
        Beam(crate::geom::Beam::new(
            w,
            corners.iter().enumerate().map(|(i, c)| (i as u32, &c[..])),
        ))
    }

    /// [`Instances::visit`] for a ray along the beam's direction (any other goes through the
    /// hierarchy): the same instances, in another order.
    pub fn visit(
        &self,
        instances: &Instances,
        ray: &Ray,
        t_max: f32,
        mut f: impl FnMut(u32, &Ray, f32) -> Option<f32>,
    ) {
        if !self.0.carries(ray) {
            return instances.visit(ray, t_max, f);
        }
        self.0.visit(ray, t_max, |i, t_max| {
            f(i, &instances.get(i).local_ray(ray), t_max)
        });
    }

    /// Whether `ray` runs along the beam's direction.
    pub fn carries(&self, ray: &Ray) -> bool {
        self.0.carries(ray)
    }

    /// Calls `f(i)` for every instance whose world box `ray` may meet, `ray` running along
    /// the beam's direction ([`Beam::carries`]) to infinity, until `f` returns false.
    pub fn visit_along(&self, ray: &Ray, mut f: impl FnMut(u32) -> bool) {
        debug_assert!(self.carries(ray));
        self.0.visit(
            ray,
            f32::INFINITY,
            |i, _| if f(i) { None } else { Some(0.0) },
        );
    }

    /// Whether any instance has a hit before `t_max` (`hit(i, local ray, t_max)`): a shadow
    /// ray's any-hit query.
    pub fn any(
        &self,
        instances: &Instances,
        ray: &Ray,
        t_max: f32,
        mut hit: impl FnMut(u32, &Ray, f32) -> bool,
    ) -> bool {
        let mut found = false;
        self.visit(instances, ray, t_max, |i, local, t_max| {
            found = hit(i, local, t_max);
            found.then_some(0.0)
        });
        found
    }
}

/// f32 >= 0 as an integer with the same order.
fn order_key(t: f32) -> u32 {
    t.max(0.0).to_bits()
}

#[derive(Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Item {
    Node(u32),
    /// An instance, and its exit as ordered bits.
    Instance(u32, u32),
}

/// Instances along one ray in order of entry: nodes of the hierarchy and instances' boxes
/// wait in a heap keyed by where the ray enters them.
pub struct Intervals<'a> {
    instances: &'a Instances,
    ray: Ray,
    slab: SlabRay,
    t_max: f32,
    heap: BinaryHeap<Reverse<(u32, Item)>>,
}

impl Intervals<'_> {
    /// Where the ray enters the next node or instance not yet handed out, if any.
    pub fn next_entry(&self) -> Option<f32> {
        self.heap.peek().map(|Reverse((t, _))| f32::from_bits(*t))
    }

    /// The next instance the ray has entered by `t`, as (instance, enter, exit); `None` when
    /// every instance entered by `t` has been handed out.
    pub fn next_entered(&mut self, t: f32) -> Option<(u32, f32, f32)> {
        while let Some(&Reverse((enter, item))) = self.heap.peek() {
            if f32::from_bits(enter) > t {
                return None;
            }
            self.heap.pop();
            match item {
                Item::Instance(i, exit) => {
                    return Some((i, f32::from_bits(enter), f32::from_bits(exit)));
                }
                Item::Node(n) => self.open(n),
            }
        }
        None
    }

    /// Queues the children of node `n` that the ray enters: inner nodes, and the intervals of
    /// the instances of leaves.
    fn open(&mut self, n: u32) {
        let bvh = &self.instances.bvh;
        for (e, content) in bvh.entered(n, &self.slab, self.t_max) {
            match content {
                NodeContent::Inner(child) => {
                    self.heap.push(Reverse((order_key(e), Item::Node(child))));
                }
                NodeContent::Leaf(items) => {
                    for &i in items {
                        if let Some((e, x)) = self.instances.interval(i, &self.ray, self.t_max) {
                            self.heap
                                .push(Reverse((order_key(e), Item::Instance(i, order_key(x)))));
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Stream;

    /// A forest of 400 scattered, turned, scaled trees of two models, some overlapping.
    fn scattered_forest(u: &mut impl FnMut() -> f32) -> Instances {
        let list: Vec<TreeTransform> = (0..400)
            .map(|k| {
                let angle = u() * std::f32::consts::TAU;
                TreeTransform {
                    look: 0,
                    model: k % 2,
                    position: Vec3::new(u() * 200.0 - 100.0, u() * 20.0, u() * 200.0 - 100.0),
                    cos: angle.cos(),
                    sin: angle.sin(),
                    scale: 0.5 + u() * 1.5,
                }
            })
            .collect();
        let boxes = vec![
            Aabb {
                lo: Vec3::new(-3.0, 0.0, -3.0),
                hi: Vec3::new(3.0, 12.0, 3.0),
            },
            Aabb {
                lo: Vec3::new(-1.0, 0.0, -2.0),
                hi: Vec3::new(4.0, 6.0, 1.0),
            },
        ];
        Instances::new(list, boxes, &[1.0, 1.0])
    }

    /// A beam hands a ray along its direction exactly the instances the hierarchy does, from
    /// anywhere (inside the forest, above it, beside it).
    #[test]
    fn a_beam_meets_what_the_hierarchy_meets() {
        let mut s = Stream::new(5, 0);
        let mut u = || s.unit() as f32;
        let instances = scattered_forest(&mut u);
        let w = Vec3::new(0.4, 0.7, -0.3).normalize();
        let beam = Beam::new(&instances, w);
        let mut met = 0;
        for _ in 0..3000 {
            let ray = Ray {
                origin: Vec3::new(u() * 240.0 - 120.0, u() * 40.0 - 5.0, u() * 240.0 - 120.0),
                dir: w,
            };
            let t_max = if u() < 0.5 { f32::INFINITY } else { u() * 50.0 };
            type Visit<'a> = &'a dyn Fn(&mut dyn FnMut(u32));
            let hits = |visit: Visit| {
                let mut v = Vec::new();
                visit(&mut |i| v.push(i));
                v.sort_unstable();
                v
            };
            let by_tree = hits(&|out| {
                instances.visit(&ray, t_max, |i, _, _| {
                    if instances.interval(i, &ray, t_max).is_some() {
                        out(i);
                    }
                    None
                })
            });
            let by_beam = hits(&|out| {
                beam.visit(&instances, &ray, t_max, |i, _, _| {
                    if instances.interval(i, &ray, t_max).is_some() {
                        out(i);
                    }
                    None
                })
            });
            assert_eq!(by_tree, by_beam, "from {} to {t_max}", ray.origin);
            met += by_beam.len();
        }
        assert!(met > 1000, "the rays met {met} trees");
    }

    /// The front-to-back walk hands out every instance whose box the ray enters before
    /// `t_max`, each once, in order of entry, with the interval [`Instances::interval`] gives.
    #[test]
    fn intervals_come_front_to_back_as_brute_force_finds_them() {
        let mut s = Stream::new(6, 0);
        let mut u = || s.unit() as f32;
        let instances = scattered_forest(&mut u);
        let mut met = 0;
        for _ in 0..2000 {
            let ray = Ray {
                origin: Vec3::new(u() * 240.0 - 120.0, u() * 40.0 - 5.0, u() * 240.0 - 120.0),
                dir: Vec3::new(u() - 0.5, u() - 0.6, u() - 0.5).normalize(),
            };
            let t_max = if u() < 0.5 { f32::INFINITY } else { u() * 80.0 };
            let mut brute: Vec<(u32, f32, f32)> = (0..instances.len() as u32)
                .filter_map(|i| {
                    let (e, x) = instances.interval(i, &ray, t_max)?;
                    Some((i, e, x))
                })
                .collect();
            brute.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            let mut walked = Vec::new();
            let mut intervals = instances.intervals(ray, t_max);
            while let Some(t) = intervals.next_entry() {
                while let Some(found) = intervals.next_entered(t) {
                    walked.push(found);
                }
            }
            assert!(
                walked.windows(2).all(|w| w[0].1 <= w[1].1),
                "in order of entry"
            );
            walked.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
            assert_eq!(walked, brute, "from {} along {}", ray.origin, ray.dir);
            met += walked.len();
        }
        assert!(met > 1000, "the rays met {met} trees");
    }
}
