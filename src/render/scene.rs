//! What the renderer draws, in its own frame (world minus the eye, f32): the trees as
//! instances of textures, the terrain as triangles, the sun and the shading constants.

use std::sync::OnceLock;

use glam::{DVec3, Vec3};

use crate::geom::{
    Aabb, Beam, Ray, TriangleBvh, TriangleHit, barycentric_point, intersect_triangle, offset_origin,
};
use crate::import::Mesh;
use crate::volume::{Occupancy, Texel};

use super::instances::{self, Instances, TreeTransform};
use super::lod::{Choices, Draw};
use super::sun_depth::SunDepth;

/// How a species looks on the rendered day.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Look {
    /// Index into [`Scene::texels`].
    pub texel: usize,
    /// Multiplies the foliage's extinction (the leaf fraction; 0 drops the foliage).
    pub foliage: f32,
    /// Linear albedo of the foliage on the day, replacing the baked one.
    pub foliage_albedo: Vec3,
}

/// A tree to draw: a texture at a place, turned about +Y and scaled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placed {
    pub look: u16,
    /// World position of the base of the trunk.
    pub position: DVec3,
    /// Rotation about +Y, radians.
    pub rotation: f32,
    pub scale: f32,
}

impl Placed {
    /// Tree `p` of a forest as the renderer draws it (its species is its look).
    pub fn of(p: &crate::formats::instances::Instance) -> Placed {
        Placed {
            look: p.species as u16,
            position: DVec3::from(p.position),
            rotation: p.rotation,
            scale: p.scale,
        }
    }

    /// The tree in the frame of a camera at `origin`, an instance of model `model`.
    pub fn transform(&self, model: u32, origin: DVec3) -> TreeTransform {
        let (sin, cos) = self.rotation.sin_cos();
        TreeTransform {
            look: self.look,
            model,
            position: (self.position - origin).as_vec3(),
            cos,
            sin,
            scale: self.scale,
        }
    }
}

/// The sun: a direction and an irradiance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sun {
    /// Unit vector towards the sun.
    pub direction: Vec3,
    /// Irradiance on a surface facing the sun. pi makes a white Lambertian surface facing the
    /// sun, unshadowed, exactly radiance 1.
    pub irradiance: f32,
}

impl Sun {
    /// From a compass azimuth (degrees clockwise from north, -Z) and an elevation above the
    /// horizon (degrees).
    pub fn from_angles(azimuth: f64, elevation: f64, irradiance: f32) -> Sun {
        let (a, e) = (azimuth.to_radians(), elevation.to_radians());
        let direction = DVec3::new(a.sin() * e.cos(), e.sin(), -a.cos() * e.cos())
            .normalize()
            .as_vec3();
        Sun {
            direction,
            irradiance,
        }
    }
}

/// The paper's shading constants (equation 3): S = albedo (I (kd cos theta + ks cos^n alpha)
/// + Ia kd).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shading {
    pub kd: f32,
    pub ks: f32,
    pub shininess: f32,
    /// Ia: radiance-scaled ambient (sky) light, in the units where a white surface lit by the
    /// sun head-on has radiance irradiance / pi.
    pub ambient: f32,
}

impl Default for Shading {
    fn default() -> Self {
        Shading {
            kd: 1.0,
            ks: 0.05,
            shininess: 10.0,
            ambient: 0.25,
        }
    }
}

/// The terrain surface in the renderer's frame.
pub struct Ground {
    pub triangles: TriangleBvh,
    pub mesh: Mesh,
    corners: Vec<[Vec3; 3]>,
    /// The triangles as rays towards the sun see them.
    sun_beam: Beam,
}

impl Ground {
    /// The terrain `mesh` in the frame of a camera at `origin`, lit from the unit direction
    /// `sun`.
    pub fn new(mesh: Mesh, origin: DVec3, sun: Vec3) -> Ground {
        let corners: Vec<[Vec3; 3]> = mesh
            .triangles
            .iter()
            .map(|t| {
                t.vertices
                    .map(|v| (mesh.positions[v as usize].as_dvec3() - origin).as_vec3())
            })
            .collect();
        let sun_beam = Beam::new(
            sun,
            corners.iter().enumerate().map(|(i, c)| (i as u32, &c[..])),
        );
        Ground {
            triangles: TriangleBvh::new(corners.clone()),
            mesh,
            corners,
            sun_beam,
        }
    }

    pub fn nearest(&self, ray: &Ray, t_max: f32) -> Option<(u32, TriangleHit)> {
        self.triangles.nearest(ray, 0.0, t_max, |_, _| true)
    }

    pub fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        if !self.sun_beam.carries(ray) {
            return self.triangles.occluded(ray, 0.0, t_max, |_, _| true);
        }
        let mut hit = false;
        self.sun_beam.visit(ray, t_max, |t, t_max| {
            hit = intersect_triangle(ray, self.corners[t as usize], 0.0, t_max).is_some();
            hit.then_some(0.0)
        });
        hit
    }

    /// Where a ray leaving the hit `hit` on triangle `t` (normal `n`) in direction `dir` may
    /// start: off the surface by its floating-point error bound, no further.
    pub fn leave(&self, t: u32, hit: &TriangleHit, n: Vec3, dir: Vec3) -> Vec3 {
        let (p, error) = barycentric_point(self.corners[t as usize], hit.w);
        offset_origin(p, error, n, dir)
    }

    /// Geometric normal of triangle `t`, facing the side `towards` comes from.
    pub fn normal(&self, t: u32, towards: Vec3) -> Vec3 {
        let [a, b, c] = self.corners[t as usize];
        let n = (b - a).cross(c - a).normalize_or(Vec3::Y);
        if n.dot(towards) < 0.0 { n } else { -n }
    }
}

/// The light and how surfaces answer it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lighting {
    pub sun: Sun,
    pub shading: Shading,
    /// Sky radiance behind everything; `None` leaves the sky transparent.
    pub sky: Option<Vec3>,
}

pub struct Scene {
    /// World position of the renderer frame's origin (the eye).
    pub origin: DVec3,
    pub texels: Vec<Texel>,
    /// Per texel and level, which bricks can hold density: marches jump over the rest.
    pub occupancy: Vec<Vec<Occupancy>>,
    pub looks: Vec<Look>,
    /// The trees, each an instance of its look's texel (whose grid box, the union over
    /// levels, is the instance's model box).
    pub instances: Instances,
    /// The instances as shadow rays see them: along the sun's direction.
    pub sun_beam: instances::Beam,
    /// Per texel, the polygon model it was baked from, for the mesh method (else empty).
    pub meshes: Vec<TreeMesh>,
    pub ground: Option<Ground>,
    pub sun: Sun,
    pub shading: Shading,
    /// Sky radiance behind everything; `None` leaves the sky transparent.
    pub sky: Option<Vec3>,
    /// Whether anything shadows the sun. Off, every surface and sample is lit as if nothing
    /// stood between it and the sun, so shading can be measured apart from shadows.
    pub shadows: bool,
    /// The trees' optical depth towards the sun, per level, built as shadow rays need it.
    pub sun_depth: SunDepth,
    /// How the frame's hybrid drawing draws each tree, worked out once ([`Scene::choose`]).
    pub(super) choices: OnceLock<Choices>,
}

impl Scene {
    pub fn new(
        origin: DVec3,
        texels: Vec<Texel>,
        looks: Vec<Look>,
        placed: &[Placed],
        ground: Option<Mesh>,
        lighting: Lighting,
    ) -> Scene {
        let Lighting { sun, shading, sky } = lighting;
        let model_boxes: Vec<Aabb> = texels
            .iter()
            .map(|t| {
                let (lo, hi) = t.grid_box();
                Aabb {
                    lo: lo.as_vec3(),
                    hi: hi.as_vec3(),
                }
            })
            .collect();
        let instances: Vec<TreeTransform> = placed
            .iter()
            .map(|p| p.transform(looks[p.look as usize].texel as u32, origin))
            .collect();
        // The terrain's hierarchy and the trees' are built side by side: each alone is the
        // same whichever thread builds it, and a frame of a sequence builds both anew.
        let (ground, (occupancy, instances, sun_beam)) = rayon::join(
            || ground.map(|m| Ground::new(m, origin, sun.direction)),
            || {
                let occupancy: Vec<Vec<Occupancy>> = texels
                    .iter()
                    .map(|t| t.levels.iter().map(Occupancy::of).collect())
                    .collect();
                let cells: Vec<f32> = texels.iter().map(|t| t.levels[0].cell as f32).collect();
                let instances = Instances::new(instances, model_boxes, &cells);
                let sun_beam = instances::Beam::new(&instances, sun.direction);
                (occupancy, instances, sun_beam)
            },
        );
        let sun_depth = SunDepth::new(&instances, &looks, &texels);
        Scene {
            origin,
            texels,
            occupancy,
            looks,
            sun_beam,
            instances,
            meshes: Vec::new(),
            ground,
            sun,
            shading,
            sky,
            shadows: true,
            sun_depth,
            choices: OnceLock::new(),
        }
    }

    /// Works out once how `draw` draws each tree, for every ray of the frame that draws as it
    /// does (a frame's samples share their footprint and their band's key): a lookup then,
    /// where each ray would work out the choice for every tree it meets. The first drawing
    /// given is kept; any other is worked out ray by ray.
    pub fn choose(&self, draw: &Draw) {
        if self.choices.get().is_none()
            && let Some(c) = Choices::of(draw, self)
        {
            // Another thread choosing at once would set the same.
            let _ = self.choices.set(c);
        }
    }

    /// Takes `grids`, the sun-depth grids another scene of the same forest, textures and sun
    /// built (an earlier frame of a sequence, whatever its eye), instead of building them
    /// again: they are in the trees' model space and the same bits whoever builds them.
    pub fn reuse_sun_depth(&mut self, grids: SunDepth) {
        assert!(
            grids.fits(&self.instances, &self.looks),
            "sun-depth grids of another forest"
        );
        self.sun_depth = grids;
    }

    /// The texture instance `i` is drawn from.
    #[inline]
    pub fn texel_of(&self, i: u32) -> &Texel {
        &self.texels[self.looks[self.instances.get(i).look as usize].texel]
    }

    /// The scene drawn from the polygon models the texels were baked from: `meshes[k]` is
    /// the model of `texels[k]`, in the same model space.
    pub fn with_meshes(self, meshes: Vec<TreeMesh>) -> Scene {
        assert_eq!(meshes.len(), self.texels.len(), "one mesh per texel");
        Scene { meshes, ..self }
    }
}

/// A tree model ready for tracing, in its model space (that of the texel baked from it).
#[derive(Clone, Debug)]
pub struct TreeMesh {
    pub mesh: Mesh,
    pub(super) triangles: TriangleBvh,
    /// Per triangle: part of the foliage (recoloured by season, thinned by leaf fraction).
    pub(super) foliage: Vec<bool>,
}

impl TreeMesh {
    pub fn new(mesh: Mesh, foliage: Vec<bool>) -> TreeMesh {
        let corners = mesh.corners();
        TreeMesh {
            triangles: TriangleBvh::new(corners),
            mesh,
            foliage,
        }
    }

    /// Triangle `t`'s corners in model space.
    pub(super) fn corners(&self, t: u32) -> [Vec3; 3] {
        self.mesh.triangles[t as usize]
            .vertices
            .map(|v| self.mesh.positions[v as usize])
    }

    pub(super) fn normal(&self, t: u32) -> Vec3 {
        let [a, b, c] = self.corners(t);
        (b - a).cross(c - a).normalize_or(Vec3::Y)
    }
}
